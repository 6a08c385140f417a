"""Reflection-point search kernels (DESIGN section 4).

One function, :func:`search_one`, walks the G-buffer for one vertex; the parallel kernel calls it
for every vertex and :func:`refsoft.search.trace_search` calls it for one vertex with a record
buffer, so the trace is the kernel's own arithmetic, step for step.

Arithmetic, in the precision of ``conv`` (float32 by default):
``normalize(x) = x * (1 / sqrt((x.x * x.x + x.y * x.y) + x.z * x.z))`` and zero for ``x = 0``;
``s(p) = (N.x h.x + N.y h.y) + N.z h.z`` with ``h = normalize(normalize(O - P) + normalize(V - P))``.
"""

import numpy as np
from numba import prange

from .._numba import kernel

HIDDEN = 1
BORDER = 2
CAPPED = 4
RESTARTED = 8
CULLED = 16

# Candidate offsets (drow, dcol), in visiting order: the current pixel, then left, up, right,
# down (the crosshair), then up-left, up-right, down-right, down-left (box only).
OFFSETS = np.array([[0, 0], [0, -1], [-1, 0], [0, 1], [1, 0], [-1, -1], [-1, 1], [1, 1], [1, -1]], dtype=np.int64)
# Candidate status in records
EVALUATED = 0
UNCOVERED = 1
OUTSIDE = 2
# Stop reasons
CONVERGED = 0
STOP_CAPPED = 1
# Record columns: phase, row, col, chosen candidate (-1 none), 9 statuses, 9 scores
RECORD_WIDTH = 4 + 9 + 9


@kernel
def _normalize(x, y, z, conv):
    length = np.sqrt((x * x + y * y) + z * z)
    if length > conv(0.0):
        inv = conv(1.0) / length
        return x * inv, y * inv, z * inv
    return conv(0.0), conv(0.0), conv(0.0)


@kernel
def score(px, py, pz, nx, ny, nz, ox, oy, oz, vx, vy, vz, conv):
    """``dot(N, normalize(normalize(O - P) + normalize(V - P)))`` (DESIGN 4.1)."""
    ax, ay, az = _normalize(ox - px, oy - py, oz - pz, conv)
    bx, by, bz = _normalize(vx - px, vy - py, vz - pz, conv)
    hx, hy, hz = _normalize(ax + bx, ay + by, az + bz, conv)
    return (nx * hx + ny * hy) + nz * hz


@kernel
def inverse_score(px, py, pz, nx, ny, nz, ox, oy, oz, vx, vy, vz, conv):
    """The score with ``W = V - 2 dot(V - P, N) N`` in place of ``V`` (DESIGN 4.6, ``search``)."""
    k = conv(2.0) * (((vx - px) * nx + (vy - py) * ny) + (vz - pz) * nz)
    return score(px, py, pz, nx, ny, nz, ox, oy, oz, vx - k * nx, vy - k * ny, vz - k * nz, conv)


@kernel
def _evaluate(P, N, r, c, eye, v, inverse, conv):
    if inverse:
        return inverse_score(P[r, c, 0], P[r, c, 1], P[r, c, 2], N[r, c, 0], N[r, c, 1], N[r, c, 2],
                             eye[0], eye[1], eye[2], v[0], v[1], v[2], conv)
    return score(P[r, c, 0], P[r, c, 1], P[r, c, 2], N[r, c, 0], N[r, c, 1], N[r, c, 2],
                 eye[0], eye[1], eye[2], v[0], v[1], v[2], conv)


@kernel
def walk(P, N, mask, eye, v, r, c, n_candidates, cap, inverse, conv, record, n_record, phase):
    """Hill-climb from (r, c) until the current pixel scores highest among its candidates.

    Returns ``(r, c, best, margin, iterations, stop, border, n_record)``: the end pixel, its
    score, best minus second-best score in its final neighbourhood (2 when it has no other
    covered candidate), neighbourhoods evaluated, CONVERGED or STOP_CAPPED, whether a neighbour
    is uncovered or outside, and the number of rows written to ``record`` (which may have zero
    rows: nothing is recorded then).
    """
    h, w = mask.shape
    it = 0
    best = _evaluate(P, N, r, c, eye, v, inverse, conv)
    while True:
        it += 1
        best_k = 0
        second = conv(-3.0)
        border = False
        rec = n_record < record.shape[0]
        if rec:
            record[n_record, 0] = phase
            record[n_record, 1] = r
            record[n_record, 2] = c
            record[n_record, 4] = EVALUATED
            record[n_record, 4 + 9] = best
        best_r, best_c = r, c
        for k in range(1, n_candidates):
            rr = r + OFFSETS[k, 0]
            cc = c + OFFSETS[k, 1]
            if rr < 0 or rr >= h or cc < 0 or cc >= w:
                border = True
                if rec:
                    record[n_record, 4 + k] = OUTSIDE
                continue
            if not mask[rr, cc]:
                border = True
                if rec:
                    record[n_record, 4 + k] = UNCOVERED
                continue
            s = _evaluate(P, N, rr, cc, eye, v, inverse, conv)
            if rec:
                record[n_record, 4 + k] = EVALUATED
                record[n_record, 4 + 9 + k] = s
            if s > best:  # strictly larger: ties never move, earlier candidates win
                second = best
                best = s
                best_k = k
                best_r, best_c = rr, cc
            elif s > second:
                second = s
        if rec:
            for k in range(n_candidates, 9):
                record[n_record, 4 + k] = OUTSIDE + 1  # not part of this neighbourhood
            record[n_record, 3] = best_k if best_k > 0 else -1
            n_record += 1
        if best_k == 0:
            margin = best - second if second > conv(-3.0) else conv(2.0)
            return r, c, best, margin, it, CONVERGED, border, n_record
        if it >= cap:
            # capped: the search keeps the pixel whose neighbourhood it evaluated last
            s_cur = _evaluate(P, N, r, c, eye, v, inverse, conv)
            return r, c, s_cur, best - s_cur, it, STOP_CAPPED, border, n_record
        r, c = best_r, best_c


@kernel
def search_one(P, N, mask, eye, v, start_r, start_c, n_candidates, cap, inverse_search, conv, record):
    """Standard search from (start_r, start_c), then the inverse search for a hidden vertex when
    ``inverse_search``. Returns ``(r, c, score, margin, iterations, flags, n_record)``."""
    r, c, best, margin, it, stop, border, n_rec = walk(P, N, mask, eye, v, start_r, start_c, n_candidates,
                                                      cap, False, conv, record, 0, 0)
    flags = 0
    if stop == STOP_CAPPED:
        flags |= CAPPED
    # hidden: V behind the tangent plane at the end pixel (dot(V - P_R, N_R) < 0)
    d = ((v[0] - P[r, c, 0]) * N[r, c, 0] + (v[1] - P[r, c, 1]) * N[r, c, 1]) + (v[2] - P[r, c, 2]) * N[r, c, 2]
    if d < conv(0.0):
        flags |= HIDDEN
        if inverse_search:
            r, c, best, margin, it2, stop, border, n_rec = walk(P, N, mask, eye, v, r, c, n_candidates, cap,
                                                                True, conv, record, n_rec, 1)
            it += it2
            if stop == STOP_CAPPED:
                flags |= CAPPED
    if border:
        flags |= BORDER
    return r, c, best, margin, it, flags, n_rec


@kernel(parallel=True)
def search_all(P, N, mask, eye, vertices, starts, default_r, default_c, n_candidates, cap, inverse_search, conv,
               pixel, best, margin, iterations, flags):
    """Search every vertex (parallel, each writes only its own outputs).

    ``starts[i]`` is the previous frame's pixel of vertex ``i`` or (-1, -1); a start that is not
    covered restarts at (default_r, default_c) and is flagged RESTARTED.
    """
    empty = np.empty((0, 22), dtype=best.dtype)
    for i in prange(vertices.shape[0]):
        r0 = starts[i, 0]
        c0 = starts[i, 1]
        extra = 0
        if r0 < 0:
            r0, c0 = default_r, default_c
        elif not mask[r0, c0]:
            r0, c0 = default_r, default_c
            extra = RESTARTED
        r, c, s, m, it, fl, _ = search_one(P, N, mask, eye, vertices[i], r0, c0, n_candidates, cap,
                                           inverse_search, conv, empty)
        pixel[i, 0] = r
        pixel[i, 1] = c
        best[i] = s
        margin[i] = m
        iterations[i] = it
        flags[i] = fl | extra


@kernel(parallel=True)
def score_field(P, N, mask, eye, v, inverse, conv, out):
    """The (inverse) score of vertex ``v`` at every covered pixel; ``out`` (H, W) stays as given
    elsewhere. For pictures and the exhaustive checks."""
    h, w = mask.shape
    for r in prange(h):
        for c in range(w):
            if mask[r, c]:
                out[r, c] = _evaluate(P, N, r, c, eye, v, inverse, conv)
