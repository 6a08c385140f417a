"""Triangles cut at the reflector's silhouette (``silhouette="clip"``, beyond the papers).

A reflected triangle with both visible and hidden vertices (HIDDEN: no reflection on the visible
side of the reflector) is, in the papers, either drawn with made-up virtual vertices for the
hidden ones (``inverse="plane"`` or ``"search"``: wrong triangles over the mirror) or left out
(``"discard"``: a gap along the reflector's rim, where the truth shows the reflection reaching the
rim). Here each edge from a visible vertex ``A`` to a hidden vertex ``B`` is cut where its
reflection reaches the silhouette: points ``A + t (B - A)`` are searched (from the last visible
point's pixel) and a bracket of ``t``, visible at its low end and HIDDEN at its high end, shrunk
to ``2**-iterations`` of the edge: by bisection, or (``predict``, the accurate preset's) with its
steps at the predicted cut where the bracket's ends reflect at the same or neighbouring texels
(:func:`refsoft.search._silhouette.cut_edges`); the last visible point ``X`` becomes a new vertex (its own search result and virtual vertex; normal the
renormalised interpolation of the end normals). The triangle is replaced by its visible part:

- one hidden corner (``a, b`` visible, ``h`` hidden, in the triangle's order): ``(a, b, X_bh)``
  and ``(a, X_bh, X_ha)``;
- two hidden corners (``a`` visible): ``(a, X_ab, X_ca)``.

The winding is kept. ``X`` reflects at the silhouette, so its virtual vertex projects onto the
reflector's rim: the visible part's virtual image reaches the rim (the stencil clips the rest).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..scene.mesh import normalize_rows
from . import CULLED, HIDDEN, search
from ._tessellate import merge_faces
from .tessellate import _distinct
from ..constants import CLIP_ITERATIONS, CLIP_TIE_STEPS


@dataclass(frozen=True, eq=False)
class Clip:
    """The new vertices and the faces after :func:`clip_at_silhouette` (the ``N`` input vertices
    keep their indices; the new ones are ``N .. N + M - 1``).

    Attributes
    ----------
    vertices, normals : ndarray (M, 3) float64
        The cut points and their normals.
    pixel : ndarray (M, 2) int32
    flags : ndarray (M,) uint8
        Their search results (never HIDDEN).
    faces : ndarray (T', 3) int64
        Every face: the unmixed ones as they were, each mixed one replaced by its visible part
        (in place, in the face order).
    face_obj : ndarray (T',) int32
    cut : int
        Edges cut.
    searched : int
        Searches run by the cut.
    ends : ndarray (M, 2) int64
        Each cut edge's visible and hidden end (vertex indices).
    t : ndarray (M,) float64
        Where along the edge the cut point lies (0 at the visible end).
    """

    vertices: np.ndarray
    normals: np.ndarray
    pixel: np.ndarray
    flags: np.ndarray
    faces: np.ndarray
    face_obj: np.ndarray
    cut: int
    searched: int
    ends: np.ndarray
    t: np.ndarray


def mixed_faces(faces, flags) -> np.ndarray:
    """(T,) bool: faces with a hidden and a visible corner and no CULLED corner."""
    from . import _silhouette

    faces = np.ascontiguousarray(faces, dtype=np.int64)
    out = np.empty(len(faces), dtype=bool)
    _silhouette.mixed_faces(faces, np.ascontiguousarray(flags, dtype=np.uint8), out)
    return out


def clip_at_silhouette(gbuffer, eye, vertices, normals, faces, face_obj, pixel, flags, neighbourhood="cross",
                       cap=None, method="walk", iterations: int = CLIP_ITERATIONS, predict: bool = False,
                       level=None) -> Clip:
    """Cut the reflected triangles of one reflector at its silhouette (see the module's text).

    Parameters
    ----------
    gbuffer : GBuffer
    eye : (3,)
    vertices, normals : ndarray (N, 3) float64
        World positions and normals of the reflected vertices.
    faces : ndarray (T, 3) int
    face_obj : ndarray (T,) int32
    pixel, flags : ndarray (N, 2) int32, (N,) uint8
        Their search results in this G-buffer (HIDDEN marks the hidden vertices).
    neighbourhood, cap, method
        The search's options (the bisection's searches use them).
    iterations : int
        Bisection steps per cut edge: the cut lies within ``2**-iterations`` of the edge of
        where the search's classification changes.
    predict : bool
        Place the steps at the predicted cut where the bracket's ends reflect at the same or
        neighbouring texels (:func:`refsoft.search._silhouette.cut_edges`; the walk only): the
        bracket is closed to the same width with fewer searches, the cut point moves within it.
    level : LevelSearch, optional
        A later bounce's G-buffer (spec section 5.1, :class:`refsoft.search.bounces.LevelSearch`):
        the bisection's walks on it with each pixel's own eye (its ``walked``); ``method`` is not
        read and ``predict`` not used (the prediction scores with one eye).

    Returns
    -------
    Clip
    """
    faces = np.asarray(faces, dtype=np.int64)
    hidden = (flags & HIDDEN) != 0
    mixed = np.flatnonzero(mixed_faces(faces, flags))
    n = len(vertices)
    empty = Clip(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 2), np.int32), np.zeros(0, np.uint8), faces,
                 np.asarray(face_obj), 0, 0, np.zeros((0, 2), np.int64), np.zeros(0))
    if len(mixed) == 0:
        return empty
    # the cut edges: (visible end, hidden end), once each
    f = faces[mixed]
    a, b = np.concatenate([f[:, 0], f[:, 1], f[:, 2]]), np.concatenate([f[:, 1], f[:, 2], f[:, 0]])
    cross = hidden[a] != hidden[b]
    vis = np.where(hidden[a], b, a)[cross]
    hid = np.where(hidden[a], a, b)[cross]
    key = _distinct(np.sort(vis * np.int64(n) + hid))
    vis, hid = key // n, key % n
    p_vis, p_hid = vertices[vis], vertices[hid]
    if method == "walk" or level is not None:
        lo_t, got_pixel, got_flags, searched = _bisect(gbuffer, eye, p_vis, p_hid, pixel[vis], pixel[hid], flags[vis],
                                                       neighbourhood, cap, iterations, predict and level is None,
                                                       None if level is None else level.walked())
    else:
        lo_t, got_pixel, got_flags = _bisect_searches(gbuffer, eye, p_vis, p_hid, pixel[vis], flags[vis],
                                                      neighbourhood, cap, method, iterations)
        searched = len(key) * iterations
    cut_v = p_vis + lo_t[:, None] * (p_hid - p_vis)
    cut_n = normalize_rows(normals[vis] + lo_t[:, None] * (normals[hid] - normals[vis]))
    parts, per_face = _visible_parts(f, hidden, key, n)
    # every face in order, each mixed one replaced by its visible part
    face_obj = np.ascontiguousarray(face_obj, dtype=np.int32)
    is_mixed = np.zeros(len(faces), dtype=bool)
    is_mixed[mixed] = True
    total = len(faces) + int(per_face.sum()) - len(mixed)
    out = np.empty((total, 3), dtype=np.int64)
    out_obj = np.empty(total, dtype=np.int32)
    merge_faces(np.ascontiguousarray(faces), face_obj, is_mixed, parts, np.repeat(face_obj[mixed], per_face),
                per_face.astype(np.int64), out, out_obj)
    return Clip(cut_v, cut_n, got_pixel, got_flags, out, out_obj, len(key), searched, np.c_[vis, hid], lo_t)


def _bisect(gbuffer, eye, p_vis, p_hid, pixel, end, flags, neighbourhood, cap, iterations, predict=False,
            walked=None):
    """Every cut edge in one kernel pass (:func:`refsoft.search._silhouette.cut_edges`): without
    ``predict``, :func:`_bisect_searches`'s results bit for bit (without a search call and array
    bookkeeping per step); with it, the bracket closed to the same width with the steps placed
    at the predicted cut. ``end``: the hidden ends' pixels; ``walked``: the packed G-buffer to walk
    on (``(G, mask, fp, offset)``, as :func:`refsoft.search._packed` gives it) in place of the
    eye's. Returns (t (M,) float64, pixel (M, 2)
    int32, flags (M,) uint8, searches run)."""
    from . import _check_options, _packed, start_pixel
    from . import _kernels as _search_kernels
    from . import _silhouette
    from .._parallel import parallel_range
    from ..constants import NEIGHBOURHOODS

    dt, cap = _check_options(gbuffer, neighbourhood, "discard", cap)
    m = len(p_vis)
    cut_t = np.empty(m)
    searched = np.zeros(m, dtype=np.int64)
    got_pixel = np.ascontiguousarray(pixel, dtype=np.int32).copy()
    got_flags = np.ascontiguousarray(flags, dtype=np.uint8).copy()
    default = start_pixel(gbuffer.mask)
    # in scratch memory: read only by the walks below, before this returns
    G, mask, fp, (r0, c0) = _packed(gbuffer, eye, scratch=True) if walked is None else walked

    def work():
        return (np.empty(3, dtype=dt), np.empty((2, 9), dtype=dt), np.zeros((2, 9), dtype=bool),
                np.zeros((0, _search_kernels.RECORD_WIDTH)))

    parallel_range(_silhouette.cut_edges, m, G, mask, r0, c0, np.ascontiguousarray(gbuffer.position),
                   np.ascontiguousarray(gbuffer.normal), np.ascontiguousarray(gbuffer.mask),
                   np.asarray(gbuffer.origin, dtype=np.float64), np.asarray(eye, dtype=np.float64),
                   np.ascontiguousarray(p_vis, dtype=np.float64), np.ascontiguousarray(p_hid, dtype=np.float64),
                   got_pixel.astype(np.int64), np.ascontiguousarray(end, dtype=np.int64), default[0], default[1],
                   NEIGHBOURHOODS[neighbourhood], cap, 2.0 ** -int(iterations), bool(predict), CLIP_TIE_STEPS, fp,
                   cut_t, got_pixel, got_flags, searched, work=work)
    return cut_t, got_pixel, got_flags, int(searched.sum())


def _bisect_searches(gbuffer, eye, p_vis, p_hid, pixel, flags, neighbourhood, cap, method, iterations):
    """The bisection of every cut edge, one :func:`refsoft.search.search` of every edge per step
    (any search method). Returns (t (M,) float64, pixel (M, 2) int32, flags (M,) uint8)."""
    m = len(p_vis)
    lo_t = np.zeros(m)
    hi_t = np.ones(m)
    start = pixel.astype(np.int64)
    got_pixel = pixel.astype(np.int32)
    got_flags = flags.astype(np.uint8)
    for _ in range(iterations):
        t = 0.5 * (lo_t + hi_t)
        mid = p_vis + t[:, None] * (p_hid - p_vis)
        res = search(gbuffer, eye, mid, neighbourhood, "discard", start, cap, method=method)
        seen = (res.flags & (HIDDEN | CULLED)) == 0
        lo_t = np.where(seen, t, lo_t)
        hi_t = np.where(seen, hi_t, t)
        start = np.where(seen[:, None], res.pixel, start)
        got_pixel = np.where(seen[:, None], res.pixel, got_pixel)
        got_flags = np.where(seen, res.flags, got_flags).astype(np.uint8)
    return lo_t, got_pixel, got_flags


def _visible_parts(f, hidden, key, n):
    """The visible part of each mixed face ``f[j]`` (M, 3) (one or two hidden corners): its
    faces, in face order (2 for a face with one hidden corner, 1 for two), and their count per
    face; the cut point of edge (visible u, hidden v) is vertex ``n + searchsorted(key, u * n + v)``."""
    h0, h1, h2 = hidden[f[:, 0]], hidden[f[:, 1]], hidden[f[:, 2]]
    one = (h0.astype(np.int8) + h1 + h2) == 1
    rows = np.arange(len(f))
    # k: the corner unlike the other two (the hidden one of one, the visible one of two)
    k = np.where(h0 == h1, 2, np.where(h0 == h2, 1, 0))
    # one hidden corner z = f[k]: x, y, z = f[k+1], f[k+2], f[k]; two: x = f[k] visible, then y, z
    x = np.where(one, f[rows, (k + 1) % 3], f[rows, k])
    y = np.where(one, f[rows, (k + 2) % 3], f[rows, (k + 1) % 3])
    z = np.where(one, f[rows, k], f[rows, (k + 2) % 3])
    # the cut edges: x-z for all; y-z for one hidden corner, x-y for two (one lookup)
    u = np.concatenate([x, np.where(one, y, x)])
    v = np.concatenate([z, np.where(one, z, y)])
    cuts = n + np.searchsorted(key, u * n + v)
    c_xz, c_2 = cuts[:len(f)], cuts[len(f):]
    per_face = np.where(one, 2, 1)
    # one: (x, y, X_yz) and (x, X_yz, X_xz); two: (x, X_xy, X_xz)
    first = np.column_stack([x, np.where(one, y, c_2), np.where(one, c_2, c_xz)])
    parts = np.empty((int(per_face.sum()), 3), dtype=np.int64)
    at = np.cumsum(per_face) - per_face
    parts[at] = first
    parts[at[one] + 1] = np.column_stack([x, c_2, c_xz])[one]
    return parts, per_face
