"""Kernels of the searches at a later bounce (spec section 5.1): the G-buffer of a reflector seen
in an earlier bounce's image, where each pixel has its own eye (the previous bounce point)."""

import numpy as np

from .._numba import kernel
from ._kernels import RECORD_WIDTH, _normalize, search_one


@kernel
def pack_eyes(lo, hi, P, N, mask, E, fp, G):
    """Rows ``lo .. hi - 1`` of ``G`` (H, W, 9), zeros on entry: P, N and U = normalize(E - P)
    at covered pixels, with ``E`` (H, W, 3) each pixel's own eye (``_kernels.pack`` with one eye
    per pixel: the same arithmetic)."""
    w = mask.shape[1]
    for r in range(lo, hi):
        for c in range(w):
            if mask[r, c]:
                for k in range(3):
                    G[r, c, k] = P[r, c, k]
                    G[r, c, 3 + k] = N[r, c, k]
                ux, uy, uz = _normalize(E[r, c, 0] - P[r, c, 0], E[r, c, 1] - P[r, c, 1], E[r, c, 2] - P[r, c, 2], fp)
                G[r, c, 6] = ux
                G[r, c, 7] = uy
                G[r, c, 8] = uz


@kernel
def search_each(lo, hi, G, mask, V, starts, n_candidates, cap, inverse, fp, pixel, score, margin, iterations, flags):
    """Vertices ``lo .. hi - 1``: the walk of spec section 4.2 (``_kernels.search_one``; with
    ``inverse``, spec section 4.6's inverse search for a hidden vertex, from the pixel the walk
    ended on, its score with each pixel's own eye, the ``U`` packed in ``G``) in the packed
    G-buffer ``G`` from ``starts[i]`` (covered), each vertex's results written to its own rows."""
    scratch = np.empty((2, 9), dtype=G.dtype)
    seen = np.zeros((2, 9), dtype=np.bool_)
    record = np.empty((0, RECORD_WIDTH), dtype=np.float64)  # nothing recorded
    v = np.empty(3, dtype=G.dtype)
    for i in range(lo, hi):
        for k in range(3):
            v[k] = V[i, k]
        r, c, s, m, it, fl, _ = search_one(G, mask, v, starts[i, 0], starts[i, 1], n_candidates, cap, inverse, fp,
                                           record, scratch, seen)
        pixel[i, 0] = r
        pixel[i, 1] = c
        score[i] = s
        margin[i] = m
        iterations[i] = it
        flags[i] = fl



@kernel
def ray_distances(lo, hi, V, O, D, L, near):
    """Rows ``lo .. hi - 1`` of ``near`` (N,) float64: the least distance from point ``V[i]``
    (N, 3) to the rays of origins ``O`` (P, 3) and unit directions ``D`` (P, 3), each ray the part
    ahead of its origin up to length ``L`` (P,) (np.inf: all of it; ``t = min(max((V - O).D, 0),
    L)``, the distance ``|V - O - t D|``), the rays in order (np.inf with none)."""
    for i in range(lo, hi):
        best = np.inf
        for p in range(O.shape[0]):
            cx, cy, cz = V[i, 0] - O[p, 0], V[i, 1] - O[p, 1], V[i, 2] - O[p, 2]
            t = (cx * D[p, 0] + cy * D[p, 1]) + cz * D[p, 2]
            if t < 0.0:
                t = 0.0
            if t > L[p]:
                t = L[p]
            ex, ey, ez = cx - t * D[p, 0], cy - t * D[p, 1], cz - t * D[p, 2]
            d2 = (ex * ex + ey * ey) + ez * ez
            if d2 < best:
                best = d2
        near[i] = np.sqrt(best)  # the root of the least square: the least root (sqrt is monotonic)


@kernel
def faces_within(lo, hi, faces, near, edge, out):
    """Rows ``lo .. hi - 1`` of ``out`` (T,) bool: whether each corner of face ``faces[i]`` (T, 3)
    lies within ``edge[i] * (1 + 1e-9)`` of a ray (``near`` (V,): :func:`ray_distances`)."""
    for i in range(lo, hi):
        e = edge[i] * (1.0 + 1e-9)
        out[i] = near[faces[i, 0]] <= e and near[faces[i, 1]] <= e and near[faces[i, 2]] <= e


@kernel
def _score(S, k, V, i):
    """Float64 score of vertex ``V[i]`` at sample ``S[k]`` (P, N, U): :func:`best_starts`'s."""
    dx, dy, dz = V[i, 0] - S[k, 0], V[i, 1] - S[k, 1], V[i, 2] - S[k, 2]
    d = np.sqrt((dx * dx + dy * dy) + dz * dz)
    if d < 1e-300:
        d = 1e-300
    hx, hy, hz = S[k, 6] + dx / d, S[k, 7] + dy / d, S[k, 8] + dz / d
    m = np.sqrt((hx * hx + hy * hy) + hz * hz)
    if m < 1e-300:
        m = 1e-300
    return ((hx / m) * S[k, 3] + (hy / m) * S[k, 4]) + (hz / m) * S[k, 5]


@kernel
def best_starts(lo, hi, S, V, X, has, out):
    """Rows ``lo .. hi - 1`` of ``out`` (n,) int64: per vertex ``V[i]`` (n, 3) float64 (relative to
    the G-buffer's origin) the sample of ``S`` (K, 9) float64 (P, N, U of K covered pixels) where
    its score is highest, the first among equals (a NaN score counts as highest, as np.argmax
    takes it); K where ``has[i]`` and its own sample ``X[i]`` (n, 9) scores higher still (its
    previous frame's pixel). Score in float64: ``b = (V - P) / max(|V - P|, 1e-300)``, ``h = (U +
    b) / max(|U + b|, 1e-300)``, ``s = (h.x N.x + h.y N.y) + h.z N.z``."""
    for i in range(lo, hi):
        best, top = -1, 0.0
        for k in range(S.shape[0]):
            s = _score(S, k, V, i)
            if s != s:  # NaN: the highest
                best, top = k, s
                break
            if best < 0 or s > top:
                best, top = k, s
        if has[i] and top == top and _score(X, i, V, i) > top:
            best = S.shape[0]
        out[i] = best

