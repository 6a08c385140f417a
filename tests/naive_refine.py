"""The sub-texel refinement (refsoft.search.refine.refine) in plain NumPy with the kernel's own
arithmetic: every operation in the G-buffer's precision and in the kernel's order (array
operations, each an IEEE operation rounded once), so that its results are the kernel's bit for
bit. (``naive.naive_refine`` is the same method written in float64 for the reader.)"""

import numpy as np


def _normalize(x, y, z):
    """``x * (1 / sqrt((x x + y y) + z z))`` per element, zero where the length is not positive."""
    length = np.sqrt((x * x + y * y) + z * z)
    pos = length > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = np.where(pos, length.dtype.type(1) / np.where(pos, length, 1), 0).astype(length.dtype)
    return (np.where(pos, x * inv, 0).astype(x.dtype), np.where(pos, y * inv, 0).astype(x.dtype),
            np.where(pos, z * inv, 0).astype(x.dtype))


def _stencil(mask, r, c, dr, dc, dt):
    """Per vertex the texels (plus, minus) of the difference along (dr, dc) and its scale: 0.5
    central, 1 one-sided, 0 none."""
    h, w = mask.shape

    def covered(rr, cc):
        inside = (rr >= 0) & (rr < h) & (cc >= 0) & (cc < w)
        return inside & mask[np.clip(rr, 0, h - 1), np.clip(cc, 0, w - 1)]

    minus, plus = covered(r - dr, c - dc), covered(r + dr, c + dc)
    rp = np.where(plus, r + dr, r)
    cp = np.where(plus, c + dc, c)
    rm = np.where(minus, r - dr, r)
    cm = np.where(minus, c - dc, c)
    scale = np.where(plus & minus, 0.5, np.where(plus | minus, 1.0, 0.0)).astype(dt)
    return rp, cp, rm, cm, scale


def refine_same_arithmetic(P, N, mask, vertices, eye, pixel, flags, hidden_bit, culled_bit, max_offset=1.0):
    """(P, N, offset) per vertex as the kernel computes them, in ``P``'s dtype; ``vertices`` and
    ``eye`` relative to the G-buffer's origin, in that dtype."""
    dt = P.dtype.type
    n = len(vertices)
    r, c = pixel[:, 0].astype(np.int64), pixel[:, 1].astype(np.int64)
    culled = (flags & culled_bit) != 0
    hidden = ~culled & ((flags & hidden_bit) != 0)
    r = np.where(culled, 0, r)
    c = np.where(culled, 0, c)
    v = [vertices[:, k] for k in range(3)]

    def residual(rr, cc):
        p = [P[rr, cc, k] for k in range(3)]
        u = _normalize(*(eye[k] - p[k] for k in range(3)))
        b = _normalize(*(v[k] - p[k] for k in range(3)))
        hh = _normalize(*(u[k] + b[k] for k in range(3)))
        return [N[rr, cc, k] - hh[k] for k in range(3)]

    ar, ac, br, bc, sa = _stencil(mask, r, c, 1, 0, dt)
    cr, cc, dr, dc, sb = _stencil(mask, r, c, 0, 1, dt)
    d0, pa, pb, pc, pd = (residual(*t) for t in ((r, c), (ar, ac), (br, bc), (cr, cc), (dr, dc)))
    j0 = [(pa[k] - pb[k]) * sa for k in range(3)]
    j1 = [(pc[k] - pd[k]) * sb for k in range(3)]
    a00 = (j0[0] * j0[0] + j0[1] * j0[1]) + j0[2] * j0[2]
    a01 = (j0[0] * j1[0] + j0[1] * j1[1]) + j0[2] * j1[2]
    a11 = (j1[0] * j1[0] + j1[1] * j1[1]) + j1[2] * j1[2]
    b0 = -((j0[0] * d0[0] + j0[1] * d0[1]) + j0[2] * d0[2])
    b1 = -((j1[0] * d0[0] + j1[1] * d0[1]) + j1[2] * d0[2])
    det = a00 * a11 - a01 * a01
    both = det > dt(1e-6) * (a00 * a11)
    rows_only = ~both & (a11 == 0) & (a00 > 0)
    cols_only = ~both & ~rows_only & (a00 == 0) & (a11 > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        t0 = np.where(both, (a11 * b0 - a01 * b1) / det, np.where(rows_only, b0 / a00, 0)).astype(dt)
        t1 = np.where(both, (a00 * b1 - a01 * b0) / det, np.where(cols_only, b1 / a11, 0)).astype(dt)
    lim = dt(max_offset)
    t0 = np.minimum(np.maximum(t0, -lim), lim)
    t1 = np.minimum(np.maximum(t1, -lim), lim)
    ka, kb = t0 * sa, t1 * sb
    out_p = np.stack([(P[r, c, k] + ka * (P[ar, ac, k] - P[br, bc, k])) + kb * (P[cr, cc, k] - P[dr, dc, k])
                      for k in range(3)], axis=1)
    nn = [(N[r, c, k] + ka * (N[ar, ac, k] - N[br, bc, k])) + kb * (N[cr, cc, k] - N[dr, dc, k]) for k in range(3)]
    out_n = np.stack(_normalize(*nn), axis=1)
    off = np.stack([t0, t1], axis=1)
    out_p[hidden], out_n[hidden], off[hidden] = P[r, c][hidden], N[r, c][hidden], 0
    out_p[culled], out_n[culled], off[culled] = 0, 0, 0
    assert out_p.dtype == out_n.dtype == off.dtype == P.dtype and len(out_p) == n
    return out_p, out_n, off
