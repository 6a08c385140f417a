"""Every image drawn on a mirror that is not convex (spec section 4.8): sheets, candidate virtual
triangles, and their exact per-pixel acceptance.

1. :func:`links` and :func:`sheets`: images of the two ends of an edge are linked when the walk
   for one vertex started at the other's image pixel ends at its image, both ways (mutual walks);
   linked images share a sheet (union-find, the smallest image index as root).
2. :func:`candidates`: each scene triangle gives one virtual triangle per triple of images of its
   vertices linked along its three edges; a triangle with a vertex without an image, or with no
   linked triple, is cut at its edge midpoints (whose images are found) and its parts are tried
   again, up to ``constants.SEVERAL_MAX_LEVEL``; a part still without a linked triple at the last
   level gives every triple (the acceptance below decides).
3. :func:`draw`: each candidate is rasterized conservatively (dilated) in the reflector's stencil;
   at each covered pixel the eye ray is reflected about the reflector's interpolated normal at its
   visible point (as the ray-traced truth does) and intersected with the candidate's *real* scene
   triangle; the nearest hit with ``t > 0`` inside the triangle wins. A candidate across a tear or
   beyond a fold is never drawn where it does not reflect, and a pixel whose reflected ray hits no
   candidate stays empty.

See ``docs/sheets.md``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .. import constants
from .._parallel import parallel_range
from ..errors import RefsoftError
from ..raster import GBuffer, _setup, shade
from . import search
from ._several import accept
from .images import Images, facing_gbuffer, find_images


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
    edges = np.asarray(edges, np.int64).reshape(-1, 2)
    if len(edges) == 0 or len(images.pixel) == 0:
        return np.zeros((0, 2), np.int64)
    fwd = _walks(gb, eye, verts, images, edges, neighbourhood, cap)
    back = _walks(gb, eye, verts, images, edges[:, ::-1], neighbourhood, cap)
    f = set(map(tuple, fwd.tolist()))
    pairs = sorted(p for p in map(tuple, back[:, ::-1].tolist()) if p in f)
    return np.asarray(pairs, np.int64).reshape(-1, 2)


def _walks(gb, eye, verts, images, edges, neighbourhood, cap):
    """(i, j) pairs: the walk of edge end b started at image i of end a ends at b's image j."""
    off = images.offset
    a, b = edges[:, 0], edges[:, 1]
    na = off[a + 1] - off[a]
    rep = np.repeat(np.arange(len(edges)), na)
    if len(rep) == 0:
        return np.zeros((0, 2), np.int64)
    first = np.repeat(off[a], na)
    i = first + (np.arange(len(rep)) - np.repeat(np.cumsum(na) - na, na))
    target = b[rep]
    res = search(gb, eye, verts[target], neighbourhood, "plane", images.pixel[i], cap)
    # each walk's end against every image of its target: the nearest (Chebyshev, the first of
    # equals) within SEVERAL_LINK_TEXELS
    nt = off[target + 1] - off[target]
    walk = np.repeat(np.arange(len(i)), nt)
    if len(walk) == 0:
        return np.zeros((0, 2), np.int64)
    j = np.repeat(off[target], nt) + (np.arange(len(walk)) - np.repeat(np.cumsum(nt) - nt, nt))
    d = np.max(np.abs(images.pixel[j].astype(np.int64) - res.pixel[walk].astype(np.int64)), axis=1)
    order = np.lexsort((j, d, walk))  # by walk, then distance, then image index
    walk, j, d = walk[order], j[order], d[order]
    first = np.ones(len(walk), bool)
    first[1:] = walk[1:] != walk[:-1]
    keep = first & (d <= constants.SEVERAL_LINK_TEXELS)
    return np.stack([i[walk[keep]], j[keep]], axis=1).astype(np.int64).reshape(-1, 2)


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
@dataclass(frozen=True, eq=False)
class Candidates:
    """Candidate virtual triangles of one reflector.

    Attributes
    ----------
    virtual : (C, 3, 3) float64
        The images of the triangle's corners (world space).
    real : (C, 3, 3) float64
        The scene triangle (or its part after subdivision), world space.
    normals : (C, 3, 3) float64
        Vertex normals at its corners.
    object_id : (C,) int32
    triangle : (C,) int64
        The scene triangle (row of the faces given) each candidate comes from.
    subdivided : int
        Scene triangles cut at least once.
    """

    virtual: np.ndarray
    real: np.ndarray
    normals: np.ndarray
    object_id: np.ndarray
    triangle: np.ndarray
    subdivided: int


def candidates(gb, eye, verts, normals, faces, face_obj, images: Images, find, neighbourhood="cross", cap=None,
               max_level=None):
    """Candidate virtual triangles of every scene triangle (module docstring, step 2).

    Parameters
    ----------
    gb : GBuffer
    eye : (3,) float64
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
    pool.walked.update(map(tuple, edges.tolist()))
    out = []
    todo_faces, todo_src = faces, np.arange(len(faces), dtype=np.int64)
    subdivided = set()
    for level in range(max_level + 1):
        last = level == max_level
        split, bare = [], []
        for f, src in zip(todo_faces, todo_src):
            triples = pool.triples(f, linked=True)
            out.extend((t, f, src) for t in triples)
            if not pool.matched(f, triples):  # a part of it may reflect where no linked triple draws it
                (bare if last else split).append((f, src))
        if last and bare:
            out.extend(pool.rim_triples(bare, gb, eye, neighbourhood, cap))
        if not split:
            break
        subdivided.update(int(s) for _, s in split)
        todo_faces, todo_src = pool.split(split, gb, eye, find, neighbourhood, cap)
    return pool.candidates(out, face_obj, len(subdivided)), with_sheets


def _edges(faces):
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    e = np.sort(e, axis=1)
    return np.unique(e, axis=0)


class _Pool:
    """Vertices (scene vertices, then midpoints), their images and the links between images."""

    def __init__(self, verts, normals, images):
        self.verts, self.normals = [verts], [normals]
        self.n = len(verts)
        self.offset = list(images.offset[:-1])
        self.count = list(np.diff(images.offset))
        self.pixel, self.virtual = [images.pixel], [images.virtual]
        self.m = len(images.pixel)
        self.linked = set()
        self.walked = set()  # edges whose links are known
        self.midpoint = {}

    def add_links(self, pairs):
        for i, j in pairs.tolist():
            self.linked.add((min(i, j), max(i, j)))

    def _images(self, v):
        return range(self.offset[v], self.offset[v] + self.count[v])

    def triples(self, f, linked):
        a, b, c = (int(x) for x in f)
        out = []
        for i in self._images(a):
            for j in self._images(b):
                if linked and (min(i, j), max(i, j)) not in self.linked:
                    continue
                for k in self._images(c):
                    if linked and ((min(j, k), max(j, k)) not in self.linked
                                   or (min(i, k), max(i, k)) not in self.linked):
                        continue
                    out.append((i, j, k))
                    if len(out) >= constants.SEVERAL_MAX_TRIPLES:
                        return out
        return out

    def matched(self, f, triples):
        """Every image of every corner of face ``f`` belongs to one of its linked ``triples``."""
        used = {i for t in triples for i in t}
        return all(self.count[int(v)] > 0 and all(i in used for i in self._images(int(v))) for v in f)

    def rim_triples(self, bare, gb, eye, neighbourhood, cap):
        """Triples for last-level parts with an image in no linked triple: every image of each corner,
        and for a corner without one the pixels where its walks from the other corners' images
        end (at the rim or a fold), as points of the reflector (a virtual vertex projects where
        its reflection point does: these serve only to rasterize; the acceptance is exact)."""
        verts = np.concatenate(self.verts)
        starts, targets, keys = [], [], []
        for f, _ in bare:
            for v in f:
                if self.count[int(v)] == 0:
                    for u in f:
                        for i in self._images(int(u)):
                            starts.append(i)
                            targets.append(int(v))
                            keys.append((int(v), i))
        ends = {}
        if starts:
            pixel = np.concatenate(self.pixel)
            res = search(gb, eye, verts[targets], neighbourhood, "plane", pixel[starts], cap)
            world = np.asarray(gb.position, np.float64)[res.pixel[:, 0], res.pixel[:, 1]] + gb.origin
            ok = np.asarray(gb.mask)[res.pixel[:, 0], res.pixel[:, 1]]
            new = []
            for key, p, good in zip(keys, world, ok):
                if good:
                    ends.setdefault(key[0], []).append(self.m + len(new))
                    new.append(p)
            if new:
                self.virtual.append(np.asarray(new, np.float64))
                self.pixel.append(np.zeros((len(new), 2), np.int32))
                self.m += len(new)
        out = []
        for f, src in bare:
            choices = [list(self._images(int(v))) or sorted(set(ends.get(int(v), []))) for v in f]
            triples = []
            for i in choices[0]:
                for j in choices[1]:
                    for k in choices[2]:
                        if len(triples) < constants.SEVERAL_MAX_TRIPLES:
                            triples.append((i, j, k))
            out.extend((t, f, src) for t in triples)
        return out

    def split(self, split, gb, eye, find, neighbourhood, cap):
        """Cut each face at its edge midpoints (shared between faces); find the new points'
        images and link the new edges. Returns the parts and their scene triangles."""
        verts = np.concatenate(self.verts)
        normals = np.concatenate(self.normals)
        new_keys, new_p, new_n = [], [], []
        parts, src = [], []
        for f, s in split:
            a, b, c = (int(x) for x in f)
            mids = []
            for p, q in ((a, b), (b, c), (c, a)):
                key = (min(p, q), max(p, q))
                if key not in self.midpoint:
                    self.midpoint[key] = self.n + len(new_keys)
                    new_keys.append(key)
                    new_p.append(0.5 * (verts[p] + verts[q]))
                    nm = normals[p] + normals[q]
                    length = np.sqrt(np.sum(nm * nm))
                    new_n.append(nm / length if length > 0 else nm)
                mids.append(self.midpoint[key])
            ab, bc, ca = mids
            parts += [(a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca)]
            src += [s] * 4
        if new_keys:
            pts = np.asarray(new_p, np.float64)
            found = find(pts)
            self.verts.append(pts)
            self.normals.append(np.asarray(new_n, np.float64))
            self.offset += [self.m + int(o) for o in found.offset[:-1]]
            self.count += [int(c) for c in np.diff(found.offset)]
            self.pixel.append(found.pixel)
            self.virtual.append(found.virtual)
            self.m += len(found.pixel)
            self.n += len(pts)
        parts = np.asarray(parts, np.int64).reshape(-1, 3)
        # link the parts' edges over every vertex so far (the walk needs every image)
        allv = np.concatenate(self.verts)
        images = Images(np.asarray(self.offset + [self.m], np.int64), np.concatenate(self.pixel),
                        np.concatenate(self.virtual), np.full(self.m, -1, np.int32))
        edges = _edges(parts)
        fresh = np.array([tuple(e) not in self.walked for e in edges.tolist()], bool).reshape(-1)
        self.walked.update(map(tuple, edges.tolist()))
        self.add_links(links(gb, eye, allv, images, edges[fresh], neighbourhood, cap))
        return parts, np.asarray(src, np.int64)

    def candidates(self, out, face_obj, subdivided):
        verts = np.concatenate(self.verts)
        normals = np.concatenate(self.normals)
        virtual = np.concatenate(self.virtual).reshape(-1, 3)
        c = len(out)
        tri_img = np.asarray([t for t, _, _ in out], np.int64).reshape(c, 3)
        f = np.asarray([f for _, f, _ in out], np.int64).reshape(c, 3)
        src = np.asarray([s for _, _, s in out], np.int64)
        return Candidates(virtual[tri_img], verts[f], normals[f], np.asarray(face_obj, np.int32)[src], src,
                          subdivided)


# --- drawing ----------------------------------------------------------------------------------
def draw(cand: Candidates, camera, reflector_mesh, triangle, stencil, box, colors):
    """Draw the candidates at the reflector's stencil pixels by exact per-pixel acceptance
    (module docstring, step 3).

    Parameters
    ----------
    cand : Candidates
    camera : Camera
        The view camera.
    reflector_mesh : Mesh
        The reflector's world mesh (the main view's).
    triangle : (H, W) int
        The reflector's visible triangle per view pixel (the main view's).
    stencil : (H, W) bool
    box : (r0, r1, c0, c1)
    colors : (K + 1, 3) float32
        Object colours by id (row 0 unused).

    Returns
    -------
    colour : (h, w, 3) float32
    reflected_id : (h, w) int32
    covered : (h, w) bool
    counts : dict
        ``pixels_accepted`` (a candidate's real triangle hit), ``pixels_rejected`` (covered by a
        candidate, none hit).
    """
    from ..truth.raytrace import primary_rays  # the truth's per-pixel reflected rays, shared

    r0, r1, c0, c1 = (int(x) for x in box)
    h, w = r1 - r0, c1 - c0
    sten = np.ascontiguousarray(stencil[r0:r1, c0:c1], bool)
    rows, cols = np.nonzero(sten)
    hit, ray, ok = primary_rays(camera, reflector_mesh, rows + r0, cols + c0, triangle[rows + r0, cols + c0])
    valid = np.zeros((h, w), bool)
    origin = np.zeros((h, w, 3))
    direction = np.zeros((h, w, 3))
    valid[rows, cols] = ok
    origin[rows, cols] = hit
    direction[rows, cols] = ray
    screen, bbox, dilate = _screen(cand.virtual, camera, box)
    best_t = np.full((h, w), np.inf)
    best_c = np.full((h, w), -1, np.int64)
    best_uv = np.zeros((h, w, 2))
    tested = np.zeros((h, w), bool)
    if len(screen):
        parallel_range(accept, h, r0, c0, valid, origin, direction, screen, bbox, dilate,
                       np.ascontiguousarray(cand.real), best_t, best_c, best_uv, tested)
    covered = best_c >= 0
    rid = np.zeros((h, w), np.int32)
    colour = np.zeros((h, w, 3), np.float32)
    if covered.any():
        c = best_c[covered]
        u, v = best_uv[covered, 0], best_uv[covered, 1]
        nrm = cand.normals[c]
        n = (1.0 - u - v)[:, None] * nrm[:, 0] + u[:, None] * nrm[:, 1] + v[:, None] * nrm[:, 2]
        length = np.sqrt(np.sum(n * n, axis=1))[:, None]
        n = np.divide(n, length, out=np.zeros_like(n), where=length > 0)
        rid[covered] = cand.object_id[c]
        colour[covered] = shade(n, np.asarray(colors, np.float32)[cand.object_id[c]])
    counts = {"pixels_accepted": int(covered.sum()), "pixels_rejected": int((tested & ~covered).sum())}
    return colour, rid, covered, counts


def _screen(virtual, camera, box):
    """View-pixel positions of the candidates' virtual vertices, their dilated bounds (box rows,
    view columns) and dilations (-1: a vertex at or behind the eye plane, the whole box)."""
    r0, r1, c0, c1 = box
    c = len(virtual)
    W, H = camera.width, camera.height
    clip = _setup.transform_points(virtual.reshape(-1, 3), camera.view_proj()).reshape(c, 3, 4)
    wv = clip[..., 3]
    good = np.all(wv > 0, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        x = (clip[..., 0] / wv + 1.0) * 0.5 * W
        y = (1.0 - clip[..., 1] / wv) * 0.5 * H
    screen = np.ascontiguousarray(np.stack([x, y], axis=2))
    screen[~good] = 0.0
    edge = np.max(np.sqrt(np.sum((screen - screen[:, [1, 2, 0]]) ** 2, axis=2)), axis=1)
    dilate = constants.SEVERAL_DILATE_PIXELS + constants.SEVERAL_DILATE_FRACTION * edge
    bbox = np.empty((c, 4), np.int64)
    lo_x, hi_x = np.min(x, axis=1) - dilate, np.max(x, axis=1) + dilate
    lo_y, hi_y = np.min(y, axis=1) - dilate, np.max(y, axis=1) + dilate
    big = float(1 << 30)
    bbox[:, 0] = np.floor(np.clip(lo_y - 0.5, -big, big)).astype(np.int64) - r0
    bbox[:, 1] = np.ceil(np.clip(hi_y - 0.5, -big, big)).astype(np.int64) + 1 - r0
    bbox[:, 2] = np.floor(np.clip(lo_x - 0.5, -big, big)).astype(np.int64)
    bbox[:, 3] = np.ceil(np.clip(hi_x - 0.5, -big, big)).astype(np.int64) + 1
    bbox[~good] = (0, r1 - r0, c0, c1)
    dilate = np.where(good & np.isfinite(dilate), dilate, -1.0)
    return screen, bbox, dilate


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


def several_pass(scene, view, k, stencil, box, reflected, opt, gb, eye, images, find):
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

    Returns
    -------
    colour, reflected_id, covered, report, images
        As :func:`draw`; ``report`` holds ``several``: images, candidate triangles, subdivided
        triangles, pixels accepted and rejected; ``images`` with their sheets.
    """
    cand, with_sheets = candidates(gb, eye, view.vertices, reflected.normals, reflected.faces,
                                   reflected.face_object, images, find, opt.neighbourhood, opt.cap)
    colors = np.vstack([np.zeros(3), [o.color for o in scene.objects]]).astype(np.float32)
    colour, rid, covered, counts = draw(cand, view.camera, view.meshes[k - 1], view.view.triangle, stencil, box,
                                        colors)
    report = {"images": int(len(images.pixel)), "candidates": int(len(cand.object_id)),
              "subdivided": int(cand.subdivided), **counts}
    return colour, rid, covered, {"several": report}, with_sheets
