"""The reflection-point search (Estalella et al. 2006, section 4; spec section 4).

For each vertex ``V`` and a reflector's G-buffer, :func:`search` walks from a start pixel to the
pixel whose normal best matches the bisector of the directions to the eye and to ``V``;
:func:`virtual_vertices` then mirrors ``V`` across that pixel's tangent plane.
:func:`trace_search` replays one search step by step.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import validate
from .._parallel import parallel_range
from ..constants import INVERSE_MODES, NEIGHBOURHOODS, SEARCH_METHODS, VIRTUAL_RULES
from ..errors import RefsoftError
from ..raster import GBuffer
from ..raster._threads import SERIAL_MAX_VERTICES
from . import _kernels, _lanes
from .scratch import kept
from ._kernels import BAD_START, BORDER, CAPPED, CULLED, HIDDEN, RESTARTED, SEVERAL

__all__ = ["search", "virtual_vertices", "start_pixel", "SearchResult", "trace_search", "Trace", "scores_at",
           "HIDDEN", "BORDER", "CAPPED", "RESTARTED", "CULLED", "SEVERAL", "NEIGHBOURHOODS", "INVERSE_MODES",
           "flag_names", "default_cap", "SEARCH_METHODS", "trace_hierarchy", "HierarchyTrace"]

_FLAG_NAMES = ((HIDDEN, "HIDDEN"), (BORDER, "BORDER"), (CAPPED, "CAPPED"), (RESTARTED, "RESTARTED"),
               (CULLED, "CULLED"), (SEVERAL, "SEVERAL"))


def flag_names(flags: int) -> list[str]:
    """Names of the bits set in one flags value, e.g. ``['HIDDEN', 'BORDER']``."""
    return [name for bit, name in _FLAG_NAMES if int(flags) & bit]


def default_cap(shape) -> int:
    """The iteration cap of spec section 4.4: ``2 * (width + height)`` of the G-buffer."""
    return 2 * (int(shape[0]) + int(shape[1]))


@dataclass(frozen=True, eq=False)
class SearchResult:
    """Per-vertex results of :func:`search` for one reflector.

    Attributes
    ----------
    pixel : ndarray, shape (N, 2), int32
        Reflection pixel (row, col) in the G-buffer; (-1, -1) where CULLED.
    score : ndarray, shape (N,), float32 or float64
        ``s`` at that pixel (the inverse score after an inverse search).
    margin : ndarray, shape (N,)
        Best minus second-best score in the final neighbourhood (2.0 when no other candidate is
        covered); a port's differing pixel is a tie when this is within a few ULP.
    iterations : ndarray, shape (N,), int32
        Neighbourhoods evaluated (standard plus inverse search).
    flags : ndarray, shape (N,), uint8
        HIDDEN | BORDER | CAPPED | RESTARTED | CULLED (SEVERAL is set in the frame's ``flags_k``
        by the enumeration of every image, :mod:`refsoft.search.images`).
    neighbourhood, inverse : str
        The options used.
    cap : int
    method : str
        ``walk`` or ``hierarchy``.
    """

    pixel: np.ndarray
    score: np.ndarray
    margin: np.ndarray
    iterations: np.ndarray
    flags: np.ndarray
    neighbourhood: str
    inverse: str
    cap: int
    method: str = "walk"

    def __len__(self):
        return len(self.pixel)


def start_pixel(mask) -> tuple[int, int] | None:
    """The search's start without history (spec section 4.3).

    The centre of the covered pixels' bounding box, ``(floor((r0 + r1) / 2), floor((c0 + c1) /
    2))``; if that pixel is not covered, the covered pixel nearest to it (Euclidean distance,
    ties to the smaller row, then the smaller col). ``None`` for an empty mask.
    """
    mask = np.asarray(mask, dtype=bool)
    any_r = np.flatnonzero(mask.any(axis=1))
    if len(any_r) == 0:
        return None
    r0, r1 = int(any_r[0]), int(any_r[-1])
    any_c = np.flatnonzero(mask[r0:r1 + 1].any(axis=0))  # the covered rows hold every covered pixel
    c0, c1 = int(any_c[0]), int(any_c[-1])
    r = (r0 + r1) // 2
    c = (c0 + c1) // 2
    if mask[r, c]:
        return r, c
    rows, cols = np.nonzero(mask[r0:r1 + 1, c0:c1 + 1])  # the bounding box holds every covered pixel
    d2 = (rows.astype(np.int64) + (r0 - r)) ** 2 + (cols.astype(np.int64) + (c0 - c)) ** 2
    # np.nonzero lists pixels in row-major order, so argmin's first minimum is the tie rule
    k = int(np.argmin(d2))
    return int(rows[k]) + r0, int(cols[k]) + c0


def _check_gbuffer(gbuffer):
    if not isinstance(gbuffer, GBuffer):
        raise RefsoftError(f"gbuffer must be a refsoft.raster.GBuffer, got {type(gbuffer).__name__}")
    dt = gbuffer.position.dtype
    if dt not in (np.float32, np.float64) or gbuffer.normal.dtype != dt:
        raise RefsoftError("G-buffer position and normal must share a float32 or float64 dtype")
    return dt.type


#: Packs of at most this many pixels run on the calling thread (tens of microseconds: less than
#: waking another thread costs).
PACK_SERIAL_PIXELS = 1 << 12


def _packed(gbuffer: GBuffer, eye, scratch=False):
    """The G-buffer packed for the one-search-at-a-time kernels (traces, the hierarchy,
    :func:`scores_at`), cropped to the covered pixels. (:func:`search` reads the positions and
    normals where they are and computes U with each score: the same values.)

    Returns ``(G, mask, fp, offset)``: ``G`` (h, w, 9) holds P, N and
    ``U = normalize(O - P)`` per covered pixel (the eye direction does not depend on the vertex,
    so it is computed once per pixel, with the same arithmetic), relative to the G-buffer's
    origin; ``mask`` (h, w) the coverage; both cover the covered pixels' bounding box plus a
    one-pixel margin (clipped to the buffer, so a neighbour outside the crop is outside the
    buffer); ``offset`` = (row, col) of the crop's first pixel; ``fp`` a prototype scalar of
    the precision. With ``scratch``, ``G`` lies in this thread's scratch memory
    (:func:`refsoft.search.scratch.kept`) and holds anything at uncovered pixels, which a walk
    never reads (it tests the mask first): for a caller done with it before it asks again."""
    dt = _check_gbuffer(gbuffer)
    fp = dt(0)  # prototype scalar: the kernels compute in its precision
    h, w = gbuffer.mask.shape
    rows = np.flatnonzero(gbuffer.mask.any(axis=1))
    if len(rows) == 0:
        r0 = r1 = c0 = c1 = 0
    else:
        r0, r1 = max(int(rows[0]) - 1, 0), min(int(rows[-1]) + 2, h)
        cols = np.flatnonzero(gbuffer.mask[r0:r1].any(axis=0))  # the covered rows hold every covered pixel
        c0, c1 = max(int(cols[0]) - 1, 0), min(int(cols[-1]) + 2, w)
    mask = np.ascontiguousarray(gbuffer.mask[r0:r1, c0:c1])
    eye_rel = (np.asarray(eye, dtype=np.float64) - gbuffer.origin).astype(dt)
    shape = (r1 - r0, c1 - c0, _kernels.PACKED)
    G = kept("packed", shape, dt) if scratch else np.zeros(shape, dtype=dt)
    parallel_range(_kernels.pack, r1 - r0, np.ascontiguousarray(gbuffer.position[r0:r1, c0:c1]),
                   np.ascontiguousarray(gbuffer.normal[r0:r1, c0:c1]), mask, eye_rel, fp, G,
                   serial=mask.size <= PACK_SERIAL_PIXELS)
    return G, mask, fp, (r0, c0)


def _check_options(gbuffer, neighbourhood, inverse, cap, method="walk"):
    """Validate the options shared by :func:`search` and :func:`trace_search`; returns
    (dtype, cap)."""
    dt = _check_gbuffer(gbuffer)
    if neighbourhood == "hierarchy":
        raise RefsoftError("neighbourhood must be one of ['cross', 'box']; the hierarchy search is method='hierarchy'")
    validate.choice(neighbourhood, tuple(NEIGHBOURHOODS), "neighbourhood")
    validate.choice(inverse, INVERSE_MODES, "inverse")
    validate.choice(method, SEARCH_METHODS, "method")
    cap = default_cap(gbuffer.mask.shape) if cap is None else validate.integer(cap, "cap", 1)
    return dt, int(cap)


def _culled_results(n, dt):
    """The output arrays of a search of ``n`` vertices before any runs: pixel (-1, -1), score,
    margin and iterations 0, flags CULLED (what a vertex keeps when there is nothing to search)."""
    return (np.full((n, 2), -1, dtype=np.int32), np.zeros(n, dtype=dt), np.zeros(n, dtype=dt),
            np.zeros(n, dtype=np.int32), np.full(n, CULLED, dtype=np.uint8))


def _check_starts(starts, shape):
    """Raise for the first previous pixel outside a G-buffer of ``shape`` ((-1, -1) is none)."""
    h, w = shape
    none = (starts[:, 0] == -1) & (starts[:, 1] == -1)
    bad = ~none & ((starts[:, 0] < 0) | (starts[:, 0] >= h) | (starts[:, 1] < 0) | (starts[:, 1] >= w))
    if bad.any():
        raise RefsoftError(f"previous pixel of vertex {int(np.argmax(bad))} is outside the {h}x{w} G-buffer")


def search(gbuffer: GBuffer, eye, vertices, neighbourhood: str = "cross", inverse: str = "plane",
           previous=None, cap: int | None = None, method: str = "walk", cone_factor: float = 1.5,
           sphere_factor: float = 2.0, break_level: int = 0) -> SearchResult:
    """Find each vertex's reflection pixel in a reflector's G-buffer.

    Parameters
    ----------
    gbuffer : GBuffer
        The reflector's G-buffer (float32 or float64: the search uses the same precision).
    eye : array_like, shape (3,)
        The eye, world space.
    vertices : array_like, shape (N, 3)
        Vertices to reflect, world space.
    neighbourhood : {"cross", "box"}
        The walk's candidates per step: the crosshair (left, up, right, down) or the 3x3 box.
    inverse : {"plane", "search", "discard"}
        Hidden-vertex mode; only ``"search"`` changes the search (an inverse search follows).
    previous : array_like, shape (N, 2), int, optional
        Each vertex's reflection pixel in the previous frame, or (-1, -1): frame-to-frame
        coherence. A previous pixel that is no longer covered restarts (flag RESTARTED).
    cap : int, optional
        Iteration cap per search (default ``2 * (width + height)``).
    method : {"walk", "hierarchy"}
        The linear walk, or Szabo's ray-cone hierarchy (:mod:`refsoft.search.hierarchy`: no
        coherence, ``iterations`` counts the texels tested).
    cone_factor, sphere_factor, break_level
        The hierarchy's error corrections (enlargement after a failed traversal; levels above
        the base where the descent stops).

    Returns
    -------
    SearchResult
    """
    dt, cap = _check_options(gbuffer, neighbourhood, inverse, cap, method)
    if method == "hierarchy":
        return _hierarchy_search(gbuffer, eye, vertices, neighbourhood, inverse, cap, cone_factor, sphere_factor,
                                 break_level)
    eye = validate.point(eye, "eye")
    verts = validate.points(vertices, "vertices")
    n = len(verts)
    if previous is None:
        starts = np.full((n, 2), -1, dtype=np.int64)
    else:
        starts = np.asarray(previous)
        if starts.shape != (n, 2) or not np.issubdtype(starts.dtype, np.integer):
            raise RefsoftError(f"previous must be an integer array of shape ({n}, 2), got {starts.dtype} {starts.shape}")
        starts = np.ascontiguousarray(starts, dtype=np.int64)  # one kernel specialisation, fresh or coherent
    start = start_pixel(gbuffer.mask)
    if start is None or not n:
        _check_starts(starts, gbuffer.mask.shape)
        return SearchResult(*_culled_results(n, dt), neighbourhood, inverse, int(cap))
    fp = dt(0)  # prototype scalar: the kernels compute in its precision
    P = np.ascontiguousarray(gbuffer.position)
    N = np.ascontiguousarray(gbuffer.normal)
    mask = np.ascontiguousarray(gbuffer.mask)
    # Search in an order where consecutive vertices start near each other (the G-buffer then
    # stays in cache), with the inputs and results in that order (read and written one after
    # another); each vertex's result is unchanged.
    h, w = mask.shape
    keys = np.empty(n, dtype=np.int64)
    rel = np.empty((n, 3), dtype=dt)
    first = np.empty((n, 2), dtype=np.int32)
    small = n <= SERIAL_MAX_VERTICES  # microseconds of work: on this thread alone
    parallel_range(_kernels.prepare, n, verts, gbuffer.origin, starts, mask, gbuffer.view_proj, LOCALITY_CELL, fp,
                   keys, rel, first, serial=small)
    if previous is not None and (first[:, 0] == BAD_START).any():
        _check_starts(starts, (h, w))
    order, rank = np.empty(n, np.int64), np.empty(n, np.int64)
    _kernels.order_by_key(keys, np.zeros(-(-h // LOCALITY_CELL) * -(-w // LOCALITY_CELL) + 1, np.int64), order, rank)
    rows = np.empty_like(rel)
    row_starts = np.empty_like(first)
    parallel_range(_kernels.gather, n, rel, first, order, rows, row_starts, serial=small)
    sorted_out = (np.empty((n, 2), np.int32), np.empty(n, dt), np.empty(n, dt), np.empty(n, np.int32),
                  np.empty(n, np.uint8))
    # several walks per thread, their candidates scored together (the one-walk search's results);
    # the eye direction of a pixel is computed with its score (as ``_packed`` computes it: the
    # same values), which costs less than packing the whole G-buffer for a few steps per vertex
    eye_rel = (eye - gbuffer.origin).astype(dt)
    nb = NEIGHBOURHOODS[neighbourhood]
    parallel_range(_lanes.SEARCH[nb], -(-n // _lanes.SEARCH_GROUP), P, N, mask, eye_rel, rows, row_starts, start[0],
                   start[1], int(cap), inverse == "search", fp, *sorted_out, work=lambda: _lanes.search_work(nb - 1, dt))
    pixel, score, margin, iterations, flags = (np.empty_like(a) for a in sorted_out)
    parallel_range(_kernels.scatter, n, rank, *sorted_out, pixel, score, margin, iterations, flags, serial=small)
    return SearchResult(pixel, score, margin, iterations, flags, neighbourhood, inverse, int(cap))


def _hierarchy_search(gbuffer, eye, vertices, neighbourhood, inverse, cap, cone_factor, sphere_factor, break_level):
    from . import _hierarchy, hierarchy

    hierarchy.check_factors(cone_factor, sphere_factor, break_level)
    eye = validate.point(eye, "eye")
    verts = validate.points(vertices, "vertices")
    dt = gbuffer.position.dtype.type
    n = len(verts)
    pixel, score, margin, iterations, flags = _culled_results(n, dt)
    start = start_pixel(gbuffer.mask)
    if start is not None and n:
        G, mask, fp, (r0, c0) = _packed(gbuffer, eye)
        sph, cone, offsets, sizes = hierarchy.build(G, mask, fp)
        parallel_range(_hierarchy.search_all, -(-n // _hierarchy.SEARCH_GROUP), G, mask, sph, cone, offsets, sizes,
                       len(sizes), np.ascontiguousarray(verts), gbuffer.origin, dt(cone_factor), dt(sphere_factor),
                       int(break_level), int(cap), inverse == "search", start[0] - r0, start[1] - c0, fp, pixel,
                       score, margin, iterations, flags)
        pixel += np.array([r0, c0], dtype=np.int32)
    return SearchResult(pixel, score, margin, iterations, flags, neighbourhood, inverse, int(cap), "hierarchy")


def trace_hierarchy(gbuffer: GBuffer, eye, vertex, cone_factor: float = 1.5, sphere_factor: float = 2.0,
                    break_level: int = 0, cap: int | None = None) -> "HierarchyTrace":
    """Replay one hierarchy traversal (the kernel's own, with a record): every texel popped and
    every child tested, in order (:class:`refsoft.search.trace.HierarchyTrace`)."""
    from . import _hierarchy, hierarchy

    hierarchy.check_factors(cone_factor, sphere_factor, break_level)
    dt, cap = _check_options(gbuffer, "cross", "plane", cap, "hierarchy")
    v = validate.point(vertex, "vertex")
    e = validate.point(eye, "eye")
    if start_pixel(gbuffer.mask) is None:
        raise RefsoftError("the reflector covers no pixel of its G-buffer: there is nothing to search")
    G, mask, fp, (r0, c0) = _packed(gbuffer, e)
    sph, cone, offsets, sizes = hierarchy.build(G, mask, fp)
    record = np.zeros((8 * cap + 64, _hierarchy.RECORD_WIDTH), dtype=np.float64)
    stack = np.empty((3 * len(sizes) + 4, 3), dtype=np.int64)
    v_rel = (v - gbuffer.origin).astype(dt)
    r, c, tests, found, n_rec = _hierarchy.traverse(G, sph, cone, offsets, sizes, len(sizes), v_rel, dt(1.0), dt(1.0),
                                                    dt(cone_factor), dt(sphere_factor), int(break_level), int(cap),
                                                    fp, stack, record, 0)
    names = {0: "rejected", 1: "pushed", 2: "popped", 3: "chosen"}
    steps = []
    for a, lvl, i, j, ev in record[:n_rec]:
        lvl = int(lvl)
        texel = [int(i), int(j)]
        if lvl == 0:
            texel = [int(i) + r0, int(j) + c0]  # base texels as G-buffer pixels
        steps.append({"attempt": int(a), "level": lvl, "texel": texel, "event": names[int(ev)]})
    return HierarchyTrace(steps, [int(r) + r0, int(c) + c0] if found else None, int(tests), len(sizes),
                          int(sizes[0]), [r0, c0])


def virtual_vertices(gbuffer: GBuffer, result: SearchResult, vertices, relative: bool = False,
                     surface=None, rule: str = "mirror", eye=None) -> np.ndarray:
    """Virtual vertices V' (spec section 4.6), world space.

    With ``d = V - P_R`` and ``N_R`` at the reflection pixel: a visible vertex (``d.N >= 0``)
    gives, by ``rule``, ``V - 2 (d.N) N`` (``mirror``: across the tangent plane, the papers) or
    ``P_R + normalize(P_R - O) |d|`` (``unfold``: on the eye's ray through the reflection point,
    at the reflected path's length; beyond the papers, see :mod:`refsoft.search._virtual`); a
    hidden one gives, by ``result.inverse``: ``plane`` ``P_R + 2 N (d.N) - d`` (Estalella's
    equation 1, verbatim), ``search`` ``V`` itself (the inverse search found where V is seen),
    ``discard`` ``V - 2 (d.N) N`` (its triangles are not drawn). CULLED vertices give ``V``.
    Arithmetic in the G-buffer's precision, relative to its origin; ``relative=True`` returns
    that result as it is (``origin + result`` in float64 is then the virtual vertex without the
    rounding of large world coordinates to float32). ``surface = (P, N)``, two (N, 3) arrays
    relative to the origin (from :func:`refsoft.search.refine.refine`), replaces the reflection
    pixel's P and N per vertex. ``eye`` (3,), world space, is needed by ``unfold``.

    Returns
    -------
    ndarray, shape (N, 3), float32 or float64 (the G-buffer's dtype)
        World space, or relative to ``gbuffer.origin`` when ``relative``.
    """
    from . import _virtual

    dt = _check_gbuffer(gbuffer)
    verts = validate.points(vertices, "vertices", len(result))
    validate.choice(rule, VIRTUAL_RULES, "rule")
    o = np.asarray(gbuffer.origin, dtype=np.float64)
    out = np.empty((len(verts), 3), dtype=dt)
    flags = np.ascontiguousarray(result.flags, dtype=np.uint8)
    mode = INVERSE_MODES.index(result.inverse)
    unfold = rule == "unfold"
    if unfold and eye is None:
        raise RefsoftError("virtual_vertices(rule='unfold') needs the eye")
    e = np.zeros(3, dtype=dt) if eye is None else (validate.point(eye, "eye") - o).astype(dt)
    small = len(verts) <= SERIAL_MAX_VERTICES  # microseconds of work: on this thread alone
    if surface is None:
        parallel_range(_virtual.virtual_from_texels, len(verts), gbuffer.position, gbuffer.normal,
                       np.ascontiguousarray(result.pixel), verts, o, e, flags, mode, unfold, dt(0), out, serial=small)
    else:
        p, nrm = (np.ascontiguousarray(np.asarray(a, dtype=dt).reshape(len(verts), 3)) for a in surface)
        parallel_range(_virtual.virtual_from_points, len(verts), p, nrm, verts, o, e, flags, mode, unfold, dt(0), out,
                       serial=small)
    if relative:
        return out
    return (out.astype(np.float64) + o).astype(dt)


def scores_at(gbuffer: GBuffer, eye, vertices, pixels, inverse=None) -> np.ndarray:
    """The search's score (float32 or float64, its own arithmetic) of each vertex at a given
    pixel; ``inverse`` (N,) bool picks the inverse score of spec section 4.6 per vertex. -3 where the
    pixel is not covered. Shape (N,)."""
    dt = _check_gbuffer(gbuffer)
    verts = validate.points(vertices, "vertices")
    pix = np.asarray(pixels, dtype=np.int64).reshape(-1, 2)
    if len(pix) != len(verts):
        raise RefsoftError(f"pixels ({len(pix)}) and vertices ({len(verts)}) differ in number")
    inv = np.zeros(len(verts), dtype=bool) if inverse is None else np.asarray(inverse, dtype=bool)
    out = np.zeros(len(verts), dtype=dt)
    if not gbuffer.mask.any() or not len(verts):
        out[:] = -3
        return out
    G, mask, fp, (r0, c0) = _packed(gbuffer, validate.point(eye, "eye"))
    parallel_range(_kernels.scores_at, len(verts), G, mask, np.ascontiguousarray(verts), gbuffer.origin, pix - [r0, c0],
                   inv, fp, out, work=lambda: (np.empty(3, dtype=dt),))
    return out


from .trace import HierarchyTrace, Trace, trace_search  # noqa: E402  (uses the names above)
from ..constants import LOCALITY_CELL
