"""Sub-texel refinement kernel (see :mod:`refsoft.search.refine`)."""

import numpy as np

from .._numba import kernel, like
from ._kernels import CULLED, HIDDEN, _normalize
from ._lanes import VECTOR, _normalize_select
from ..constants import MAX_OFFSET

#: Vertices whose steps' residuals are computed together (5 per vertex: a multiple of ``VECTOR``
#: columns).
BLOCK = 32


# _residual and _stencil are compiled on their own, not inlined at Numba's level: LLVM inlines
# their machine code into refine (the same speed), and refine compiles in a fraction of the time
# it took with every helper inlined into it.
@kernel
def _residual(P, N, r, c, vx, vy, vz, ex, ey, ez, fp):
    """``N - h`` at texel (r, c): h the bisector of the directions to the eye and to V."""
    ux, uy, uz = _normalize(ex - P[r, c, 0], ey - P[r, c, 1], ez - P[r, c, 2], fp)
    bx, by, bz = _normalize(vx - P[r, c, 0], vy - P[r, c, 1], vz - P[r, c, 2], fp)
    hx, hy, hz = _normalize(ux + bx, uy + by, uz + bz, fp)
    return N[r, c, 0] - hx, N[r, c, 1] - hy, N[r, c, 2] - hz


@kernel
def _stencil(mask, r, c, dr, dc, fp):
    """The two texels whose difference times ``scale`` is the derivative along (dr, dc) at
    (r, c): central when both neighbours are covered, one-sided next to an uncovered one, none
    (scale 0) when neither is. Returns (r_plus, c_plus, r_minus, c_minus, scale)."""
    h, w = mask.shape
    rm, cm, rp, cp = r - dr, c - dc, r + dr, c + dc
    minus = 0 <= rm < h and 0 <= cm < w and mask[rm, cm]
    plus = 0 <= rp < h and 0 <= cp < w and mask[rp, cp]
    if minus and plus:
        return rp, cp, rm, cm, like(0.5, fp)
    if plus:
        return rp, cp, r, c, like(1.0, fp)
    if minus:
        return r, c, rm, cm, like(1.0, fp)
    return r, c, r, c, like(0.0, fp)


@kernel(inline=True)
def surface_values(P, N, mask, r, c, t0, t1, fp):
    """P and unit N at (r + t0, c + t1) by the first-order model at texel (r, c):
    ``(px, py, pz, nx, ny, nz)``."""
    ar, ac, br, bc, sa = _stencil(mask, r, c, 1, 0, fp)
    cr, cc, dr, dc, sb = _stencil(mask, r, c, 0, 1, fp)
    ka = t0 * sa
    kb = t1 * sb
    px = (P[r, c, 0] + ka * (P[ar, ac, 0] - P[br, bc, 0])) + kb * (P[cr, cc, 0] - P[dr, dc, 0])
    py = (P[r, c, 1] + ka * (P[ar, ac, 1] - P[br, bc, 1])) + kb * (P[cr, cc, 1] - P[dr, dc, 1])
    pz = (P[r, c, 2] + ka * (P[ar, ac, 2] - P[br, bc, 2])) + kb * (P[cr, cc, 2] - P[dr, dc, 2])
    nx, ny, nz = _normalize((N[r, c, 0] + ka * (N[ar, ac, 0] - N[br, bc, 0])) + kb * (N[cr, cc, 0] - N[dr, dc, 0]),
                            (N[r, c, 1] + ka * (N[ar, ac, 1] - N[br, bc, 1])) + kb * (N[cr, cc, 1] - N[dr, dc, 1]),
                            (N[r, c, 2] + ka * (N[ar, ac, 2] - N[br, bc, 2])) + kb * (N[cr, cc, 2] - N[dr, dc, 2]),
                            fp)
    return px, py, pz, nx, ny, nz


@kernel(inline=True)
def _surface(P, N, mask, r, c, t0, t1, fp, out_p, out_n, i):
    """:func:`surface_values` written to row ``i`` of ``out_p`` and ``out_n``."""
    px, py, pz, nx, ny, nz = surface_values(P, N, mask, r, c, t0, t1, fp)
    out_p[i, 0] = px
    out_p[i, 1] = py
    out_p[i, 2] = pz
    out_n[i, 0] = nx
    out_n[i, 1] = ny
    out_n[i, 2] = nz


@kernel(inline=True)
def _solve(d0, pa, pb, pc, pd, sa, sb, fp):
    """The Gauss-Newton step (rows, cols) from the residual ``d0`` at the texel and at the
    stencils' texels (the derivative ``pa - pb`` times ``sa`` along rows, ``pc - pd`` times
    ``sb`` along columns), not clamped."""
    zero = like(0.0, fp)
    j00, j01, j02 = (pa[0] - pb[0]) * sa, (pa[1] - pb[1]) * sa, (pa[2] - pb[2]) * sa
    j10, j11, j12 = (pc[0] - pd[0]) * sb, (pc[1] - pd[1]) * sb, (pc[2] - pd[2]) * sb
    # normal equations of min |d0 + J t|^2, t = (rows, cols)
    a00 = (j00 * j00 + j01 * j01) + j02 * j02
    a01 = (j00 * j10 + j01 * j11) + j02 * j12
    a11 = (j10 * j10 + j11 * j11) + j12 * j12
    b0 = -((j00 * d0[0] + j01 * d0[1]) + j02 * d0[2])
    b1 = -((j10 * d0[0] + j11 * d0[1]) + j12 * d0[2])
    det = a00 * a11 - a01 * a01
    t0 = zero
    t1 = zero
    if det > like(1e-6, fp) * (a00 * a11):
        t0 = (a11 * b0 - a01 * b1) / det
        t1 = (a00 * b1 - a01 * b0) / det
    elif a11 == zero and a00 > zero:
        t0 = b0 / a00  # only the rows are usable
    elif a00 == zero and a11 > zero:
        t1 = b1 / a11  # only the columns
    return t0, t1


@kernel
def gauss_newton_step(P, N, mask, r, c, vx, vy, vz, ex, ey, ez, fp):
    """One Gauss-Newton step on ``N(x) - h(x) = 0`` for the vertex (vx, vy, vz) from the covered
    texel (r, c), the residual's derivatives by central differences (one-sided next to uncovered
    texels, none along an axis with no covered neighbour): the offset (rows, cols) in texels,
    not clamped."""
    d0 = _residual(P, N, r, c, vx, vy, vz, ex, ey, ez, fp)
    # the residual's derivatives along rows and columns
    ar, ac, br, bc, sa = _stencil(mask, r, c, 1, 0, fp)
    pa = _residual(P, N, ar, ac, vx, vy, vz, ex, ey, ez, fp)
    pb = _residual(P, N, br, bc, vx, vy, vz, ex, ey, ez, fp)
    cr, cc, dr, dc, sb = _stencil(mask, r, c, 0, 1, fp)
    pc = _residual(P, N, cr, cc, vx, vy, vz, ex, ey, ez, fp)
    pd = _residual(P, N, dr, dc, vx, vy, vz, ex, ey, ez, fp)
    return _solve(d0, pa, pb, pc, pd, sa, sb, fp)


@kernel
def residual_batch(n, B, ex, ey, ez, fp):
    """Columns ``0 .. n - 1`` of the block ``B`` (12, M): from P (rows 0-2), N (3-5) and the
    vertex V (6-8) of a texel, the residual ``N - normalize(normalize(O - P) + normalize(V - P))``
    (rows 9-11), the arithmetic of :func:`_residual` written with selects (no branch) so that
    the loop vectorizes: the same values, bit for bit."""
    for j in range(n):
        px = B[0, j]
        py = B[1, j]
        pz = B[2, j]
        vx = B[6, j]
        vy = B[7, j]
        vz = B[8, j]
        ux, uy, uz = _normalize_select(ex - px, ey - py, ez - pz, fp)
        bx, by, bz = _normalize_select(vx - px, vy - py, vz - pz, fp)
        hx, hy, hz = _normalize_select(ux + bx, uy + by, uz + bz, fp)
        B[9, j] = B[3, j] - hx
        B[10, j] = B[4, j] - hy
        B[11, j] = B[5, j] - hz


@kernel(llvm_inline=True)
def _put(B, m, P, N, r, c, vx, vy, vz):
    """Column ``m`` of the block: P and N of texel (r, c) and the vertex."""
    for k in range(3):
        B[k, m] = P[r, c, k]
        B[3 + k, m] = N[r, c, k]
    B[6, m] = vx
    B[7, m] = vy
    B[8, m] = vz


@kernel
def refine(lo, hi, P, N, mask, vertices, origin, eye, pixel, flags, fp, out_p, out_n, out_offset, B, S):
    """For each vertex ``lo .. hi - 1`` (run over every vertex by
    :func:`refsoft._parallel.parallel_range`): one Gauss-Newton step on ``N(x) - h(x) = 0`` from
    its reflection pixel, with the residual's derivatives by central differences (one-sided next to uncovered texels,
    none along an axis with no covered neighbour), then P and N at the new point by the same
    first-order model (:func:`_surface`). Arithmetic in the precision of ``fp``, ``vertices``
    (world space, float64) taken relative to ``origin`` (3,) float64 and rounded to it; ``eye``
    relative to the origin already. Vertices CULLED or HIDDEN keep their texel's P and N
    (offset 0; zeros when CULLED).

    The vertices go in blocks of ``BLOCK``: the five residuals of each vertex's step (at its
    texel and its stencils' four) are gathered into the columns of ``B`` (12, 5 BLOCK) and
    computed together by :func:`residual_batch` (vectorized), then each step is solved as
    :func:`gauss_newton_step` solves it (the same offsets, bit for bit). ``S`` (2, BLOCK) holds
    each vertex's stencil scales. ``B`` and ``S`` are :func:`refine_work`'s arrays."""
    zero = like(0.0, fp)
    lim = like(MAX_OFFSET, fp)
    ex, ey, ez = eye[0], eye[1], eye[2]
    for j in range(B.shape[1]):  # columns past the block's end are computed too, never read
        for k in range(12):
            B[k, j] = zero
    for b0 in range(lo, hi, BLOCK):
        b1 = min(b0 + BLOCK, hi)
        m = 0
        for i in range(b0, b1):
            if flags[i] & (CULLED | HIDDEN):
                continue
            r = pixel[i, 0]
            c = pixel[i, 1]
            vx = like(vertices[i, 0] - origin[0], fp)
            vy = like(vertices[i, 1] - origin[1], fp)
            vz = like(vertices[i, 2] - origin[2], fp)
            ar, ac, br, bc, sa = _stencil(mask, r, c, 1, 0, fp)
            cr, cc, dr, dc, sb = _stencil(mask, r, c, 0, 1, fp)
            S[0, i - b0] = sa
            S[1, i - b0] = sb
            _put(B, m, P, N, r, c, vx, vy, vz)
            _put(B, m + 1, P, N, ar, ac, vx, vy, vz)
            _put(B, m + 2, P, N, br, bc, vx, vy, vz)
            _put(B, m + 3, P, N, cr, cc, vx, vy, vz)
            _put(B, m + 4, P, N, dr, dc, vx, vy, vz)
            m += 5
        residual_batch((m + VECTOR - 1) // VECTOR * VECTOR, B, ex, ey, ez, fp)
        m = 0
        for i in range(b0, b1):
            r = pixel[i, 0]
            c = pixel[i, 1]
            out_offset[i, 0] = zero
            out_offset[i, 1] = zero
            if flags[i] & CULLED:
                for k in range(3):
                    out_p[i, k] = zero
                    out_n[i, k] = zero
                continue
            if flags[i] & HIDDEN:
                for k in range(3):
                    out_p[i, k] = P[r, c, k]
                    out_n[i, k] = N[r, c, k]
                continue
            t0, t1 = _solve((B[9, m], B[10, m], B[11, m]), (B[9, m + 1], B[10, m + 1], B[11, m + 1]),
                            (B[9, m + 2], B[10, m + 2], B[11, m + 2]), (B[9, m + 3], B[10, m + 3], B[11, m + 3]),
                            (B[9, m + 4], B[10, m + 4], B[11, m + 4]), S[0, i - b0], S[1, i - b0], fp)
            m += 5
            t0 = min(max(t0, -lim), lim)
            t1 = min(max(t1, -lim), lim)
            out_offset[i, 0] = t0
            out_offset[i, 1] = t1
            _surface(P, N, mask, r, c, t0, t1, fp, out_p, out_n, i)


@kernel
def check_pixels(pixel, flags, mask):
    """Whether every vertex not CULLED has its reflection pixel (row, col) on a covered texel:
    0 yes; 1 a pixel lies outside the (h, w) ``mask``; else 2 a pixel is not covered."""
    h, w = mask.shape
    found = 0
    for i in range(pixel.shape[0]):
        if flags[i] & CULLED:
            continue
        r = pixel[i, 0]
        c = pixel[i, 1]
        if r < 0 or r >= h or c < 0 or c >= w:
            return 1
        if not mask[r, c]:
            found = 2
    return found


def refine_work(dtype):
    """The work arrays of one part of :func:`refine`: the block ``B`` (12, 5 BLOCK) and the
    stencil scales ``S`` (2, BLOCK), of the G-buffer's float type (made by the caller, so that
    the kernel allocates nothing)."""
    return np.empty((12, 5 * BLOCK), dtype), np.empty((2, BLOCK), dtype)


@kernel
def surface_at(lo, hi, P, N, mask, pixel, offset, fp, out_p, out_n):
    """P and unit N at texel ``pixel[i]`` plus ``offset[i]`` (rows, cols), by the first-order
    model of :func:`refine`, for ``i`` in ``lo .. hi - 1``."""
    for i in range(lo, hi):
        _surface(P, N, mask, pixel[i, 0], pixel[i, 1], offset[i, 0], offset[i, 1], fp, out_p, out_n, i)
