"""Kernels of the ray tiles: the reflected rays of a stencil box bounded per square tile of pixels,
so that the rays that may hit a triangle are found without testing every ray (the ray-cone
bounds of :mod:`refsoft.search._hierarchy` turned around: here the rays are bounded, the
triangle is a sphere).

A tile's bound is a ball of its rays' origins (centre ``A``, radius ``a``) and a cone of their
unit directions (axis ``d``, half-angle ``alpha``). A ray from ``O`` (within ``a`` of ``A``) along a
unit ``D`` (within ``alpha`` of ``d``) meets a ball (centre ``C``, radius ``rho``, ``L = |C - A| >
rho + a``) only if ``angle(d, C - A) <= alpha + asin(rho / (L - a)) + asin(a / L)``: the angle from
``D`` to ``C - O`` is at most ``asin(rho / |C - O|)`` and ``C - O`` turns at most ``asin(a / L)``
from ``C - A``. A tile that fails cannot hold a ray that hits the triangle in the ball; the rays of
the others get the exact test (``_several._may_hit``), so a triangle's list is the brute-force
list (``_several.rays_near_every``) less rays that cannot hit it.
"""

import numpy as np

from .._numba import kernel
from ._several import _may_hit, _triangle

# tile bound columns: origin centre (3), origin radius, axis (3), half-angle, longest direction,
# rays in the tile, "keep every ray" (a value that is not finite)
TILE_WIDTH = 11


@kernel
def tile_bounds(lo, hi, valid, origin, direction, size, n_cols, out):
    """Tile rows ``lo .. hi - 1`` of ``size`` x ``size`` pixel tiles over the box (``n_cols`` tiles a
    row): ``out`` (n_rows * n_cols, TILE_WIDTH) float64, each tile's bound of its valid rays (the
    ray count 0 where it has none)."""
    h, w = valid.shape
    for tr in range(lo, hi):
        for tc in range(n_cols):
            b = out[tr * n_cols + tc]
            for k in range(TILE_WIDTH):
                b[k] = 0.0
            r0, r1 = tr * size, min(h, tr * size + size)
            c0, c1 = tc * size, min(w, tc * size + size)
            lo_x, lo_y, lo_z = np.inf, np.inf, np.inf
            hi_x, hi_y, hi_z = -np.inf, -np.inf, -np.inf
            sx, sy, sz = 0.0, 0.0, 0.0
            n = 0
            odd = False
            dmax = 0.0
            for r in range(r0, r1):
                for c in range(c0, c1):
                    if not valid[r, c]:
                        continue
                    ox, oy, oz = origin[r, c, 0], origin[r, c, 1], origin[r, c, 2]
                    dx, dy, dz = direction[r, c, 0], direction[r, c, 1], direction[r, c, 2]
                    ln = np.sqrt((dx * dx + dy * dy) + dz * dz)
                    if not (np.isfinite(ox) and np.isfinite(oy) and np.isfinite(oz) and np.isfinite(ln) and ln > 0.0):
                        odd = True
                        n += 1
                        continue
                    lo_x, lo_y, lo_z = min(lo_x, ox), min(lo_y, oy), min(lo_z, oz)
                    hi_x, hi_y, hi_z = max(hi_x, ox), max(hi_y, oy), max(hi_z, oz)
                    sx, sy, sz = sx + dx / ln, sy + dy / ln, sz + dz / ln
                    dmax = max(dmax, ln)
                    n += 1
            b[9] = n
            if n == 0:
                continue
            if odd:
                b[10] = 1.0
                continue
            ax, ay, az = 0.5 * (lo_x + hi_x), 0.5 * (lo_y + hi_y), 0.5 * (lo_z + hi_z)
            sn = np.sqrt((sx * sx + sy * sy) + sz * sz)
            if not sn > 0.0:
                b[10] = 1.0
                continue
            sx, sy, sz = sx / sn, sy / sn, sz / sn
            rad = 0.0
            ang = 0.0
            for r in range(r0, r1):
                for c in range(c0, c1):
                    if not valid[r, c]:
                        continue
                    ex, ey, ez = origin[r, c, 0] - ax, origin[r, c, 1] - ay, origin[r, c, 2] - az
                    rad = max(rad, np.sqrt((ex * ex + ey * ey) + ez * ez))
                    dx, dy, dz = direction[r, c, 0], direction[r, c, 1], direction[r, c, 2]
                    cx, cy, cz = sy * dz - sz * dy, sz * dx - sx * dz, sx * dy - sy * dx
                    ang = max(ang, np.arctan2(np.sqrt((cx * cx + cy * cy) + cz * cz), (sx * dx + sy * dy) + sz * dz))
            b[0], b[1], b[2], b[3] = ax, ay, az, rad
            b[4], b[5], b[6], b[7] = sx, sy, sz, ang
            b[8] = dmax


@kernel(inline=True)
def _could_meet(b, cx, cy, cz, rho):
    """Whether a ray of the tile bound ``b`` may pass within ``rho`` of (cx, cy, cz) (module
    docstring); True for a tile whose bound is not finite. The angles get a relative slack of
    1e-9 and an absolute one of 1e-9 rad for their rounding."""
    if b[9] == 0.0:
        return False
    if b[10] != 0.0:
        return True
    ex, ey, ez = cx - b[0], cy - b[1], cz - b[2]
    L = np.sqrt((ex * ex + ey * ey) + ez * ez)
    a = b[3]
    if not L > (rho + a) * (1.0 + 1e-9):
        return True
    qx, qy, qz = b[5] * ez - b[6] * ey, b[6] * ex - b[4] * ez, b[4] * ey - b[5] * ex
    beta = np.arctan2(np.sqrt((qx * qx + qy * qy) + qz * qz), (b[4] * ex + b[5] * ey) + b[6] * ez)
    limit = b[7] + np.arcsin(min(1.0, rho / (L - a))) + np.arcsin(min(1.0, a / L))
    return beta <= limit * (1.0 + 1e-9) + 1e-9


@kernel(inline=True)
def _ball(real, f, margin, dmax):
    """The centre and radius of a ball holding every point ``_may_hit`` can accept on triangle
    ``f`` (barycentrics ``margin`` outside, ``t`` down to ``-margin (|e1| + |e2|)`` along a
    direction at most ``dmax`` long); radius inf when a corner is not finite."""
    cx = (real[f, 0, 0] + real[f, 1, 0] + real[f, 2, 0]) / 3.0
    cy = (real[f, 0, 1] + real[f, 1, 1] + real[f, 2, 1]) / 3.0
    cz = (real[f, 0, 2] + real[f, 1, 2] + real[f, 2, 2]) / 3.0
    rho = 0.0
    for k in range(3):
        ex, ey, ez = real[f, k, 0] - cx, real[f, k, 1] - cy, real[f, k, 2] - cz
        rho = max(rho, np.sqrt((ex * ex + ey * ey) + ez * ez))
    e1x, e1y, e1z = real[f, 1, 0] - real[f, 0, 0], real[f, 1, 1] - real[f, 0, 1], real[f, 1, 2] - real[f, 0, 2]
    e2x, e2y, e2z = real[f, 2, 0] - real[f, 0, 0], real[f, 2, 1] - real[f, 0, 1], real[f, 2, 2] - real[f, 0, 2]
    edges = np.sqrt((e1x * e1x + e1y * e1y) + e1z * e1z) + np.sqrt((e2x * e2x + e2y * e2y) + e2z * e2z)
    # the barycentric margin moves a point at most 2 margin (|e1| + |e2|); t's margin along d
    rho = (rho + 2.0 * margin * edges + margin * edges * dmax) * (1.0 + 1e-9)
    if not (np.isfinite(cx) and np.isfinite(cy) and np.isfinite(cz) and np.isfinite(rho)):
        return 0.0, 0.0, 0.0, np.inf
    return cx, cy, cz, rho


@kernel
def rays_near_tiles(lo, hi, real, valid, origin, direction, ray_id, fine, coarse, size, ratio, margin, parallel,
                    dmax, count, start, out, fill, blocks, tiles):
    """Triangles ``lo .. hi - 1``: the rays (indices ``ray_id`` (h, w) of the box's valid pixels,
    row-major) that may hit each one, ascending: those of the ``fine`` tiles (``size`` pixels a
    side) whose bound meets the triangle's ball, inside the ``coarse`` tiles (``ratio`` fine tiles a
    side) whose bound does, that ``_several._may_hit`` keeps. ``fill`` False: ``count[f]``
    written; True: the rays written to ``out[start[f]:]``. ``blocks`` (coarse tiles a row,) and
    ``tiles`` (fine tiles a row,) int64 are work arrays."""
    h, w = valid.shape
    n_fine_cols = (w + size - 1) // size
    n_fine_rows = (h + size - 1) // size
    big = size * ratio
    n_coarse_cols = (w + big - 1) // big
    n_coarse_rows = (h + big - 1) // big
    for f in range(lo, hi):
        if fill and count[f] == 0:
            continue
        cx, cy, cz, rho = _ball(real, f, margin, dmax)
        tri = _triangle(real, f, margin, parallel)
        n = 0
        pos = start[f] if fill else 0
        every = not rho < np.inf
        for br in range(n_coarse_rows):
            nb = 0
            for bc in range(n_coarse_cols):
                if every or _could_meet(coarse[br * n_coarse_cols + bc], cx, cy, cz, rho):
                    blocks[nb] = bc
                    nb += 1
            if nb == 0:
                continue
            for tr in range(br * ratio, min(n_fine_rows, br * ratio + ratio)):
                nt = 0
                for m in range(nb):
                    bc = blocks[m]
                    for tc in range(bc * ratio, min(n_fine_cols, bc * ratio + ratio)):
                        if every or _could_meet(fine[tr * n_fine_cols + tc], cx, cy, cz, rho):
                            tiles[nt] = tc
                            nt += 1
                for r in range(tr * size, min(h, tr * size + size)):
                    for m in range(nt):
                        tc = tiles[m]
                        for c in range(tc * size, min(w, tc * size + size)):
                            k = ray_id[r, c]
                            if k < 0:
                                continue
                            dx, dy, dz = direction[r, c, 0], direction[r, c, 1], direction[r, c, 2]
                            ln = np.sqrt((dx * dx + dy * dy) + dz * dz)
                            if not _may_hit(tri, origin[r, c, 0], origin[r, c, 1], origin[r, c, 2], dx, dy, dz, ln,
                                            margin):
                                continue
                            if fill:
                                out[pos + n] = k
                            n += 1
        if not fill:
            count[f] = n
