"""Kernels of the searches at a later bounce (spec section 5.1): the G-buffer of a reflector seen
in an earlier bounce's image, where each pixel has its own eye (the previous bounce point)."""

import numpy as np

from .._numba import kernel
from ._kernels import RECORD_WIDTH, _normalize, search_one
from ._several import _may_hit, _triangle
from ._tessellate import thesis_error


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
def edge_errors(lo, hi, P, N, mask, origin, E, verts, pixel, e0, e1, out):
    """``out[i]`` for ``i`` in ``lo .. hi - 1``: the thesis's error of edge (e0[i], e1[i]) at a
    later bounce, taken at the texel halfway between its ends' pixels (rounded down) with that
    texel's own eye ``E`` (h, w, 3) float64 world; 1 where an end has no pixel or that texel is
    not covered. ``_tessellate.edge_errors`` without sub-texel points, the one eye replaced by the
    texel's (with every eye the camera's: its results bit for bit)."""
    for i in range(lo, hi):
        a = e0[i]
        b = e1[i]
        out[i] = 1.0
        if pixel[a, 0] < 0 or pixel[a, 1] < 0 or pixel[b, 0] < 0 or pixel[b, 1] < 0:
            continue
        hr = (pixel[a, 0] + pixel[b, 0]) // 2
        hc = (pixel[a, 1] + pixel[b, 1]) // 2
        if not mask[hr, hc]:
            continue
        px = np.float64(P[hr, hc, 0]) + origin[0]
        py = np.float64(P[hr, hc, 1]) + origin[1]
        pz = np.float64(P[hr, hc, 2]) + origin[2]
        nx, ny, nz = np.float64(N[hr, hc, 0]), np.float64(N[hr, hc, 1]), np.float64(N[hr, hc, 2])
        out[i] = thesis_error(px, py, pz, nx, ny, nz, E[hr, hc, 0], E[hr, hc, 1], E[hr, hc, 2], verts, a, b)


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



@kernel
def rays_by_tiles(lo, hi, tri, coarse, fine, index, size, real, rays, margin, parallel, count, start, out, fill,
                  coarse_band, fine_band):
    """Triangles ``lo .. hi - 1`` (run by :func:`refsoft._parallel.parallel_range`; each writes only
    its own outputs): the rays that may hit it by :func:`refsoft.search._several.rays_near`'s test
    (the same arithmetic), ascending, each tested only where its fine tile (``size`` x ``size``
    pixels of ``index``, four a side in a coarse tile) may come near the triangle
    (:func:`_tile_meets`, a fine tile tried only in a coarse tile that may).

    Parameters
    ----------
    tri : (F, 10) float64
        Per triangle: centroid, the radius about it that holds the triangle widened by the
        pruning's margin, the unit normal, the sine and cosine of the angle to its plane within
        which a ray is kept as parallel, and 1 where every ray is kept (degenerate)
        (:func:`refsoft.search.meet._triangles`).
    coarse, fine : (TR, TC, 11) float64
        Per tile: its origins' centre and radius, its directions' unit axis, the cosine and sine of
        the cone's half-angle, 1 where it holds a ray, 1 where it is kept for every triangle
        (:func:`refsoft.search.meet._tiles`).
    index : (h, w) int64
        Each pixel's ray index (row-major over the valid pixels), -1 none.
    real : (F, 3, 3) float64
        The triangles.
    rays : (7, R) float64
        Origins (x, y, z), directions (x, y, z) and direction lengths, one row each.
    margin, parallel : float
        ``constants.SEVERAL_PRUNE_MARGIN``, ``constants.SEVERAL_PRUNE_PARALLEL``.
    count, start : (F,) int64
        ``fill`` False: ``count`` written (each triangle's number of rays); True: read, and
        ``start`` where its rays go in ``out``.
    out : (T,) int64
    coarse_band, fine_band : (TC,) int64
        Work: the tiles of one band that are kept.
    """
    h, w = index.shape
    n_cr, n_cc = coarse.shape[0], coarse.shape[1]
    n_fr, n_fc = fine.shape[0], fine.shape[1]
    for f in range(lo, hi):
        n = 0
        pos = start[f] if fill else 0
        if fill and count[f] == 0:
            continue
        near = _triangle(real, f, margin, parallel)
        for cr in range(n_cr):
            if fill and n == count[f]:  # every ray of it written: the bands below hold none
                break
            kc = 0
            for cc in range(n_cc):
                if _tile_meets(tri, f, coarse, cr, cc):
                    coarse_band[kc] = cc
                    kc += 1
            if kc == 0:
                continue
            for fr in range(4 * cr, min(n_fr, 4 * cr + 4)):
                k = 0
                for j in range(kc):
                    for fc in range(4 * coarse_band[j], min(n_fc, 4 * coarse_band[j] + 4)):
                        if _tile_meets(tri, f, fine, fr, fc):
                            fine_band[k] = fc
                            k += 1
                for r in range(fr * size, min(h, (fr + 1) * size)):
                    for j in range(k):
                        c0 = fine_band[j] * size
                        for c in range(c0, min(w, c0 + size)):
                            q = index[r, c]
                            if q >= 0 and _may_hit(near, rays[0, q], rays[1, q], rays[2, q], rays[3, q],
                                                   rays[4, q], rays[5, q], rays[6, q], margin):
                                if fill:
                                    out[pos + n] = q
                                n += 1
        if not fill:
            count[f] = n


@kernel(inline=True)
def _tile_meets(tri, f, tiles, i, j):
    """Whether a ray of tile (i, j) may pass within the radius of triangle ``f``'s centre, or lie
    within the parallel rule's angle of its plane: with ``w`` from the tile's centre to the
    triangle's, a ray from within the tile's radius along a direction within the cone's
    half-angle ``alpha`` of its axis ``a`` passes the centre at least ``|w| sin(phi) - radius``
    away, ``phi`` the angle between ``w`` and the ray's line, at least ``angle(w, +-a) - alpha``:
    it may come near when ``angle(w, +-a) <= alpha + asin((rho + radius) / |w|)``, compared by
    cosines. A ray within ``eps`` of the plane (sine ``tri``'s parallel rule) may be in the cone
    when ``|a . n| <= sin(alpha + eps)``."""
    if tiles[i, j, 9] == 0.0:  # no ray
        return False
    if tiles[i, j, 10] != 0.0 or tri[f, 9] != 0.0:
        return True
    wx, wy, wz = tri[f, 0] - tiles[i, j, 0], tri[f, 1] - tiles[i, j, 1], tri[f, 2] - tiles[i, j, 2]
    wl = np.sqrt((wx * wx + wy * wy) + wz * wz)
    reach = tri[f, 3] + tiles[i, j, 3]
    if wl <= reach:
        return True
    ax, ay, az = tiles[i, j, 4], tiles[i, j, 5], tiles[i, j, 6]
    ca, sa = tiles[i, j, 7], tiles[i, j, 8]
    c = abs((wx * ax + wy * ay) + wz * az) / wl
    sg = reach / wl
    cg = np.sqrt(1.0 - sg * sg)
    if c >= ca * cg - sa * sg - 1e-9:
        return True
    if ca * tri[f, 8] - sa * tri[f, 7] <= 0.0:  # alpha + eps reaches the plane: cos(alpha + eps) <= 0
        return True
    an = abs((ax * tri[f, 4] + ay * tri[f, 5]) + az * tri[f, 6])
    return an <= sa * tri[f, 8] + ca * tri[f, 7] + 1e-9
