"""Crack-free adaptive tessellation of reflected geometry (Szabo 2013, chapter 5).

The rasterizer joins reflected vertices with straight edges, where the reflection of a straight
edge in a curved mirror is curved. Per triangle edge A-B with reflection pixels R_A, R_B, the
thesis's error is ``1 - (dot(N, b) + 1) / 2`` where, at the pixel halfway between R_A and R_B
(rounded down), N is the mirror's normal and b the normalised bisector of the directions from
that surface point to the eye and to the edge's midpoint (A + B) / 2: 0 when that pixel is where
the midpoint reflects. A triangle whose largest edge error exceeds the threshold is split 1-to-4
at its edge midpoints; the new vertices are searched, starting from their parents' pixels.

Crack-free (the thesis's version leaves holes): an edge split for one triangle is split for its
neighbours too, which are then split 1-to-2, 1-to-3 or 1-to-4 by how many of their edges were
split (red-green refinement), so no vertex lies on another triangle's edge. Every level splits
only triangles created by the previous one, up to ``max_level`` levels.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import _tessellate as _kernels
from ..errors import RefsoftError
from ..scene.mesh import normalize_rows
from . import CULLED, HIDDEN, search

#: Edge keys are ``min * KEY_BASE + max`` of vertex indices (room for 2^31 vertices).
KEY_BASE = np.int64(1) << 31


def edge_errors(gbuffer, eye, a_world, b_world, pa, pb, oa=None, ob=None) -> np.ndarray:
    """The thesis's reflection error of edges A-B (world endpoints (E, 3) float64, reflection
    pixels (E, 2)); 1 where a pixel is missing (-1) or the midpoint pixel is uncovered.
    Shape (E,), float64.

    With sub-texel offsets ``oa``, ``ob`` (E, 2) of the endpoints' reflection points
    (:func:`refsoft.search.refine.refine`), the error is taken at the exact midpoint of the
    refined points, P and N there by the refinement's first-order model at the texel nearest to
    it (beside the mirror's outline, where that texel is uncovered, at the thesis's texel),
    instead of at the texel halfway (rounded down): the error then no longer includes up to a
    texel of rounding, and small thresholds stop splitting edges already straight in the image.
    """
    a = np.asarray(a_world, dtype=np.float64).reshape(-1, 3)
    e = len(a)
    verts = np.concatenate([a, np.asarray(b_world, dtype=np.float64).reshape(-1, 3)])
    pix = np.concatenate([np.asarray(pa), np.asarray(pb)]).reshape(-1, 2)
    off = None if oa is None else np.concatenate([np.asarray(oa), np.asarray(ob)]).reshape(-1, 2)
    idx = np.arange(e, dtype=np.int64)
    return _edge_errors(gbuffer, eye, verts, pix, off, idx, idx + e)


def _edge_errors(gbuffer, eye, verts, pixel, offset, e0, e1):
    """:func:`edge_errors` of edges (verts[e0], verts[e1]) without gathering them first."""
    dt = gbuffer.position.dtype
    sub = offset is not None
    off = np.ascontiguousarray(offset, dtype=dt) if sub else np.zeros((1, 2), dtype=dt)
    out = np.empty(len(e0))
    _kernels.edge_errors(gbuffer.position, gbuffer.normal, gbuffer.mask, np.asarray(gbuffer.origin, np.float64),
                         np.asarray(eye, dtype=np.float64), np.ascontiguousarray(verts, dtype=np.float64),
                         np.ascontiguousarray(pixel, dtype=np.int64), off, np.ascontiguousarray(e0, dtype=np.int64),
                         np.ascontiguousarray(e1, dtype=np.int64), sub, dt.type(0), out)
    return out


def _edge_keys(u, v, n):
    """Undirected edge keys ``min * n + max`` (int64)."""
    lo, hi = np.minimum(u, v), np.maximum(u, v)
    return lo.astype(np.int64) * n + hi


def _split(faces, edge_keys, edge_mid, n_vertices, only=None):
    """Red-green refinement of ``faces`` (T, 3), vectorised: a triangle whose three edges are
    split gives 4, two edges 3, one edge 2; ``edge_keys`` (sorted, :func:`_edge_keys`) are the
    split edges and ``edge_mid`` their new vertices. Children come in the parents' order.
    Returns (faces, parent). ``only`` (bool (T,)): split just these 1-to-4 and leave the others
    whole, T-junctions and all (the thesis's rule, for comparison)."""
    f = np.asarray(faces, dtype=np.int64)
    t = len(f)
    a, b, c = f[:, 0], f[:, 1], f[:, 2]
    ends = [(a, b), (b, c), (c, a)]
    has = np.zeros((t, 3), dtype=bool)
    mid = np.full((t, 3), -1, dtype=np.int64)
    for k, (u, v) in enumerate(ends):
        key = _edge_keys(u, v, n_vertices)
        pos = np.clip(np.searchsorted(edge_keys, key), 0, max(len(edge_keys) - 1, 0))
        hit = (edge_keys[pos] == key) if len(edge_keys) else np.zeros(t, dtype=bool)
        has[:, k] = hit
        mid[:, k] = np.where(hit, edge_mid[pos] if len(edge_mid) else -1, -1)
    if only is not None:
        has &= np.asarray(only, dtype=bool)[:, None]
        mid = np.where(has, mid, -1)
    n = has.sum(axis=1)
    count = np.choose(n, [1, 2, 3, 4])
    start = np.concatenate([[0], np.cumsum(count)[:-1]])
    out = np.empty((int(count.sum()), 3), dtype=np.int64)
    parent = np.repeat(np.arange(t), count)
    v = f  # v[:, k] = vertex k
    rows = np.arange(t)
    # no split: the triangle itself
    s0 = n == 0
    out[start[s0]] = f[s0]
    # three: corners, then the middle
    s3 = n == 3
    ab, bc, ca = mid[s3, 0], mid[s3, 1], mid[s3, 2]
    st = start[s3]
    out[st] = np.c_[a[s3], ab, ca]
    out[st + 1] = np.c_[ab, b[s3], bc]
    out[st + 2] = np.c_[ca, bc, c[s3]]
    out[st + 3] = np.c_[ab, bc, ca]
    # one: the split edge k from v_k to v_k+1, the opposite vertex v_k+2
    s1 = n == 1
    k = np.argmax(has[s1], axis=1)
    r1 = rows[s1]
    v0, v1, opp = v[r1, k], v[r1, (k + 1) % 3], v[r1, (k + 2) % 3]
    m = mid[r1, k]
    out[start[s1]] = np.c_[v0, m, opp]
    out[start[s1] + 1] = np.c_[m, v1, opp]
    # two: the unsplit edge k keeps a triangle of its own
    s2 = n == 2
    k = np.argmin(has[s2], axis=1)
    r2 = rows[s2]
    v0, v1, opp = v[r2, k], v[r2, (k + 1) % 3], v[r2, (k + 2) % 3]
    m1, m2 = mid[r2, (k + 1) % 3], mid[r2, (k + 2) % 3]
    out[start[s2]] = np.c_[v0, v1, m1]
    out[start[s2] + 1] = np.c_[v0, m1, m2]
    out[start[s2] + 2] = np.c_[m2, m1, opp]
    return out, parent


def _triangle_errors(gbuffer, eye, verts, pixel, flags, offset, f, threshold, min_span) -> np.ndarray:
    """Each triangle's largest edge error (:func:`edge_errors`), (T,) float64; -inf for a
    triangle with a CULLED corner (no reflection to refine) and, when adaptive (``threshold >
    0``), for one all of whose corners are hidden (no visible reflection whose error could be
    measured; full tessellation still splits it). Edges whose ends' pixels are at most
    ``min_span`` apart count 0."""
    e0, e1 = f.reshape(-1), f[:, [1, 2, 0]].reshape(-1)
    err = np.zeros(len(e0))
    need = np.ones(len(e0), dtype=bool)
    if min_span > 0:  # an edge reflected within min_span pixels: nothing to draw between its ends
        # per axis, in the pixels' int32 (|differences| < 2^16): a tenth of the time of one
        # (E, 2) int64 block on 1.3M triangles, whose temporaries outgrow the cache
        rows, cols = pixel[:, 0], pixel[:, 1]
        need = (np.abs(rows[e0] - rows[e1]) > min_span) | (np.abs(cols[e0] - cols[e1]) > min_span)
    err[need] = _edge_errors(gbuffer, eye, verts, pixel, offset, e0[need], e1[need])
    bad = ((flags[f] & CULLED) != 0).any(axis=1)
    if threshold > 0:
        bad |= ((flags[f] & HIDDEN) != 0).all(axis=1)
    return np.where(bad, -np.inf, err.reshape(-1, 3).max(axis=1))


def _apply_split(faces, face_obj, keys, mids, ea, eb, n_vertices, only=None):
    """One level's split of ``faces``: the neighbours of split triangles that share a split edge
    are split too (crack-free), unless ``only`` (the split triangles' indices) restricts the
    split to those (the thesis's rule). Returns the new faces, their object ids and which of
    them the level touched (the next level's candidates)."""
    mask = None
    if only is not None:
        mask = np.zeros(len(faces), dtype=bool)
        mask[only] = True
    new_faces, parent = _split_some(faces, keys, mids, ea, eb, n_vertices, mask)
    touched = np.zeros(len(faces), dtype=bool)
    touched[np.unique(parent[np.bincount(parent, minlength=len(faces))[parent] > 1])] = True
    return new_faces, face_obj[parent], touched[parent]


def _split_edges(tris) -> np.ndarray:
    """The sorted unique edge keys of triangles ``tris`` (T, 3)."""
    return np.unique(np.concatenate([_edge_keys(tris[:, i], tris[:, (i + 1) % 3], KEY_BASE) for i in range(3)]))


def _midpoint_starts(mask, pa, pb) -> np.ndarray:
    """Search starts of new midpoints from their parents' pixels ``pa``, ``pb`` (M, 2): the
    pixel halfway between, where covered; else the first parent's; (-1, -1) where neither."""
    start = (pa + pb) // 2
    h, w = mask.shape
    ok = np.all(pa >= 0, axis=1) & np.all(pb >= 0, axis=1)
    ok &= mask[np.clip(start[:, 0], 0, h - 1), np.clip(start[:, 1], 0, w - 1)]
    start = np.where(ok[:, None], start, pa)
    return np.where(np.all(start >= 0, axis=1)[:, None], start, -1)


def _split_some(faces, keys, mids, ea, eb, n_vertices, only=None):
    """:func:`_split` of ``faces``, run on the faces with two corners among the split edges'
    ends only (the others are kept whole, as :func:`_split` keeps them): the same faces and
    parents in the same order."""
    marked = np.zeros(n_vertices, dtype=bool)
    marked[ea] = True
    marked[eb] = True
    sel = np.flatnonzero(marked[faces].sum(axis=1) >= 2)
    sub_faces, sub_parent = _split(faces[sel], keys, mids, KEY_BASE, None if only is None else only[sel])
    counts = np.ones(len(faces), dtype=np.int64)
    counts[sel] = np.bincount(sub_parent, minlength=len(sel))
    parent = np.repeat(np.arange(len(faces)), counts)
    out = faces[parent]
    first = np.cumsum(counts) - counts
    out[np.repeat(first[sel], counts[sel]) + (np.arange(len(sub_parent)) - first_of(sub_parent))] = sub_faces
    return out, parent


def first_of(parent) -> np.ndarray:
    """For sorted group ids ``parent``, the index of each element's group's first element."""
    starts = np.flatnonzero(np.r_[True, parent[1:] != parent[:-1]])
    return np.repeat(starts, np.diff(np.r_[starts, len(parent)]))


@dataclass(frozen=True, eq=False)
class Tessellation:
    """The reflected geometry of one reflector after :func:`tessellate`: the ``N`` input
    vertices first, then the ``N' - N`` new ones.

    Attributes
    ----------
    vertices, normals : ndarray (N', 3) float64
    pixel : ndarray (N', 2) int32
        Reflection pixels (the new vertices' from their own searches).
    flags : ndarray (N',) uint8
    faces : ndarray (T', 3) int64
    face_obj : ndarray (T',) int32
    searched : int
        New vertices searched.
    levels : int
        Levels done.
    surface : (P, N, offset), optional
        Sub-texel reflection points of all ``N'`` vertices, when refined.
    """

    vertices: np.ndarray
    normals: np.ndarray
    pixel: np.ndarray
    flags: np.ndarray
    faces: np.ndarray
    face_obj: np.ndarray
    searched: int
    levels: int
    surface: tuple | None = None


def tessellate(gbuffer, eye, vertices, normals, faces, face_obj, pixel, flags, threshold, max_level,
               neighbourhood="cross", inverse="plane", cap=None, crack_free=True, surface=None,
               method="walk", min_span: int = 0) -> Tessellation:
    """Refine the reflected triangles of one reflector until every triangle's largest edge error
    is at most ``threshold`` (0: every triangle, i.e. full tessellation) or ``max_level`` levels.

    Parameters
    ----------
    gbuffer : GBuffer
    eye : (3,)
    vertices, normals : ndarray (N, 3) float64
        World positions and normals of the reflected vertices (scene order).
    faces : ndarray (T, 3) int
    face_obj : ndarray (T,) int32
    pixel, flags : ndarray (N, 2) int32, (N,) uint8
        Their search results in this G-buffer.
    threshold : float
    max_level : int
    crack_free : bool
        Refine the neighbours of split triangles along the split edges (default); ``False``
        reproduces the thesis's rule, which leaves cracks.
    surface : (P, N, offset), optional
        Sub-texel reflection points of the vertices (:func:`refsoft.search.refine.refine`):
        edge errors are then taken between refined points (:func:`edge_errors`) and the new
        vertices are refined too.

    method : {"walk", "hierarchy"}
        The search the new vertices get (as the original vertices').
    min_span : int
        Beyond the thesis: an edge whose ends' reflection pixels are at most this many pixels
        apart along both axes is not a reason to split (its reflection covers a few pixels
        whatever its error; 0: the thesis's rule, every edge is measured).

    Returns
    -------
    Tessellation
    """
    from .. import validate

    validate.number(threshold, "tessellation threshold", minimum=0.0)
    validate.integer(max_level, "max_level", 0)
    verts = [np.asarray(vertices, dtype=np.float64)]
    norms = [np.asarray(normals, dtype=np.float64)]
    pix = [np.asarray(pixel, dtype=np.int32)]
    fl = [np.asarray(flags, dtype=np.uint8)]
    surf = None if surface is None else [[np.asarray(a)] for a in surface]
    faces = np.asarray(faces, dtype=np.int64)
    face_obj = np.asarray(face_obj, dtype=np.int32)
    active = np.ones(len(faces), dtype=bool)  # triangles made by the last level (candidates)
    n_total = len(verts[0])
    searched = 0
    levels = 0
    for _ in range(max_level):
        allv, allp, allf = np.concatenate(verts), np.concatenate(pix), np.concatenate(fl)
        cand = np.flatnonzero(active)
        if len(cand) == 0:
            break
        f = faces[cand]
        err = _triangle_errors(gbuffer, eye, allv, allp, allf, None if surf is None else np.concatenate(surf[2]), f,
                               threshold, min_span)
        split_tri = cand[err > threshold]
        if len(split_tri) == 0:
            break
        keys = _split_edges(faces[split_tri])
        ea, eb = keys // KEY_BASE, keys % KEY_BASE
        mids = n_total + np.arange(len(keys), dtype=np.int64)
        new_v = 0.5 * (allv[ea] + allv[eb])
        new_n = normalize_rows(np.concatenate(norms)[ea] + np.concatenate(norms)[eb])
        start = _midpoint_starts(gbuffer.mask, allp[ea].astype(np.int64), allp[eb].astype(np.int64))
        res = search(gbuffer, eye, new_v, neighbourhood, inverse, start, cap, method=method)
        for lst, a in zip((verts, norms, pix, fl), (new_v, new_n, res.pixel, res.flags)):
            lst.append(a)
        if surf is not None:
            from .refine import refine

            for lst, a in zip(surf, refine(gbuffer, eye, new_v, res)):
                lst.append(a)
        searched += len(new_v)
        n_total += len(new_v)
        faces, face_obj, active = _apply_split(faces, face_obj, keys, mids, ea, eb, n_total,
                                               None if crack_free else split_tri)
        levels += 1
    return Tessellation(np.concatenate(verts), np.concatenate(norms), np.concatenate(pix), np.concatenate(fl), faces,
                        face_obj, searched, levels,
                        None if surf is None else tuple(np.concatenate(lst) for lst in surf))
