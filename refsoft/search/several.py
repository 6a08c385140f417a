"""Every image drawn on a mirror that is not convex (spec section 4.8): sheets, candidate virtual
triangles, and their exact per-pixel acceptance.

1. :func:`links` and :func:`sheets`: images of the two ends of an edge are linked when the walk
   for one vertex started at the other's image pixel ends at its image, both ways (mutual walks);
   linked images share a sheet (union-find, the smallest image index as root).
2. :func:`candidates`: each scene triangle gives one virtual triangle per triple of images of its
   vertices linked along its three edges; a triangle with a vertex without an image, or with no
   linked triple, is cut at its edge midpoints (whose images are found) and its parts are tried
   again, up to ``constants.SEVERAL_MAX_LEVEL``; a part still without a linked triple at the last
   level gives every triple (the acceptance below decides). Given the reflected rays of step 3, a
   triangle to be cut that no ray comes near (kernels ``rays_near_every``, ``rays_near``) gives no
   candidate and is not cut, with what the others do not depend on (``_Pool.needed``).
3. :func:`refsoft.search.acceptance.draw`: each candidate is rasterized conservatively
   (dilated) in the reflector's stencil; at each covered pixel the eye ray is reflected about the
   reflector's interpolated normal at its visible point (as the ray-traced truth does) and
   intersected with the candidate's *real* scene triangle; the nearest hit wins
   (:mod:`refsoft.search.acceptance`). The picture is the same bits as without the pruning.
4. :func:`with_ray_lists`: each scene triangle with a candidate is also drawn whole, met with every
   reflected ray that may hit it wherever its pixel (:func:`.reach.ray_lists`, through the ray tiles of
   :mod:`refsoft.search._raytiles`): where a virtual triangle misses its image by more than the
   dilation, or an image was not found, the triangle is still drawn where it reflects.

See ``docs/sheets.md``.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .. import constants
from .._parallel import parallel_range
from ..errors import RefsoftError
from . import search
from ._several import linked_triples, nearest_image
from .acceptance import Candidates, draw, pixel_rays
from .images import Images, facing_gbuffer, find_images
from .reach import Reach, ray_lists, take


# --- sheets -----------------------------------------------------------------------------------
def links(gb, eye, verts, images: Images, edges, neighbourhood="cross", cap=None) -> np.ndarray:
    """Mutually linked images across edges (spec section 4.8 sheets).

    Parameters
    ----------
    gb : GBuffer
    eye : (3,) float64
    verts : (N, 3) float64
        The vertices ``images`` holds images of.
    images : Images
    edges : (E, 2) int64
        Vertex index pairs.
    neighbourhood, cap
        The walk's options (:func:`refsoft.search.search`).

    Returns
    -------
    (L, 2) int64
        Image index pairs (i, j), ``i`` an image of the edge's first vertex, ``j`` of its second,
        sorted by (i, j).
    """
    off = np.asarray(images.offset, np.int64)
    return _links(gb, eye, verts, off[:-1], np.diff(off), images.pixel, edges, neighbourhood, cap)


def _links(gb, eye, verts, start, count, pixel, edges, neighbourhood, cap):
    """:func:`links` with vertex ``v``'s images at rows ``start[v] .. start[v] + count[v] - 1``
    of ``pixel`` (M, 2) int32 (in any order of the vertices)."""
    edges = np.asarray(edges, np.int64).reshape(-1, 2)
    if len(edges) == 0 or len(pixel) == 0:
        return np.zeros((0, 2), np.int64)
    start, count = np.ascontiguousarray(start, np.int64), np.ascontiguousarray(count, np.int64)
    pixel = np.ascontiguousarray(pixel)
    fwd = _walks(gb, eye, verts, start, count, pixel, edges, neighbourhood, cap)
    back = _walks(gb, eye, verts, start, count, pixel, edges[:, ::-1], neighbourhood, cap)
    back = back[:, ::-1]
    pairs = back[_member(back[:, 0] * _KEY + back[:, 1], _sorted_unique(fwd[:, 0] * _KEY + fwd[:, 1]))]
    return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))].reshape(-1, 2)


def _walks(gb, eye, verts, start, count, pixel, edges, neighbourhood, cap):
    """(i, j) pairs: the walk of edge end b started at image i of end a ends at b's image j."""
    a, b = edges[:, 0], edges[:, 1]
    i, rep, _ = _ranges(start[a], count[a])
    if len(rep) == 0:
        return np.zeros((0, 2), np.int64)
    target = b[rep]
    res = _walk(gb, eye, verts[target], pixel[i], neighbourhood, cap)
    # each walk's end against every image of its target: the nearest (Chebyshev, the first of
    # equals) within SEVERAL_LINK_TEXELS
    j = np.empty(len(i), np.int64)
    parallel_range(nearest_image, len(i), np.ascontiguousarray(res.pixel, np.int64), np.ascontiguousarray(target),
                   start, count, pixel, int(constants.SEVERAL_LINK_TEXELS), j)
    keep = j >= 0
    return np.stack([i[keep], j[keep]], axis=1).astype(np.int64).reshape(-1, 2)


def _walk(gb, eye, verts, starts, neighbourhood, cap):
    """The walks of ``verts`` from ``starts`` (M, 2): spec section 4.2's from the eye (3,), or a
    later level's with each pixel's own (``eye`` a :class:`refsoft.search.bounces.LevelEyes`)."""
    if hasattr(eye, "walk"):
        return eye.walk(verts, starts)
    return search(gb, eye, verts, neighbourhood, "plane", starts, cap)


def sheets(images: Images, pairs) -> Images:
    """``images`` with ``sheet``: connected components of the linked pairs, each labelled by its
    smallest image index (deterministic union-find by repeated minimum labels)."""
    label = np.arange(len(images.pixel), dtype=np.int64)
    pairs = np.asarray(pairs, np.int64).reshape(-1, 2)
    while len(pairs):
        low = np.minimum(label[pairs[:, 0]], label[pairs[:, 1]])
        new = label.copy()
        np.minimum.at(new, pairs[:, 0], low)
        np.minimum.at(new, pairs[:, 1], low)
        new = new[new]
        if np.array_equal(new, label):
            break
        label = new
    return replace(images, sheet=label.astype(np.int32))


# --- candidates -------------------------------------------------------------------------------
def candidates(gb, eye, verts, normals, faces, face_obj, images: Images, find, neighbourhood="cross", cap=None,
               max_level=None, rays=None):
    """Candidate virtual triangles of every scene triangle (module docstring, step 2).

    With ``rays`` (the reflector's reflected rays, those :func:`draw` tests), the candidates of a
    triangle (or part) no ray comes near (:class:`Reach`) are left out, and so are its parts:
    the acceptance would refuse them at every pixel, so the picture is the same bits. Only what
    the others' candidates depend on is still made: a triangle sharing a vertex with one a ray
    comes near is matched and cut (a part at the last level may take its rim triples from walks
    of its neighbours' images), and at the last level only the parts a ray comes near and those
    sharing with one of them not matched a corner without an image are kept; the images of
    midpoints are found for the corners of the parts kept alone (see ``docs/sheets.md``).

    Parameters
    ----------
    gb : GBuffer
    eye : (3,) float64, or LevelEyes
        The eye; at a later bounce (spec section 5.1) its
        :class:`refsoft.search.bounces.LevelEyes` (its walks with each pixel's own eye, and the
        view points of its pixels).
    verts, normals : (N, 3) float64
        The reflected vertices and their unit normals.
    faces : (F, 3) int64
    face_obj : (F,) int32
    images : Images
        Every image of ``verts``.
    find : callable
        ``find(points (K, 3) float64) -> Images``: every image of new points (midpoints).
    max_level : int, optional
        Subdivision levels (default ``constants.SEVERAL_MAX_LEVEL``).
    rays : tuple of two (R, 3) float64, optional
        Origins and directions of the reflected rays (:func:`pixel_rays`); None: every candidate.

    Returns
    -------
    Candidates, Images
        The candidates, and ``images`` with its sheets (from the links of the scene's edges).
    """
    max_level = constants.SEVERAL_MAX_LEVEL if max_level is None else int(max_level)
    if max_level < 0:
        raise RefsoftError(f"max_level must be >= 0, got {max_level}")
    verts = np.asarray(verts, np.float64)
    faces = np.asarray(faces, np.int64).reshape(-1, 3)
    pool = _Pool(verts, np.asarray(normals, np.float64), images)
    edges = _edges(faces)
    pairs = links(gb, eye, verts, images, edges, neighbourhood, cap)
    with_sheets = sheets(images, pairs)
    pool.add_links(pairs)
    pool.walked = _sorted_unique(edges[:, 0] * _KEY + edges[:, 1])
    out_t, out_f, out_s, out_r, subdivided = [], [], [], [], []
    todo_faces, todo_src = faces, np.arange(len(faces), dtype=np.int64)
    reach = None if rays is None else Reach(*rays)
    alive = span = None
    if reach is not None:
        # the scene triangles matched are neither cut nor tested (their candidates are few, each
        # tested at every pixel it covers); the others only if a ray comes near them
        t, owner = pool.triples(faces)
        rest = ~pool.matched(faces, t, owner)
        span = np.full(len(faces), -1, np.int64), np.full(len(faces), -1, np.int64)
        span[0][rest], span[1][rest] = reach.test_every(pool.corners(faces[rest]))
        alive = ~rest | (span[1] > span[0])
        keep = pool.needed(faces, alive, max_level > 0, gb, eye, find, neighbourhood, cap)
        todo_faces, todo_src, alive, span = faces[keep], todo_src[keep], alive[keep], take(span, keep)
    for level in range(max_level + 1):
        t, owner = pool.triples(todo_faces)
        kept = slice(None) if alive is None else alive[owner]
        out_t.append(t[kept])
        out_f.append(todo_faces[owner[kept]])
        out_s.append(todo_src[owner[kept]])
        if reach is not None:
            out_r.append(take(span, owner[kept]))
        # a part of a face not matched may reflect where no linked triple draws it
        rest = ~pool.matched(todo_faces, t, owner)
        if not rest.any():
            break
        faces_rest, src_rest = todo_faces[rest], todo_src[rest]
        if level == max_level:
            t, owner = pool.rim_triples(faces_rest, gb, eye, neighbourhood, cap)
            kept = slice(None) if alive is None else alive[rest][owner]
            out_t.append(t[kept])
            out_f.append(faces_rest[owner[kept]])
            out_s.append(src_rest[owner[kept]])
            if reach is not None:
                out_r.append(take(take(span, rest), owner[kept]))
            break
        subdivided.append(src_rest)
        todo_faces, todo_src = pool.cut(faces_rest, src_rest)
        if reach is None:
            pool.settle(todo_faces, gb, eye, find, neighbourhood, cap)
            continue
        # a part's rays are its face's (parts in order, four per face)
        span = reach.test(pool.corners(todo_faces), np.repeat(span[0][rest], 4), np.repeat(span[1][rest], 4))
        alive = span[1] > span[0]
        keep = pool.needed(todo_faces, alive, level + 1 < max_level, gb, eye, find, neighbourhood, cap)
        todo_faces, todo_src, alive, span = todo_faces[keep], todo_src[keep], alive[keep], take(span, keep)
        pool.settle(todo_faces, gb, eye, find, neighbourhood, cap)
    n_sub = len(np.unique(np.concatenate(subdivided))) if subdivided else 0
    cand = pool.candidates(np.concatenate(out_t), np.concatenate(out_f), np.concatenate(out_s), face_obj, n_sub)
    if reach is not None:
        cand = replace(cand, rays=(np.concatenate([r[0] for r in out_r]), np.concatenate([r[1] for r in out_r]),
                                   reach.ray()))
    return cand, with_sheets


def _edges(faces):
    """(E, 2) int64: the faces' edges, each (smaller, larger) once, in lexicographic order (the
    order of their pair keys)."""
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    e = np.sort(e, axis=1)
    keys = _sorted_unique(e[:, 0] * _KEY + e[:, 1])
    return np.stack([keys // _KEY, keys % _KEY], axis=1).astype(e.dtype).reshape(-1, 2)


def _sorted_unique(a):
    """The distinct values of an integer array, ascending (1-D): :func:`numpy.unique`'s result, by
    a sort and a comparison of neighbours (NumPy's unique hashes integers, several times slower on
    the millions of keys of a frame)."""
    s = np.sort(np.asarray(a).reshape(-1))
    if len(s) < 2:
        return s
    keep = np.empty(len(s), bool)
    keep[0] = True
    np.not_equal(s[1:], s[:-1], out=keep[1:])
    return s[keep]


def _union(a, b):
    """:func:`numpy.union1d` of ``a`` (sorted, distinct) and ``b``: ``b``'s distinct values, then a
    stable sort of the two runs (a merge, linear in their lengths) and a comparison of neighbours."""
    b = _sorted_unique(b)
    if len(a) == 0:
        return b.astype(np.result_type(a, b))
    s = np.sort(np.concatenate([a, b]), kind="stable")
    keep = np.empty(len(s), bool)
    keep[0] = True
    np.not_equal(s[1:], s[:-1], out=keep[1:])
    return s[keep]


#: Pair keys: ``i * _KEY + j`` for indices below 2**31 (vertices, images).
_KEY = np.int64(1 << 32)


def _pair_key(i, j):
    """(...) int64 keys of unordered index pairs."""
    i, j = np.asarray(i, np.int64), np.asarray(j, np.int64)
    return np.minimum(i, j) * _KEY + np.maximum(i, j)


def _member(keys, table):
    """(...) bool: whether each key is in ``table`` (sorted, unique int64)."""
    if len(table) == 0:
        return np.zeros(np.shape(keys), bool)
    pos = np.minimum(np.searchsorted(table, keys), len(table) - 1)
    return table[pos] == keys


def _ranges(start, count):
    """The indices ``start[g] .. start[g] + count[g] - 1`` of every group ``g`` in order, and
    each one's group and rank within it (all (sum(count),) int64)."""
    count = np.asarray(count, np.int64)
    group = np.repeat(np.arange(len(count), dtype=np.int64), count)
    rank = np.arange(len(group), dtype=np.int64) - np.repeat(np.cumsum(count) - count, count)
    return np.asarray(start, np.int64)[group] + rank, group, rank


def _products(size, limit):
    """Per face the first ``min(prod(size), limit)`` index triples of its corners' choices in
    nested-loop order (first corner slowest). ``size`` (F, 3) int64; returns the triples
    (T, 3) int64 and their faces (T,) int64."""
    total = size[:, 0] * size[:, 1] * size[:, 2]
    if limit is not None:
        total = np.minimum(total, limit)
    _, owner, q = _ranges(np.zeros(len(size), np.int64), total)
    nb, nc = size[owner, 1], size[owner, 2]
    return np.stack([q // (nb * nc), (q // nc) % nb, q % nc], axis=1), owner


class _Pool:
    """Vertices (scene vertices, then midpoints), their images and the links between images, as
    arrays (links, walked edges and midpoints as sorted pair keys)."""

    def __init__(self, verts, normals, images):
        self.verts, self.normals = [verts], [normals]
        self.n = len(verts)
        self.offset = np.asarray(images.offset[:-1], np.int64)
        self.count = np.diff(np.asarray(images.offset, np.int64))
        self.pixel, self.virtual = [images.pixel], [images.virtual]
        self.m = len(images.pixel)
        self.found = np.ones(self.n, bool)  # vertices whose images are known (midpoints: settle)
        self.linked = np.zeros(0, np.int64)
        self.walked = np.zeros(0, np.int64)  # edges whose links are known
        self.mid_key = np.zeros(0, np.int64)  # sorted edge keys, and their midpoints' vertex index
        self.mid_index = np.zeros(0, np.int64)

    def needed(self, faces, alive, cut, gb, eye, find, neighbourhood, cap):
        """(F,) bool: the faces (F, 3) of a level whose candidates or walks the candidates of the
        ``alive`` ones (those a ray comes near) depend on. Those alive, and beside an alive one not
        matched (the others are neither cut nor walked from): sharing with it a corner without an
        image (its walks may give the rim triples of the alive one's parts, or of itself at the
        last level) or, when the level is ``cut`` further, an edge (the midpoints on it). The
        images and links of the alive faces are made here (:meth:`settle`)."""
        live = faces[alive]
        self.settle(live, gb, eye, find, neighbourhood, cap)
        t, owner = self.triples(live)
        live = live[~self.matched(live, t, owner)]
        bare = np.zeros(self.n, bool)
        flat = live.reshape(-1)
        bare[flat[self.count[flat] == 0]] = True
        keep = alive | np.any(bare[faces], axis=1)
        if cut:
            keys = _pair_key(faces, faces[:, [1, 2, 0]])
            keep |= np.any(_member(keys, _sorted_unique(_pair_key(live, live[:, [1, 2, 0]]))), axis=1)
        return keep

    def corners(self, faces):
        """(F, 3, 3) float64: the corners of faces (F, 3) of the vertices so far."""
        return np.concatenate(self.verts)[faces]

    def add_links(self, pairs):
        pairs = np.asarray(pairs, np.int64).reshape(-1, 2)
        self.linked = _union(self.linked, _pair_key(pairs[:, 0], pairs[:, 1]))

    def triples(self, faces):
        """Every face's linked image triples (i of its first corner, j, k), in nested-loop order
        and at most ``SEVERAL_MAX_TRIPLES`` per face: (T, 3) int64 and their faces (T,) int64."""
        faces = np.ascontiguousarray(faces, np.int64)
        args = (faces, self.offset, self.count, self.linked, int(_KEY), constants.SEVERAL_MAX_TRIPLES)
        n = np.zeros(len(faces), np.int64)
        empty = np.zeros((0, 3), np.int64)
        if len(faces):
            parallel_range(linked_triples, len(faces), *args, n, empty, False)
        start = np.cumsum(n) - n
        t = np.empty((int(n.sum()), 3), np.int64)
        if len(t):
            parallel_range(linked_triples, len(faces), *args, start, t, True)
        return t, np.repeat(np.arange(len(faces), dtype=np.int64), n)

    def matched(self, faces, t, owner):
        """(F,) bool: every image of every corner of the face belongs to one of its triples."""
        ok = np.all(self.count[faces] > 0, axis=1)
        used = _sorted_unique(owner[:, None] * self.m + t)
        flat = faces.reshape(-1)
        img, corner, _ = _ranges(self.offset[flat], self.count[flat])
        face = corner // 3
        ok[face[~_member(face * self.m + img, used)]] = False
        return ok

    def rim_triples(self, faces, gb, eye, neighbourhood, cap):
        """Triples for last-level parts with an image in no linked triple: every image of each corner,
        and for a corner without one the pixels where its walks from the other corners' images
        end (at the rim or a fold), as points of the reflector (a virtual vertex projects where
        its reflection point does: these serve only to rasterize; the acceptance is exact).
        Returns (T, 3) int64 image triples and their faces (T,) int64."""
        count = self.count[faces]
        bare = faces.reshape(-1)[count.reshape(-1) == 0]  # corners without an image, face by face
        bare_face = np.nonzero(count.reshape(-1) == 0)[0] // 3
        # walks to each such corner from every image of every corner of its face, in order
        u = faces[bare_face].reshape(-1)
        starts, walk, _ = _ranges(self.offset[u], self.count[u])
        targets = np.repeat(bare, 3)[walk]
        base = self.m
        tg = np.zeros(0, np.int64)
        if len(starts):
            verts = np.concatenate(self.verts)
            pixel = np.concatenate(self.pixel)
            res = _walk(gb, eye, verts[targets], pixel[starts], neighbourhood, cap)
            if hasattr(eye, "points"):  # a later level: the view points of the pixels
                world, ok = eye.points(res.pixel)
            else:
                world = np.asarray(gb.position, np.float64)[res.pixel[:, 0], res.pixel[:, 1]] + gb.origin
                ok = np.asarray(gb.mask)[res.pixel[:, 0], res.pixel[:, 1]]
            tg = targets[ok]
            if len(tg):
                self.virtual.append(np.asarray(world[ok], np.float64))
                self.pixel.append(np.zeros((len(tg), 2), np.int32))
                self.m += len(tg)
        # a corner without an image chooses every walk end to it (over every face), in order
        order = np.argsort(tg, kind="stable")
        lo = np.searchsorted(tg[order], faces, "left")
        size = np.where(count > 0, count, np.searchsorted(tg[order], faces, "right") - lo)
        local, owner = _products(size, constants.SEVERAL_MAX_TRIPLES)
        t = self.offset[faces[owner]] + local
        own = count[owner] > 0
        if not own.all():
            t[~own] = base + order[(lo[owner] + local)[~own]]
        return t, owner

    def cut(self, faces, src):
        """Cut each face at its edge midpoints (shared between faces; their images are not found
        yet, :meth:`settle`). Returns the parts (four per face, in order) and their scene
        triangles."""
        keys = _pair_key(faces, faces[:, [1, 2, 0]]).reshape(-1)  # ab, bc, ca, face by face
        known = _member(keys, self.mid_key)
        mids = np.empty(len(keys), np.int64)
        mids[known] = self.mid_index[np.searchsorted(self.mid_key, keys[known])]
        uniq, first, inverse = np.unique(keys[~known], return_index=True, return_inverse=True)
        order = np.argsort(first)  # new midpoints numbered in order of first use
        rank = np.empty(len(uniq), np.int64)
        rank[order] = np.arange(len(uniq))
        mids[~known] = self.n + rank[inverse.reshape(-1)]
        new_keys = uniq[order]
        if len(new_keys):
            verts = np.concatenate(self.verts)
            normals = np.concatenate(self.normals)
            p, q = new_keys // _KEY, new_keys % _KEY
            pts = 0.5 * (verts[p] + verts[q])
            nm = normals[p] + normals[q]
            sq = nm * nm
            length = np.sqrt((sq[:, 0] + sq[:, 1]) + sq[:, 2])[:, None]
            nm = np.divide(nm, length, out=nm.copy(), where=length > 0)
            self.verts.append(pts)
            self.normals.append(nm)
            self.offset = np.concatenate([self.offset, np.zeros(len(pts), np.int64)])
            self.count = np.concatenate([self.count, np.zeros(len(pts), np.int64)])
            self.found = np.concatenate([self.found, np.zeros(len(pts), bool)])
            self.n += len(pts)
            all_keys = np.concatenate([self.mid_key, new_keys])
            all_index = np.concatenate([self.mid_index, self.n - len(pts) + np.arange(len(pts))])
            by = np.argsort(all_keys)
            self.mid_key, self.mid_index = all_keys[by], all_index[by]
        a, b, c = faces[:, 0], faces[:, 1], faces[:, 2]
        ab, bc, ca = mids[0::3], mids[1::3], mids[2::3]
        parts = np.stack([a, ab, ca, ab, b, bc, ca, bc, c, ab, bc, ca], axis=1).reshape(-1, 3)
        return parts, np.repeat(np.asarray(src, np.int64), 4)

    def settle(self, faces, gb, eye, find, neighbourhood, cap):
        """Find the images of the corners of ``faces`` not found yet (``find``, in vertex order)
        and link the faces' edges not walked yet."""
        v = _sorted_unique(faces)
        v = v[~self.found[v]]
        if len(v):
            found = find(np.concatenate(self.verts)[v])
            self.offset[v] = self.m + np.asarray(found.offset[:-1], np.int64)
            self.count[v] = np.diff(np.asarray(found.offset, np.int64))
            self.found[v] = True
            self.pixel.append(found.pixel)
            self.virtual.append(found.virtual)
            self.m += len(found.pixel)
        # link the edges over every vertex so far (the walk needs every image)
        edges = _edges(faces)
        ek = edges[:, 0] * _KEY + edges[:, 1]
        fresh = ~_member(ek, self.walked)
        self.walked = _union(self.walked, ek)
        self.add_links(_links(gb, eye, np.concatenate(self.verts), self.offset, self.count,
                              np.concatenate(self.pixel), edges[fresh], neighbourhood, cap))

    def candidates(self, tri_img, f, src, face_obj, subdivided):
        verts = np.concatenate(self.verts)
        normals = np.concatenate(self.normals)
        virtual = np.concatenate(self.virtual).reshape(-1, 3)
        tri_img, f = tri_img.reshape(-1, 3), f.reshape(-1, 3)
        return Candidates(virtual[tri_img], verts[f], normals[f], np.asarray(face_obj, np.int32)[src], src,
                          subdivided)


# --- every candidate triangle met with the rays that may hit it --------------------------------
def with_ray_lists(cand, verts, normals, faces, face_obj, rays):
    """``cand`` followed by one candidate per scene triangle it holds (whole, in triangle order),
    met with every ray that may hit it (:func:`ray_lists`) wherever its pixel, without a
    projection (virtual corners NaN, as :func:`near_rays`'): where an image was not found, or a
    virtual triangle misses its image by more than the dilation, the triangle is still drawn at the
    pixels whose rays hit it. Each pixel keeps the nearest hit, so the picture is the exact ray
    cast's over the candidates' triangles.

    Parameters
    ----------
    cand : Candidates
        With ray lists (``rays`` not None) or without.
    verts, normals : (N, 3) float64
    faces : (F, 3) int64
    face_obj : (F,) int32
    rays : tuple
        :func:`refsoft.search.acceptance.pixel_rays` of the drawing.

    Returns
    -------
    Candidates
    """
    src = _sorted_unique(np.asarray(cand.triangle, np.int64))
    faces = np.asarray(faces, np.int64).reshape(-1, 3)
    real = np.asarray(verts, np.float64)[faces[src]]
    first, last, ray = ray_lists(real, rays)
    keep = last > first
    src, real, first, last = src[keep], real[keep], first[keep], last[keep]
    n = len(cand.object_id)
    if cand.rays is None:
        f0, l0, r0 = np.full(n, -1, np.int64), np.full(n, -1, np.int64), np.zeros(0, np.int64)
    else:
        f0, l0, r0 = (np.asarray(a, np.int64) for a in cand.rays)
    return Candidates(np.concatenate([cand.virtual, np.full((len(src), 3, 3), np.nan)]),
                      np.concatenate([cand.real, real]),
                      np.concatenate([cand.normals, np.asarray(normals, np.float64)[faces[src]]]),
                      np.concatenate([cand.object_id, np.asarray(face_obj, np.int32)[src]]),
                      np.concatenate([cand.triangle, src]), cand.subdivided,
                      (np.concatenate([f0, first + len(r0)]), np.concatenate([l0, last + len(r0)]),
                       np.concatenate([r0, ray])))


# --- the method's branch ----------------------------------------------------------------------
def image_source(scene, view, k, refl, opt):
    """Where reflector ``k``'s images come from, or None (the virtual pass draws it): the images
    the method enumerated (``images="all"`` on a reflector the convex skip does not skip,
    :mod:`refsoft.search.convex`).

    Returns
    -------
    (gbuffer, eye, Images of the view's vertices, find) or None
        ``find(points)`` gives the images of new points (subdivision midpoints): their walk, then
        :func:`refsoft.search.images.find_images`.
    """
    images = getattr(refl, "images", None)
    if images is None:
        return None
    eye = np.asarray(view.camera.eye, np.float64)
    gb = facing_gbuffer(refl.gbuffer, eye)  # where the images were enumerated

    def find(points):
        walk = search(gb, eye, points, opt.neighbourhood, opt.inverse, None, opt.cap)
        return find_images(gb, eye, points, walk)

    return gb, eye, images, find


def several_pass(scene, view, k, stencil, box, reflected, opt, gb, eye, images, find, keep=None):
    """The drawing of every image on reflector ``k`` (steps 1-3).

    Parameters
    ----------
    scene, view, k, stencil, box
        As the seam's ``reflect``; ``box`` the pixels drawn.
    reflected : Combined
        The non-reflector meshes concatenated (:func:`refsoft.search.virtual.reflected_mesh`).
    opt : RenderOptions
        Read: ``neighbourhood``, ``cap``.
    gb, eye, images, find
        From :func:`image_source`.
    keep : dict, optional
        Receives what a later bounce needs of this drawing (:func:`refsoft.search.levels.deepen_images`):
        ``candidates`` (the scene's), ``rays`` (:func:`pixel_rays`), ``source`` ``(gb, eye, find)``.

    Returns
    -------
    colour, reflected_id, covered, report, images
        As :func:`draw`; ``report`` holds ``several``: images, candidate triangles (those a
        reflected ray may hit), subdivided triangles, pixels accepted and empty; ``images`` with
        their sheets.
    """
    mesh, triangle = view.meshes[k - 1], view.view.triangle
    rays = pixel_rays(view.camera, mesh, triangle, stencil, box)
    valid, origin, direction = rays
    cand, with_sheets = candidates(gb, eye, view.vertices, reflected.normals, reflected.faces,
                                   reflected.face_object, images, find, opt.neighbourhood, opt.cap,
                                   rays=(origin[valid], direction[valid]))
    drawn = with_ray_lists(cand, view.vertices, reflected.normals, reflected.faces, reflected.face_object, rays)
    colors = np.vstack([np.zeros(3), [o.color for o in scene.objects]]).astype(np.float32)
    colour, rid, covered, counts = draw(drawn, view.camera, mesh, triangle, stencil, box, colors, rays)
    if keep is not None:
        keep.update(candidates=cand, rays=rays, source=(gb, eye, find))
    report = {"images": int(len(images.pixel)), "candidates": int(len(cand.object_id)),
              "subdivided": int(cand.subdivided), **counts}
    return colour, rid, covered, {"several": report}, with_sheets
