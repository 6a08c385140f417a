"""The linear search of many vertices, several walks at a time (spec section 4; the same results, bit
for bit, as :func:`refsoft.search._kernels.search_one`, the one-walk search the traces record).

Each thread takes the vertices in groups of ``SEARCH_GROUP`` and advances ``LANES`` walks
together: every round gathers the candidates that need a score (covered, and not in the previous
neighbourhood, whose scores are known; a walk's first pixel too) of all its walks into one block
of per-channel rows, scores them in one branch-free loop that LLVM vectorizes (8 float32 lanes
with AVX2), then compares each walk's candidates in the visiting order, as the one-walk search does. Vectorized
square roots, divisions, products and sums are IEEE operations rounded exactly like the scalar
ones, and there is no contraction (``fastmath=False``), so every score is the scalar score bit
for bit. A walk that ends makes room for the next vertex of the group.

One source gives two kernels, :data:`SEARCH` ``[5]`` (the crosshair) and ``[9]`` (the box): the
neighbourhood's size is a constant of each compiled kernel. Their arguments:

P, N, mask : the G-buffer's (h, w, 3) positions and normals (relative to its origin; float32 or
float64, the working precision) and its (h, w) coverage
eye : (3,), the eye relative to the G-buffer's origin, in the working precision
vertices : (N, 3), the vertices relative to the G-buffer's origin, in the working precision, in
search order (vertices starting near each other one after another: ``_kernels.gather``)
starts : (N, 2) int32, start pixel, or (DEFAULT_START or RESTART, -1) for the default start
default_r, default_c : the default start
cap : int; inverse_search : bool; fp : a scalar of the working precision
pixel (N, 2) int32, best_out, margin_out, iterations (N,) int32, flags_out (N,)
uint8 : the outputs, row ``i`` for row ``i`` of the inputs

Measured: docs/benchmarks.md ("Reflection-point search").
"""

import numpy as np
from numba import literally

from .._numba import kernel, like
from ..constants import LONE_MARGIN, NO_SCORE
from ._kernels import OFFSETS, RESTART, RESTARTED, REUSE, end_walk_at

#: Walks advanced together by one thread.
LANES = 16
#: The scoring loop runs over a multiple of this many candidates (no scalar remainder).
VECTOR = 8
#: Vertices searched by one thread one after another (its work arrays are allocated once per group).
SEARCH_GROUP = 256


@kernel(inline=True)
def _normalize_select(x, y, z, fp):
    """``_kernels._normalize`` with selects in place of its branch (same values, vectorizable):
    ``x * (1 / sqrt(...))``, zero where the length is not positive."""
    zero = like(0.0, fp)
    length = np.sqrt((x * x + y * y) + z * z)
    q = like(1.0, fp) / length
    pos = length > zero
    return (x * q if pos else zero), (y * q if pos else zero), (z * q if pos else zero)


@kernel
def score_batch(n, P0, P1, P2, N0, N1, N2, ex, ey, ez, VX, VY, VZ, INV, OUT, fp):
    """``OUT[j]``: the score (the inverse score where ``INV[j]``) of vertex ``(VX, VY, VZ)[j]`` at
    the pixel whose P and N are ``(P0, P1, P2)[j]`` and ``(N0, N1, N2)[j]``, seen from the eye
    ``(ex, ey, ez)``: the arithmetic of :func:`refsoft.search._kernels.score_pnu` with
    ``U = normalize(O - P)``, written without branches (selects) so that the loop vectorizes."""
    two = like(2.0, fp)
    for j in range(n):
        px = P0[j]
        py = P1[j]
        pz = P2[j]
        nx = N0[j]
        ny = N1[j]
        nz = N2[j]
        vx = VX[j]
        vy = VY[j]
        vz = VZ[j]
        t = two * (((vx - px) * nx + (vy - py) * ny) + (vz - pz) * nz)
        inv = INV[j]
        wx = vx - t * nx if inv else vx
        wy = vy - t * ny if inv else vy
        wz = vz - t * nz if inv else vz
        ux, uy, uz = _normalize_select(ex - px, ey - py, ez - pz, fp)
        bx, by, bz = _normalize_select(wx - px, wy - py, wz - pz, fp)
        hx, hy, hz = _normalize_select(ux + bx, uy + by, uz + bz, fp)
        OUT[j] = (nx * hx + ny * hy) + nz * hz


# Per walk slot, the columns of its int64 state ``W``: the vertex's row (-1: the slot is free),
# the current pixel, the candidate moved to last (0: none, the previous neighbourhood's scores are
# unknown; -1: none, and the current pixel's score is unknown too: it is scored with the
# neighbours in the next round, a walk's start as every other candidate), the iterations of this
# phase and of the first, the phase (1: inverse search), the flags. Its float state ``SV``
# (working precision) holds the vertex (columns 0-2) and the score at the current pixel (column
# S0). The state is in two arrays, not one per field: each array a helper takes costs it a
# reference count increment and decrement per call.
VI, R, C, MOVED, IT, IT0, PH, FL = range(8)
S0 = 3


# The walks' helpers are compiled on their own and LLVM inlines their machine code into
# search_group: quick to compile, and the code of one function. Inlined at Numba's level instead,
# each array argument would become a variable of its own with a reference count increment and
# decrement (atomic) per call, which only the parallel passes' copy propagation removes.


@kernel(llvm_inline=True)
def _begin(vertices, starts, default_r, default_c, i, s, W, SV):
    """Walk slot ``s`` takes the vertex of row ``i``: its start (previous pixel, else the
    default start), whose score the next round computes; counters cleared, flags RESTARTED or
    none."""
    W[s, VI] = i
    for k in range(3):
        SV[s, k] = vertices[i, k]
    r0 = starts[i, 0]
    c0 = starts[i, 1]
    W[s, FL] = RESTARTED if r0 == RESTART else 0
    if r0 < 0:
        r0 = default_r
        c0 = default_c
    W[s, R] = r0
    W[s, C] = c0
    W[s, IT] = 0
    W[s, IT0] = 0
    W[s, PH] = 0
    W[s, MOVED] = -1


@kernel(inline=True)
def _push(cand, INV, m, P, N, r, c, SV, s, inverse):
    """Candidate ``m`` of the batch: pixel (r, c)'s P and N and slot ``s``'s vertex, scored
    inversely where ``inverse``. Returns ``m + 1``."""
    for ch in range(3):
        cand[ch, m] = P[r, c, ch]
        cand[3 + ch, m] = N[r, c, ch]
        cand[6 + ch, m] = SV[s, ch]
    INV[m] = inverse
    return m + 1


@kernel(llvm_inline=True)
def _gather(P, N, mask, NB, W, SV, cand, INV, IDX):
    """Gathers the candidates of this round that need a score, those of every active walk that
    are covered and not in its previous neighbourhood (whose scores are known), and the current
    pixel of a walk that has just started (its start's, or its inverse phase's): column ``m`` of
    ``cand`` (9, (NB + 1) * LANES) holds P, N of the candidate's pixel and its walk's vertex (one
    row per channel), ``INV[m]`` whether that walk is in its inverse phase. ``IDX[s * (NB + 1) +
    k]`` is where walk ``s``'s candidate ``k`` is: column ``m``; -1 uncovered or outside (or,
    for the current pixel ``k = 0``, known); ``-2 - j`` known, the previous neighbourhood's
    candidate ``j``. Returns the number of columns filled."""
    h, w = mask.shape
    m = 0
    for s in range(LANES):
        if W[s, VI] < 0:
            continue
        r = W[s, R]
        c = W[s, C]
        moved = W[s, MOVED]
        IDX[s * (NB + 1)] = -1
        if moved < 0:  # a start: covered (the start rules), scored here
            IDX[s * (NB + 1)] = m
            m = _push(cand, INV, m, P, N, r, c, SV, s, W[s, PH] == 1)
        for k in range(1, NB + 1):
            q = s * (NB + 1) + k
            rr = r + OFFSETS[k, 0]
            cc = c + OFFSETS[k, 1]
            if not (rr >= 0 and rr < h and cc >= 0 and cc < w and mask[rr, cc]):
                IDX[q] = -1
                continue
            if moved > 0:
                j = REUSE[moved, k]
                if j >= 0 and j < NB + 1:
                    IDX[q] = -2 - j
                    continue
            IDX[q] = m
            m = _push(cand, INV, m, P, N, rr, cc, SV, s, W[s, PH] == 1)
    return m


@kernel(llvm_inline=True)
def _compare(s, NB, SV, PREV, IDX, OUT, CUR, fp):
    """Walk ``s``'s neighbourhood in the visiting order, as ``_kernels.walk`` compares it: its
    scores into ``CUR`` (the current pixel's first; uncovered candidates left as they were).
    Returns ``(best_k, best, second, border)``: the best candidate (0: the current pixel), its
    score, the second-best score (``NO_SCORE`` when there is none) and whether a candidate is uncovered
    or outside."""
    j0 = IDX[s * (NB + 1)]
    if j0 >= 0:  # the current pixel scored in this round
        SV[s, S0] = OUT[j0]
    s0 = SV[s, S0]
    best = s0
    best_k = 0
    second = like(NO_SCORE, fp)
    border = False
    CUR[0] = s0
    for k in range(1, NB + 1):
        j = IDX[s * (NB + 1) + k]
        if j == -1:
            border = True
            continue
        sc = PREV[s, -2 - j] if j < -1 else OUT[j]
        CUR[k] = sc
        if sc > best:  # strictly larger: ties never move, earlier candidates win
            second = best
            best = sc
            best_k = k
        elif sc > second:
            second = sc
    return best_k, best, second, border


@kernel(llvm_inline=True)
def _move(s, NB, best_k, best, it, CUR, PREV, W, SV):
    """Walk ``s`` moves to its candidate ``best_k`` (score ``best``) after ``it`` steps; the
    neighbourhood's scores are kept for the next round."""
    for k in range(NB + 1):
        PREV[s, k] = CUR[k]
    W[s, MOVED] = best_k
    SV[s, S0] = best
    W[s, R] = W[s, R] + OFFSETS[best_k, 0]
    W[s, C] = W[s, C] + OFFSETS[best_k, 1]
    W[s, IT] = it


@kernel(llvm_inline=True)
def _end(inverse_search, fp, s, it, best_k, best, second, border, W, SV, px, py, pz, nx, ny, nz):
    """Walk ``s`` stops after ``it`` steps: converged (``best_k`` 0) or capped, at a pixel of
    position ``(px, py, pz)`` and normal ``(nx, ny, nz)`` (scalars: the G-buffer's arrays,
    shared by the threads, are not passed, and their reference counts not touched per walk). A
    hidden vertex's walk goes on as the inverse search from there, its pixel's inverse score
    computed in the next round (with ``inverse_search``: returns ``(False, ...)``); otherwise
    returns ``(True, score, margin, iterations, flags)``, the vertex's results (its pixel is the
    walk's: the slot is free once they are written)."""
    s0 = SV[s, S0]
    if best_k == 0:
        res_s = best
        res_m = best - second if second > like(NO_SCORE, fp) else like(LONE_MARGIN, fp)
    else:  # capped: the walk keeps the pixel whose neighbourhood it evaluated last
        res_s = s0
        res_m = best - s0
    vx = SV[s, 0]
    vy = SV[s, 1]
    vz = SV[s, 2]
    fl, total, inverse = end_walk_at(W[s, FL], W[s, IT0], it, best_k != 0, border, W[s, PH], vx, vy, vz, px, py, pz,
                                     nx, ny, nz, inverse_search, fp)
    if inverse:
        W[s, PH] = 1
        W[s, FL] = fl
        W[s, IT0] = total
        W[s, IT] = 0
        W[s, MOVED] = -1
    return not inverse, res_s, res_m, total, fl


@kernel
def search_group(P, N, mask, eye, vertices, starts, default_r, default_c, cap, inverse_search, fp, pixel, best_out,
                 margin_out, iterations, flags_out, NB, lo, hi, cand, INV, OUT, IDX, CUR, W, SV, PREV):
    """The searches of rows ``lo`` to ``hi - 1``, ``LANES`` walks at a time, each of ``NB``
    neighbours around its current pixel. ``NB`` is a constant of the compiled code (``literally``:
    one specialisation per neighbourhood). The last eight: :func:`search_work`'s arrays, set
    here as zeros (no walk in ``W``'s slots) before the group starts."""
    literally(NB)
    # per candidate of a round: P, N of its pixel and its vertex (one row per channel), whether
    # its walk is in the inverse phase, its score; where each walk's candidates are (_gather);
    # per walk slot: its state (W, SV) and the previous neighbourhood's scores
    for j in range((NB + 1) * LANES):
        for k in range(9):
            cand[k, j] = 0
        INV[j] = False
        OUT[j] = 0
        IDX[j] = 0
    for j in range(NB + 1):
        CUR[j] = 0
    for s in range(LANES):
        for k in range(8):
            W[s, k] = 0
        W[s, VI] = -1
        for k in range(4):
            SV[s, k] = 0
        for j in range(NB + 1):
            PREV[s, j] = 0
    P0 = cand[0]
    P1 = cand[1]
    P2 = cand[2]
    N0 = cand[3]
    N1 = cand[4]
    N2 = cand[5]
    VX = cand[6]
    VY = cand[7]
    VZ = cand[8]
    nxt = lo
    active = 0
    for s in range(LANES):
        if nxt < hi:
            _begin(vertices, starts, default_r, default_c, nxt, s, W, SV)
            nxt += 1
            active += 1
    while active > 0:
        m = _gather(P, N, mask, NB, W, SV, cand, INV, IDX)
        score_batch((m + VECTOR - 1) // VECTOR * VECTOR, P0, P1, P2, N0, N1, N2, eye[0], eye[1], eye[2], VX, VY, VZ,
                    INV, OUT, fp)
        for s in range(LANES):
            if W[s, VI] < 0:
                continue
            best_k, best, second, border = _compare(s, NB, SV, PREV, IDX, OUT, CUR, fp)
            it = W[s, IT] + 1
            if best_k != 0 and it < cap:
                _move(s, NB, best_k, best, it, CUR, PREV, W, SV)
                continue
            r = W[s, R]
            c = W[s, C]
            done, res_s, res_m, total, fl = _end(inverse_search, fp, s, it, best_k, best, second, border, W, SV,
                                                 P[r, c, 0], P[r, c, 1], P[r, c, 2], N[r, c, 0], N[r, c, 1],
                                                 N[r, c, 2])
            if not done:
                continue
            i = W[s, VI]
            pixel[i, 0] = r
            pixel[i, 1] = c
            best_out[i] = res_s
            margin_out[i] = res_m
            iterations[i] = total
            flags_out[i] = fl
            if nxt < hi:  # the slot takes the group's next vertex
                _begin(vertices, starts, default_r, default_c, nxt, s, W, SV)
                nxt += 1
            else:
                W[s, VI] = -1
                active -= 1


def _make_search(n_neighbours):
    """The lanes kernel for a neighbourhood of ``n_neighbours`` (4: the crosshair, 8: the box)
    around the current pixel, over groups ``lo .. hi - 1`` (run over every group by
    :func:`refsoft._parallel.parallel_range`). It calls ``search_group``, compiled on its own, with
    the count as a literal: a constant of the compiled code, one specialisation per neighbourhood,
    each as fast as one written for its neighbourhood alone."""
    NB = n_neighbours

    @kernel
    def search_lanes(lo, hi, P, N, mask, eye, vertices, starts, default_r, default_c, cap, inverse_search, fp, pixel,
                     best_out, margin_out, iterations, flags_out, cand, INV, OUT, IDX, CUR, W, SV, PREV):
        n = vertices.shape[0]
        for g in range(lo, hi):
            search_group(P, N, mask, eye, vertices, starts, default_r, default_c, cap, inverse_search, fp, pixel,
                         best_out, margin_out, iterations, flags_out, NB, g * SEARCH_GROUP,
                         min(n, (g + 1) * SEARCH_GROUP), cand, INV, OUT, IDX, CUR, W, SV, PREV)

    return search_lanes


def search_work(n_neighbours, dtype):
    """The work arrays of one part of a lanes kernel (``n_neighbours`` around the current pixel,
    ``dtype`` the G-buffer's float type): per candidate of a round ``cand`` (9, (NB + 1) LANES)
    (P, N of its pixel, its vertex), ``INV`` ((NB + 1) LANES,) bool, ``OUT`` ((NB + 1) LANES,)
    scores, ``IDX`` ((NB + 1) LANES,) int64; ``CUR`` (NB + 1,); per walk slot ``W`` (LANES, 8)
    int64, ``SV`` (LANES, 4) and ``PREV`` (LANES, NB + 1). Made by the caller (:func:`search_group` sets
    them) so that the kernel allocates nothing."""
    nb, dt = n_neighbours, np.dtype(dtype)
    k = (nb + 1) * LANES
    return (np.empty((9, k), dt), np.empty(k, np.bool_), np.empty(k, dt), np.empty(k, np.int64), np.empty(nb + 1, dt),
            np.empty((LANES, 8), np.int64), np.empty((LANES, 4), dt), np.empty((LANES, nb + 1), dt))


#: The lanes kernel by candidates per step (current pixel included), as ``search.NEIGHBOURHOODS``.
SEARCH = {5: _make_search(4), 9: _make_search(8)}
