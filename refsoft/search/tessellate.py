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

With ``min_span`` (edges reflected within that many pixels are not measured), only the faces a
level can change take part: a face none of whose edges is measured is split only as the neighbour
of a split face, so the levels run on the faces with a measured edge and ``max_level`` rings of
faces around them (:func:`_working`), and the others are copied, in order, at the end: the same
vertices and faces, bit for bit, as when every face takes part.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import _tessellate as _kernels
from .._parallel import parallel_range
from ..raster._threads import SERIAL_MAX_TRIANGLES
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
    parallel_range(_kernels.edge_errors, len(e0), gbuffer.position, gbuffer.normal, gbuffer.mask,
                   np.asarray(gbuffer.origin, np.float64), np.asarray(eye, dtype=np.float64),
                   np.ascontiguousarray(verts, dtype=np.float64), np.ascontiguousarray(pixel, dtype=np.int64), off,
                   np.ascontiguousarray(e0, dtype=np.int64), np.ascontiguousarray(e1, dtype=np.int64), sub, dt.type(0),
                   out, serial=len(e0) <= SERIAL_MAX_TRIANGLES)
    return out


def edge_pixel_errors(gbuffer, eye, a_world, b_world, pa, pb, oa, ob) -> np.ndarray:
    """How far, in texels, the reflection of each edge's midpoint (A + B) / 2 lies from the
    midpoint of its ends' refined reflection points (where the rasterizer's straight edge passes):
    one Gauss-Newton step of the sub-texel refinement (:func:`refsoft.search.refine.refine`) from
    the texel nearest to the latter, each axis of the step clamped to ``MAX_OFFSET``; 2 where an
    end has no pixel or that texel is uncovered. Unlike the thesis's error (:func:`edge_errors`,
    a difference of cosines whose pixel size depends on the mirror's curvature), it reads in the
    image's units.

    Parameters
    ----------
    gbuffer : GBuffer
    eye : (3,)
    a_world, b_world : array_like, shape (E, 3)
        World endpoints (float64).
    pa, pb : array_like, shape (E, 2), int
        Their reflection pixels (-1 where none).
    oa, ob : array_like, shape (E, 2)
        Their sub-texel offsets (rows, cols).

    Returns
    -------
    ndarray, shape (E,), float64
    """
    a = np.asarray(a_world, dtype=np.float64).reshape(-1, 3)
    e = len(a)
    verts = np.concatenate([a, np.asarray(b_world, dtype=np.float64).reshape(-1, 3)])
    pix = np.concatenate([np.asarray(pa), np.asarray(pb)]).reshape(-1, 2)
    off = np.concatenate([np.asarray(oa), np.asarray(ob)]).reshape(-1, 2)
    idx = np.arange(e, dtype=np.int64)
    return _edge_pixel_errors(gbuffer, eye, verts, pix, off, idx, idx + e)


def _edge_pixel_errors(gbuffer, eye, verts, pixel, offset, e0, e1):
    """:func:`edge_pixel_errors` of edges (verts[e0], verts[e1]) without gathering them first."""
    dt = gbuffer.position.dtype
    out = np.empty(len(e0))
    parallel_range(_kernels.edge_pixel_errors, len(e0), gbuffer.position, gbuffer.normal, gbuffer.mask,
                   np.asarray(gbuffer.origin, np.float64), np.asarray(eye, dtype=np.float64),
                   np.ascontiguousarray(verts, dtype=np.float64), np.ascontiguousarray(pixel, dtype=np.int64),
                   np.ascontiguousarray(offset, dtype=dt), np.ascontiguousarray(e0, dtype=np.int64),
                   np.ascontiguousarray(e1, dtype=np.int64), dt.type(0), out, serial=len(e0) <= SERIAL_MAX_TRIANGLES)
    return out


def _edge_keys(u, v, n):
    """Undirected edge keys ``min * n + max`` (int64)."""
    lo, hi = np.minimum(u, v), np.maximum(u, v)
    return lo.astype(np.int64) * n + hi


# Red-green children per split pattern (bit k set: edge k, from corner k to k + 1, is split),
# as slots of the row (a, b, c, mid_ab, mid_bc, mid_ca): 1 triangle whole; one edge k split:
# (v_k, m_k, v_k+2), (m_k, v_k+1, v_k+2); two split, edge k not: (v_k, v_k+1, m_k+1),
# (v_k, m_k+1, m_k+2), (m_k+2, m_k+1, v_k+2); all three: the corners, then the middle.
_CHILDREN = np.array([
    [[0, 1, 2], [0, 0, 0], [0, 0, 0], [0, 0, 0]],  # none
    [[0, 3, 2], [3, 1, 2], [0, 0, 0], [0, 0, 0]],  # ab
    [[1, 4, 0], [4, 2, 0], [0, 0, 0], [0, 0, 0]],  # bc
    [[2, 0, 3], [2, 3, 4], [4, 3, 1], [0, 0, 0]],  # ab, bc (ca whole)
    [[2, 5, 1], [5, 0, 1], [0, 0, 0], [0, 0, 0]],  # ca
    [[1, 2, 5], [1, 5, 3], [3, 5, 0], [0, 0, 0]],  # ab, ca (bc whole)
    [[0, 1, 4], [0, 4, 5], [5, 4, 2], [0, 0, 0]],  # bc, ca (ab whole)
    [[0, 3, 5], [3, 1, 4], [5, 4, 2], [3, 4, 5]],  # all three
], dtype=np.int64)
_N_CHILDREN = np.array([1, 2, 2, 3, 2, 3, 3, 4], dtype=np.int64)


def _split(faces, edge_keys, edge_mid, n_vertices, only=None):
    """Red-green refinement of ``faces`` (T, 3), vectorised: a triangle whose three edges are
    split gives 4, two edges 3, one edge 2; ``edge_keys`` (sorted, :func:`_edge_keys`) are the
    split edges and ``edge_mid`` their new vertices. Children come in the parents' order.
    Returns (faces, parent). ``only`` (bool (T,)): split just these 1-to-4 and leave the others
    whole, T-junctions and all (the thesis's rule, for comparison)."""
    f = np.asarray(faces, dtype=np.int64)
    out, count = _children(f, edge_keys, edge_mid, n_vertices, only)
    return out, np.repeat(np.arange(len(f)), count)


def _children(f, edge_keys, edge_mid, n_vertices, only=None):
    """:func:`_split`'s children of int64 faces ``f`` and their count per face (T,)."""
    t = len(f)
    # one lookup of the 3 T edge keys, edge k of every face in block k
    key = _edge_keys(f.T.reshape(-1), f[:, [1, 2, 0]].T.reshape(-1), n_vertices)
    slots = np.empty((t, 6), dtype=np.int64)
    slots[:, :3] = f
    if len(edge_keys):
        pos = np.minimum(np.searchsorted(edge_keys, key), len(edge_keys) - 1)
        hit = edge_keys[pos] == key
        slots[:, 3:] = edge_mid[pos].reshape(3, t).T  # read only where the edge is split
    else:
        hit = np.zeros(3 * t, dtype=bool)
    has = hit.reshape(3, t)
    if only is not None:
        has = has & np.asarray(only, dtype=bool)
    pattern = has[0] + 2 * has[1].astype(np.int64) + 4 * has[2].astype(np.int64)
    count = _N_CHILDREN[pattern]
    parent = np.repeat(np.arange(t), count)
    child = np.arange(len(parent)) - np.repeat(np.cumsum(count) - count, count)
    # each child's three slots, read from its parent's row of ``slots``
    at = _CHILDREN[pattern[parent], child] + 6 * parent[:, None]
    return slots.reshape(-1)[at], count


def outline_edges(faces, pixel, offset, rows=None) -> np.ndarray:
    """Which edges of ``faces`` can draw an object's outline in the reflection: an edge of one
    face only (the mesh's border), of more than two, or of two faces turned different ways in
    the image (their corners' reflection points, ``pixel + offset``, wound in opposite senses, or
    one of them degenerate). An edge between two faces wound alike has the same object on both
    sides, so where it is reflected changes the picture by shading only.

    Parameters
    ----------
    faces : ndarray, shape (T, 3), int
    pixel : ndarray, shape (N, 2), int
    offset : ndarray, shape (N, 2)
    rows : ndarray of int, optional
        The faces whose edges are wanted (default every face); their neighbours are still
        looked for among all ``faces``.

    Returns
    -------
    ndarray, shape (T, 3) or (len(rows), 3), bool
        Edge k of face i runs from corner k to corner k + 1.
    """
    f = np.asarray(faces, dtype=np.int64)
    t = len(f)
    if t == 0 or (rows is not None and len(rows) == 0):
        return np.zeros((t if rows is None else 0, 3), dtype=bool)
    q = np.asarray(pixel, np.float64) + np.asarray(offset, np.float64)
    a, b, c = q[f[:, 0]], q[f[:, 1]], q[f[:, 2]]
    side = np.sign((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))
    # each edge's key with its face's winding (0, 1, 2) in the two low bits: one sort (no
    # argsort) groups an edge's faces, their windings in order within the group
    keys = _edge_keys(f.reshape(-1), f[:, [1, 2, 0]].reshape(-1), len(q))  # face-major: 3 i + k
    packed = np.sort(keys * 4 + np.repeat(side.astype(np.int64) + 1, 3))
    sk = packed >> 2
    first = np.ones(len(sk), dtype=bool)
    np.not_equal(sk[1:], sk[:-1], out=first[1:])
    starts = np.flatnonzero(first)
    ends = np.append(starts[1:], len(sk)) - 1
    lo, hi = packed[starts] & 3, packed[ends] & 3
    # two faces wound alike and neither degenerate (winding 1 is 0): not an outline
    outline = ((ends - starts) != 1) | (lo != hi) | (lo == 1)
    want = keys if rows is None else keys.reshape(t, 3)[np.asarray(rows)].reshape(-1)
    return outline[np.searchsorted(sk[starts], want)].reshape(-1, 3)


def _triangle_errors(gbuffer, eye, verts, pixel, flags, offset, f, threshold, min_span, metric="thesis",
                     measured=None, level=None) -> np.ndarray:
    """Each triangle's largest edge error (:func:`edge_errors`), (T,) float64; -inf for a
    triangle with a CULLED corner (no reflection to refine) and, when adaptive (``threshold >
    0``), for one all of whose corners are hidden (no visible reflection whose error could be
    measured; full tessellation still splits it). Edges whose ends' pixels are at most
    ``min_span`` apart count 0. ``metric``: "thesis" (:func:`edge_errors`) or "pixels"
    (:func:`edge_pixel_errors`, which needs ``offset``). ``measured`` ((T, 3) bool): the edges
    measured, the others count 0. ``level``: a later level's edge error (:func:`tessellate`)."""
    errors = _edge_pixel_errors if metric == "pixels" else _edge_errors
    if level is not None:  # each texel's own eye
        errors = (lambda gb, eye, v, p, off, a, b: level.edge_errors(v, p, a, b))
    if measured is None:  # one kernel pass: which edges are measured, which triangles are bad
        f = np.ascontiguousarray(f, dtype=np.int64)
        need = np.empty(3 * len(f), dtype=bool)
        bad = np.empty(len(f), dtype=bool)
        _kernels.measured_edges(f, np.ascontiguousarray(pixel, dtype=np.int32), np.ascontiguousarray(flags, np.uint8),
                                int(min_span), threshold > 0, CULLED, HIDDEN, need, bad)
        idx = np.flatnonzero(need)
        err = np.zeros(3 * len(f))
        if len(idx):
            tri, k = idx // 3, idx % 3
            err[idx] = errors(gbuffer, eye, verts, pixel, offset, f[tri, k], f[tri, (k + 1) % 3])
        err = err.reshape(-1, 3)
        return np.where(bad, -np.inf, np.maximum(np.maximum(err[:, 0], err[:, 1]), err[:, 2]))
    # the outline's edges only (``measured``), those reflected within min_span pixels left out
    e0, e1 = f.reshape(-1), f[:, [1, 2, 0]].reshape(-1)
    err = np.zeros(len(e0))
    need = np.flatnonzero(measured.reshape(-1))
    if min_span > 0:
        rows, cols = pixel[:, 0], pixel[:, 1]
        a, b = e0[need], e1[need]
        need = need[(np.abs(rows[a] - rows[b]) > min_span) | (np.abs(cols[a] - cols[b]) > min_span)]
    err[need] = errors(gbuffer, eye, verts, pixel, offset, e0[need], e1[need])
    # per-vertex tests gathered per corner, and the maximum of three columns: axis-1
    # reductions over rows of three are several times slower
    f0, f1, f2 = f[:, 0], f[:, 1], f[:, 2]
    culled = (flags & CULLED) != 0
    bad = culled[f0] | culled[f1] | culled[f2]
    if threshold > 0:
        hidden = (flags & HIDDEN) != 0
        bad |= hidden[f0] & hidden[f1] & hidden[f2]
    err = err.reshape(-1, 3)
    return np.where(bad, -np.inf, np.maximum(np.maximum(err[:, 0], err[:, 1]), err[:, 2]))


def _apply_split(faces, face_obj, keys, mids, ea, eb, n_vertices, only=None, parents=False):
    """One level's split of ``faces``: the neighbours of split triangles that share a split edge
    are split too (crack-free), unless ``only`` (the split triangles' indices) restricts the
    split to those (the thesis's rule). Returns the new faces, their object ids and which of
    them the level touched (the next level's candidates); ``parents``: and each new face's row in
    ``faces``."""
    mask = None
    if only is not None:
        mask = np.zeros(len(faces), dtype=bool)
        mask[only] = True
    pattern, slot, count = _split_plan(faces, keys, ea, eb, n_vertices, mask)
    out = _write_children(faces, face_obj, pattern, slot, mids, count)
    return (*out, np.repeat(np.arange(len(faces)), count)) if parents else out


def _split_edges(tris) -> np.ndarray:
    """The sorted unique edge keys of triangles ``tris`` (T, 3) (``np.unique``'s result)."""
    keys = np.sort(_edge_keys(tris.reshape(-1), tris[:, [1, 2, 0]].reshape(-1), KEY_BASE))
    return _distinct(keys)


def _distinct(keys) -> np.ndarray:
    """The distinct values of sorted ``keys``, in order (``np.unique`` of sorted keys, which
    hashes and sorts again)."""
    if len(keys) == 0:
        return keys
    first = np.empty(len(keys), dtype=bool)
    first[0] = True
    np.not_equal(keys[1:], keys[:-1], out=first[1:])
    return keys[first]


def _midpoint_starts(mask, pa, pb) -> np.ndarray:
    """Search starts of new midpoints from their parents' pixels ``pa``, ``pb`` (M, 2): the
    pixel halfway between, where covered; else the first parent's; (-1, -1) where neither."""
    start = (pa + pb) // 2
    h, w = mask.shape
    ok = (pa[:, 0] >= 0) & (pa[:, 1] >= 0) & (pb[:, 0] >= 0) & (pb[:, 1] >= 0)
    ok &= mask[np.clip(start[:, 0], 0, h - 1), np.clip(start[:, 1], 0, w - 1)]
    start = np.where(ok[:, None], start, pa)
    return np.where(((start[:, 0] >= 0) & (start[:, 1] >= 0))[:, None], start, -1)


def _split_some(faces, keys, mids, ea, eb, n_vertices, only=None):
    """:func:`_split` of ``faces``, looked up on the faces with two corners among the split
    edges' ends only (the others are kept whole, as :func:`_split` keeps them): the same faces
    and parents in the same order."""
    faces = np.asarray(faces, dtype=np.int64)
    pattern, slot, count = _split_plan(faces, keys, ea, eb, n_vertices, only)
    out, _, _ = _write_children(faces, np.zeros(len(faces), np.int32), pattern, slot, mids, count)
    return out, np.repeat(np.arange(len(faces)), count)


def _split_plan(faces, keys, ea, eb, n_vertices, only=None):
    """Each face's split pattern (T,) int8 (bit k: edge k is split), the split edges' indices in
    ``keys`` (T, 3) (read where split) and its number of children (T,) int64; only the faces with
    two corners among the split edges' ends ``ea``, ``eb`` are looked up (one kernel pass)."""
    t = len(faces)
    faces = np.ascontiguousarray(faces, dtype=np.int64)
    marked = np.zeros(n_vertices, dtype=bool)
    marked[ea] = True
    marked[eb] = True
    pattern = np.empty(t, dtype=np.int8)
    slot = np.empty((t, 3), dtype=np.int64)
    use = only is not None
    keys = np.asarray(keys, dtype=np.int64)
    _kernels.split_pattern(faces, keys // KEY_BASE, keys % KEY_BASE, np.empty(n_vertices, dtype=np.int64), marked,
                           np.asarray(only, dtype=bool) if use else np.zeros(1, dtype=bool), use, pattern, slot)
    return pattern, slot, _N_CHILDREN[pattern]


def _write_children(faces, face_obj, pattern, slot, mids, count):
    """The faces after the split planned by :func:`_split_plan`, children in their parents' order:
    (faces (T', 3) int64, object ids (T',) int32, active (T',) bool: the children of split faces)."""
    start = np.cumsum(count) - count
    total = int(start[-1] + count[-1]) if len(count) else 0
    out = np.empty((total, 3), dtype=np.int64)
    obj = np.empty(total, dtype=np.int32)
    active = np.empty(total, dtype=bool)
    _kernels.write_children(faces, np.ascontiguousarray(face_obj, dtype=np.int32), pattern, slot,
                            np.ascontiguousarray(mids, dtype=np.int64), _CHILDREN, _N_CHILDREN, start, out, obj, active)
    return out, obj, active


def _working(faces, pixel, min_span, max_level):
    """The faces (T,) bool that ``max_level`` levels of tessellation can split
    (:func:`refsoft.search._tessellate.working_faces`), or None when that is every face."""
    if min_span <= 0 or max_level == 0:
        return None
    keep = np.empty(len(faces), dtype=bool)
    marked = np.empty(len(pixel), dtype=bool)
    _kernels.working_faces(np.ascontiguousarray(faces), np.ascontiguousarray(pixel, dtype=np.int32), int(min_span),
                           int(max_level), marked, keep)
    return None if keep.all() else keep


def _merged(all_faces, all_obj, work, faces, face_obj, origin):
    """Every face after a tessellation of the ``work`` faces alone: each face not in ``work`` as it
    was, each one in ``work`` replaced by its tessellated faces (``faces``, ``face_obj``; ``origin``
    their rows in ``all_faces[work]``, None when the tessellation split none), in face order."""
    n_work = int(work.sum())
    counts = np.ones(n_work, dtype=np.int64) if origin is None else np.bincount(origin, minlength=n_work)
    total = len(all_faces) - n_work + len(faces)
    out = np.empty((total, 3), dtype=np.int64)
    obj = np.empty(total, dtype=np.int32)
    _kernels.merge_faces(np.ascontiguousarray(all_faces), np.ascontiguousarray(all_obj), work,
                         np.ascontiguousarray(faces), np.ascontiguousarray(face_obj, dtype=np.int32), counts, out, obj)
    return out, obj


class _Rows:
    """Arrays of one row per vertex that grow together (their capacity doubled when full): a
    level's new vertices are written after the others, not copied with them into new arrays."""

    def __init__(self, arrays):
        self.n = len(arrays[0])
        self.buf = []
        for a in arrays:
            b = np.empty((max(2 * self.n, 16),) + a.shape[1:], dtype=a.dtype)
            b[:self.n] = a
            self.buf.append(b)

    def view(self) -> list:
        """The arrays' first ``n`` rows (views)."""
        return [b[:self.n] for b in self.buf]

    def append(self, arrays) -> None:
        """Add rows (one array per buffer, in order, each of the same length)."""
        m = len(arrays[0])
        if self.n + m > len(self.buf[0]):
            size = max(2 * len(self.buf[0]), self.n + m)
            for i, b in enumerate(self.buf):
                grown = np.empty((size,) + b.shape[1:], dtype=b.dtype)
                grown[:self.n] = b[:self.n]
                self.buf[i] = grown
        for b, a in zip(self.buf, arrays):
            b[self.n:self.n + m] = a
        self.n += m


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
               method="walk", min_span: int = 0, metric: str = "thesis", outline=None, level=None) -> Tessellation:
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
    metric : {"thesis", "pixels"}
        The edge error ``threshold`` bounds: the thesis's (:func:`edge_errors`) or the distance
        in texels between the straight edge's midpoint and its reflection
        (:func:`edge_pixel_errors`, with ``surface`` only).
    outline : float, optional
        Also split a triangle one of whose edges can draw an object's outline in the reflection
        (:func:`outline_edges`) when that edge's reflection bends more than ``outline`` texels
        away from the straight edge (:func:`edge_pixel_errors`; with ``surface`` only): where
        an outline is drawn a fraction of a pixel off, its pixels show the other object, where
        an edge inside an object changes the shading only.
    level : LevelSearch, optional
        A later bounce's G-buffer (spec section 5.1, :class:`refsoft.search.bounces.LevelSearch`):
        the edge errors taken with the eye of the texel they are taken at and the new vertices
        searched with each pixel's own eye (its ``edge_errors`` and ``search``, from the same
        starts), in place of ``eye``'s; the thesis's metric, without ``surface`` or ``outline``
        (``method`` is not read).

    Returns
    -------
    Tessellation
    """
    from .. import validate

    validate.number(threshold, "tessellation threshold", minimum=0.0)
    validate.integer(max_level, "max_level", 0)
    if metric not in ("thesis", "pixels"):
        raise RefsoftError(f"tessellation metric must be 'thesis' or 'pixels', got {metric!r}")
    if outline is not None:
        validate.number(outline, "outline threshold", minimum=0.0)
    if (metric == "pixels" or outline is not None) and surface is None:
        raise RefsoftError("the tessellation's pixel metric needs the sub-texel points (surface)")
    if level is not None and (surface is not None or outline is not None):
        raise RefsoftError("a later bounce's tessellation takes the thesis's metric without sub-texel points")
    # the vertices' arrays, grown in place as levels add vertices (no copy of all rows per level)
    rows = _Rows([np.asarray(vertices, dtype=np.float64), np.asarray(normals, dtype=np.float64),
                  np.asarray(pixel, dtype=np.int32), np.asarray(flags, dtype=np.uint8)]
                 + ([] if surface is None else [np.asarray(a) for a in surface]))
    refined = surface is not None
    faces = np.asarray(faces, dtype=np.int64)
    face_obj = np.asarray(face_obj, dtype=np.int32)
    # only the faces the levels can change take part (the others are copied at the end); the
    # outline's test looks for every face's neighbours, so it sees them all
    work = _working(faces, rows.view()[2], min_span, max_level) if outline is None else None
    all_faces, all_obj = faces, face_obj
    if work is not None:
        faces, face_obj = np.compress(work, faces, axis=0), np.compress(work, face_obj)
    active = None  # triangles made by the last level (candidates); None: every triangle
    origin = None  # each face's row in the faces the loop started with; None: its own
    searched = 0
    levels = 0
    for _ in range(max_level):
        allv, alln, allp, allf = rows.view()[:4]
        alloff = rows.view()[6] if refined else None
        cand = np.arange(len(faces)) if active is None else np.flatnonzero(active)
        if len(cand) == 0:
            break
        f = faces if active is None else faces[cand]
        split = _triangle_errors(gbuffer, eye, allv, allp, allf, alloff, f, threshold, min_span, metric,
                                 level=level) > threshold
        if outline is not None:  # and the pixel metric on the edges that can draw an outline
            measured = outline_edges(faces, allp, alloff, cand)
            split |= _triangle_errors(gbuffer, eye, allv, allp, allf, alloff, f, outline, min_span, "pixels",
                                      measured) > outline
        split_tri = cand[split]
        if len(split_tri) == 0:
            break
        keys = _split_edges(faces[split_tri])
        ea, eb = keys // KEY_BASE, keys % KEY_BASE
        mids = rows.n + np.arange(len(keys), dtype=np.int64)
        new_v = 0.5 * (allv[ea] + allv[eb])
        new_n = normalize_rows(alln[ea] + alln[eb])
        start = _midpoint_starts(gbuffer.mask, allp[ea].astype(np.int64), allp[eb].astype(np.int64))
        if level is None:
            res = search(gbuffer, eye, new_v, neighbourhood, inverse, start, cap, method=method)
        else:
            res = level.search(new_v, start)
        new = [new_v, new_n, res.pixel, res.flags]
        if refined:
            from .refine import refine

            new += list(refine(gbuffer, eye, new_v, res))
        rows.append(new)
        searched += len(new_v)
        faces, face_obj, active, parent = _apply_split(faces, face_obj, keys, mids, ea, eb, rows.n,
                                                       None if crack_free else split_tri, parents=True)
        origin = parent if origin is None else origin[parent]
        levels += 1
    if work is not None:
        faces, face_obj = _merged(all_faces, all_obj, work, faces, face_obj, origin)
    out = rows.view()
    return Tessellation(out[0], out[1], out[2], out[3], faces, face_obj, searched, levels,
                        tuple(out[4:]) if refined else None)
