"""Reflection-point search kernels (spec section 4).

One function, :func:`search_one`, walks the G-buffer for one vertex, recording every step for
:func:`refsoft.search.trace_search`; the searches of many vertices run in
:mod:`refsoft.search._lanes`, several walks at a time, and are tested to give its results bit for
bit.

Arithmetic, in the precision of ``fp`` (float32 by default):
``normalize(x) = x * (1 / sqrt((x.x * x.x + x.y * x.y) + x.z * x.z))`` and zero for ``x = 0``;
``s(p) = (N.x h.x + N.y h.y) + N.z h.z`` with ``h = normalize(normalize(O - P) + normalize(V - P))``.
"""

import numpy as np

from .._numba import kernel, like
from ..constants import LONE_MARGIN, NO_SCORE, NOT_A_CANDIDATE

HIDDEN = 1
BORDER = 2
CAPPED = 4
RESTARTED = 8
CULLED = 16
#: More than one reflection point on this reflector (spec section 4.8; set by the enumeration).
SEVERAL = 32

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


@kernel(inline=True)
def _normalize(x, y, z, fp):
    length = np.sqrt((x * x + y * y) + z * z)
    if length > like(0.0, fp):
        inv = like(1.0, fp) / length
        return x * inv, y * inv, z * inv
    return like(0.0, fp), like(0.0, fp), like(0.0, fp)


# Packed G-buffer channels: position P (0-2), normal N (3-5), and the unit direction to the eye
# U = normalize(O - P) (6-8), which does not depend on the vertex and is computed once per pixel.
PACKED = 9


@kernel
def pack(lo, hi, P, N, mask, eye, fp, G):
    """Rows ``lo .. hi - 1`` of ``G`` (H, W, 9), zeros on entry: P, N and U = normalize(O - P)
    at covered pixels (zeros elsewhere)."""
    w = mask.shape[1]
    for r in range(lo, hi):
        for c in range(w):
            if mask[r, c]:
                for k in range(3):
                    G[r, c, k] = P[r, c, k]
                    G[r, c, 3 + k] = N[r, c, k]
                ux, uy, uz = _normalize(eye[0] - P[r, c, 0], eye[1] - P[r, c, 1], eye[2] - P[r, c, 2], fp)
                G[r, c, 6] = ux
                G[r, c, 7] = uy
                G[r, c, 8] = uz


@kernel(inline=True)
def score_pnu(px, py, pz, nx, ny, nz, ux, uy, uz, vx, vy, vz, inverse, fp):
    """``dot(N, normalize(U + normalize(V - P)))`` (spec section 4.1) at a pixel with position P, normal
    N and eye direction ``U = normalize(O - P)``; with ``inverse`` the inverse score, ``V``
    replaced by its mirror image ``W = V - 2 dot(V - P, N) N`` (spec section 4.6, ``search``)."""
    if inverse:
        k = like(2.0, fp) * (((vx - px) * nx + (vy - py) * ny) + (vz - pz) * nz)
        vx, vy, vz = vx - k * nx, vy - k * ny, vz - k * nz
    bx, by, bz = _normalize(vx - px, vy - py, vz - pz, fp)
    hx, hy, hz = _normalize(ux + bx, uy + by, uz + bz, fp)
    return (nx * hx + ny * hy) + nz * hz


@kernel(inline=True)
def _evaluate(G, r, c, v, inverse, fp):
    """The (inverse) score of vertex ``v`` at packed pixel (r, c) (U precomputed by ``pack``,
    with the arithmetic of ``_normalize``: the same values as computing it here)."""
    g = G[r, c]
    return score_pnu(g[0], g[1], g[2], g[3], g[4], g[5], g[6], g[7], g[8], v[0], v[1], v[2], inverse, fp)


def _reuse_table():
    """REUSE[m, j]: after moving by candidate m's offset, the index the new candidate j had in
    the old neighbourhood (-1 if it was not in it). Reusing a known score changes nothing."""
    off = [tuple(o) for o in OFFSETS]
    table = np.full((9, 9), -1, dtype=np.int64)
    for m in range(9):
        for j in range(9):
            old = (off[j][0] + off[m][0], off[j][1] + off[m][1])
            if old in off:
                table[m, j] = off.index(old)
    return table


REUSE = _reuse_table()


@kernel
def walk(G, mask, v, r, c, n_candidates, cap, inverse, fp, record, n_record, phase, scratch, seen):
    """Hill-climb from (r, c) until the current pixel scores highest among its candidates.

    Returns ``(r, c, best, margin, iterations, stop, border, n_record)``: the end pixel, its
    score, best minus second-best score in its final neighbourhood (2 when it has no other
    covered candidate), neighbourhoods evaluated, CONVERGED or STOP_CAPPED, whether a neighbour
    is uncovered or outside, and the number of rows written to ``record`` (which may have zero
    rows: nothing is recorded then). Scores of candidates that were already in the previous
    neighbourhood are reused, not recomputed (same values). ``scratch`` (2, 9) and ``seen``
    (2, 9) bool are work arrays (allocated once per group of searches, not per search).
    """
    h, w = mask.shape
    scores = scratch[0]
    prev = scratch[1]
    known = seen[0]
    prev_known = seen[1]
    for k in range(9):
        prev_known[k] = False
    it = 0
    moved = -1
    scores[0] = _evaluate(G, r, c, v, inverse, fp)
    known[0] = True
    while True:
        it += 1
        best = scores[0]
        best_k = 0
        second = like(NO_SCORE, fp)
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
            known[k] = False
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
            j = REUSE[moved, k] if moved > 0 else -1
            if j >= 0 and j < n_candidates and prev_known[j]:
                s = prev[j]
            else:
                s = _evaluate(G, rr, cc, v, inverse, fp)
            scores[k] = s
            known[k] = True
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
                record[n_record, 4 + k] = NOT_A_CANDIDATE
            record[n_record, 3] = best_k if best_k > 0 else -1
            n_record += 1
        if best_k == 0:
            margin = best - second if second > like(NO_SCORE, fp) else like(LONE_MARGIN, fp)
            return r, c, best, margin, it, CONVERGED, border, n_record
        if it >= cap:
            # capped: the search keeps the pixel whose neighbourhood it evaluated last
            return r, c, scores[0], best - scores[0], it, STOP_CAPPED, border, n_record
        for k in range(n_candidates):
            prev[k] = scores[k]
            prev_known[k] = known[k]
        # the new current pixel's score is known: candidate best_k of this neighbourhood
        scores[0] = prev[best_k]
        known[0] = True
        moved = best_k
        r, c = best_r, best_c


@kernel(inline=True)
def end_walk(flags, total, it, capped, border, phase, vx, vy, vz, P, N, r, c, n0, inverse_search, fp):
    """The end of a walk of ``it`` steps for vertex ``(vx, vy, vz)`` at pixel (r, c), whose
    position is ``P[r, c, 0:3]`` and normal ``N[r, c, n0:n0 + 3]`` (the packed G-buffer: ``P = N =
    G``, ``n0 = 3``): :func:`end_walk_at` at that pixel."""
    return end_walk_at(flags, total, it, capped, border, phase, vx, vy, vz, P[r, c, 0], P[r, c, 1], P[r, c, 2],
                       N[r, c, n0], N[r, c, n0 + 1], N[r, c, n0 + 2], inverse_search, fp)


@kernel(inline=True)
def end_walk_at(flags, total, it, capped, border, phase, vx, vy, vz, px, py, pz, nx, ny, nz, inverse_search, fp):
    """The end of a walk of ``it`` steps for vertex ``(vx, vy, vz)`` at a pixel of position
    ``(px, py, pz)`` and normal ``(nx, ny, nz)`` (spec sections 4.4 and 4.6), shared by every
    search: ``flags`` gains CAPPED when the walk was ``capped``; after the first walk (``phase``
    0) HIDDEN when the vertex is behind the pixel's tangent plane, ``dot(V - P, N) < 0``; then
    BORDER when ``border`` (a neighbour uncovered or outside), unless the inverse search follows.
    Returns ``(flags, total + it, inverse)``: ``inverse`` True when the inverse search
    (``inverse_search``) is to start from that pixel, its walk to end here again with phase 1,
    these flags and this total."""
    if capped:
        flags |= CAPPED
    total += it
    if phase == 0:
        d = ((vx - px) * nx + (vy - py) * ny) + (vz - pz) * nz
        if d < like(0.0, fp):
            flags |= HIDDEN
            if inverse_search:
                return flags, total, True
    if border:
        flags |= BORDER
    return flags, total, False


@kernel
def search_one(G, mask, v, start_r, start_c, n_candidates, cap, inverse_search, fp, record, scratch, seen):
    """Standard search from (start_r, start_c) in the packed G-buffer ``G``, then the inverse
    search for a hidden vertex when ``inverse_search``. Returns
    ``(r, c, score, margin, iterations, flags, n_record)``."""
    # both walks with the same argument types (no constant among them), so that the walk is
    # compiled once, not once per set of constants
    zero = n_candidates - n_candidates
    no = zero != zero
    r, c, best, margin, it, stop, border, n_rec = walk(G, mask, v, start_r, start_c, n_candidates,
                                                      cap, no, fp, record, zero, zero, scratch, seen)
    flags, total, inverse = end_walk(0, 0, it, stop == STOP_CAPPED, border, 0, v[0], v[1], v[2], G, G, r, c, 3,
                                     inverse_search, fp)
    if inverse:
        r, c, best, margin, it, stop, border, n_rec = walk(G, mask, v, r, c, n_candidates, cap, not no, fp, record,
                                                          n_rec, zero + 1, scratch, seen)
        flags, total, _ = end_walk(flags, total, it, stop == STOP_CAPPED, border, 1, v[0], v[1], v[2], G, G, r, c,
                                   3, inverse_search, fp)
    return r, c, best, margin, total, flags, n_rec


#: A start's row in the search's inputs: the default start; the default start after a restart
#: (the previous pixel is no longer covered); a previous pixel outside the G-buffer (bad input).
DEFAULT_START = -1
RESTART = -2
BAD_START = -3


@kernel
def prepare(lo, hi, vertices, origin, starts, mask, view_proj, cell, fp, keys, rel, first):
    """Per vertex ``i`` in ``lo .. hi - 1``: the locality key ``keys[i]`` (the ``cell`` x ``cell``
    G-buffer cell where its search starts: its previous pixel, else its projection, clamped);
    ``rel[i]`` the vertex relative to ``origin``, rounded to the working precision (``like(v - o,
    fp)``); ``first[i]`` the pixel its search starts from, or (DEFAULT_START, RESTART or
    BAD_START, -1). ``starts[i]`` is the previous pixel or (-1, -1)."""
    h, w = mask.shape
    cells_x = (w + cell - 1) // cell
    for i in range(lo, hi):
        for k in range(3):
            rel[i, k] = like(vertices[i, k] - origin[k], fp)
        r = np.int64(starts[i, 0])
        c = np.int64(starts[i, 1])
        first[i, 1] = -1
        if r != -1 or c != -1:
            if r < 0 or r >= h or c < 0 or c >= w:
                first[i, 0] = BAD_START
                keys[i] = 0
                continue
            if mask[r, c]:
                first[i, 0] = r
                first[i, 1] = c
            else:
                first[i, 0] = RESTART
        else:
            first[i, 0] = DEFAULT_START
            x, y, z = vertices[i, 0], vertices[i, 1], vertices[i, 2]
            cw = ((view_proj[3, 0] * x + view_proj[3, 1] * y) + view_proj[3, 2] * z) + view_proj[3, 3]
            r = 0
            c = 0
            if cw > 0.0:
                cx = ((view_proj[0, 0] * x + view_proj[0, 1] * y) + view_proj[0, 2] * z) + view_proj[0, 3]
                cy = ((view_proj[1, 0] * x + view_proj[1, 1] * y) + view_proj[1, 2] * z) + view_proj[1, 3]
                fx = (cx / cw + 1.0) * 0.5 * w
                fy = (cy / cw + 1.0) * 0.5 * h
                c = int(min(max(fx, 0.0), w - 1.0))
                r = int(min(max(h - 1.0 - fy, 0.0), h - 1.0))
        keys[i] = (r // cell) * cells_x + c // cell


@kernel
def order_by_key(keys, first, order, rank):
    """The stable order of ``keys`` (ints in [0, n_keys)), as ``np.argsort(keys,
    kind="stable")``, into ``order``, and each element's place in it (``rank[order[j]] = j``):
    one pass to count, one to place (NumPy's radix argsort of 16-bit keys is slower on 1M
    vertices: docs/benchmarks.md). ``first``: a zeroed work array of n_keys + 1 int64;
    ``order`` and ``rank``: (n,) int64, written."""
    n = keys.shape[0]
    n_keys = first.shape[0] - 1
    for i in range(n):
        first[keys[i] + 1] += 1
    for k in range(n_keys):
        first[k + 1] += first[k]
    for i in range(n):
        k = keys[i]
        order[first[k]] = i
        rank[i] = first[k]
        first[k] += 1


@kernel
def gather(lo, hi, rel, first, order, V, S):
    """Row ``j`` of the search's inputs, ``V[j]`` and ``S[j]``, is row ``order[j]`` of
    ``prepare``'s ``rel`` and ``first``, for ``j`` in ``lo .. hi - 1``: in search order, the walks
    read their inputs one after another (1.5x faster than reading scattered rows on 1M
    vertices)."""
    for j in range(lo, hi):
        i = order[j]
        for k in range(3):
            V[j, k] = rel[i, k]
        S[j, 0] = first[i, 0]
        S[j, 1] = first[i, 1]


@kernel
def scatter(lo, hi, rank, pixel_s, score_s, margin_s, iterations_s, flags_s, pixel, score, margin, iterations, flags):
    """Vertex ``i``'s results from row ``rank[i]`` of the results in search order, for ``i`` in
    ``lo .. hi - 1``. (Reading scattered rows and writing in order is 3x faster than the converse
    on 1M vertices.)"""
    for i in range(lo, hi):
        j = rank[i]
        pixel[i, 0] = pixel_s[j, 0]
        pixel[i, 1] = pixel_s[j, 1]
        score[i] = score_s[j]
        margin[i] = margin_s[j]
        iterations[i] = iterations_s[j]
        flags[i] = flags_s[j]


@kernel
def score_field(lo, hi, G, mask, v, inverse, fp, out):
    """The (inverse) score of vertex ``v`` at every covered pixel of rows ``lo .. hi - 1`` of the
    packed G-buffer; ``out`` (H, W) stays as given elsewhere. For pictures and the exhaustive
    checks."""
    w = mask.shape[1]
    for r in range(lo, hi):
        for c in range(w):
            if mask[r, c]:
                out[r, c] = _evaluate(G, r, c, v, inverse, fp)


@kernel
def scores_at(lo, hi, G, mask, vertices, origin, pixels, inverse, fp, out, v):
    """The (inverse, where ``inverse[i]``) score of vertex ``i`` at crop pixel ``pixels[i]``, for
    ``i`` in ``lo .. hi - 1``, with the search's own arithmetic; ``NO_SCORE`` (-3) where that
    pixel is outside the crop or uncovered. For ``refsoft check``'s tie rule. ``v``: a work
    array (3,) like ``out``."""
    h, w = mask.shape
    for i in range(lo, hi):
        r = pixels[i, 0]
        c = pixels[i, 1]
        if r < 0 or r >= h or c < 0 or c >= w or not mask[r, c]:
            out[i] = like(NO_SCORE, fp)
            continue
        for k in range(3):
            v[k] = like(vertices[i, k] - origin[k], fp)
        out[i] = _evaluate(G, r, c, v, inverse[i], fp)
