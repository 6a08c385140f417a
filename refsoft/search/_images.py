"""Kernels of the enumeration of every reflection point (spec section 4.8).

The bounds are Szabo's ray-cone pyramid (:mod:`refsoft.search._hierarchy`) over texels whose
sphere and cone are *dilated*: a texel's sphere is centred on its point with a radius of
``IMAGE_BOUND_FACTOR`` times the largest distance to a covered 3x3 neighbour's point, its cone
is the reflected eye ray with a half-angle of ``IMAGE_BOUND_FACTOR`` times the largest angle to a
neighbour's reflected ray. A solution within 1.5 texels of a texel then lies in the
texel's sphere and reflects into its cone (to first order in the texel size), so a cell whose
cone does not meet the vertex holds no image and is pruned (Mitchell and Hanrahan 1992, Wang,
Hasan and Yan 2020: prune where the normal and bisector bounds cannot meet).

A texel is reached only when its own dilated bounds meet the vertex: that test is part of the
definition of an image (its reflected ray can reach the vertex from within the texel's reach;
without it a Newton step can land near a texel whose reflected ray points far from the vertex,
where the bisector is ill-conditioned: ``U + B`` near zero). At each texel reached,
:func:`_judge` applies the rest: a local maximum of the score over its covered 3x3
neighbourhood, the vertex in front of its tangent plane, and Newton's iteration on
``r = (h - N)`` (:func:`converge`) converging within ``IMAGE_REACH`` texels of it. Each step is
taken in a tangent basis of the texel it stands on (``h`` the bisector; central differences over
the crosshair, one-sided at the rim) and moves the iteration to the texel nearest its point; the
iteration has converged when a step is at most ``IMAGE_CONVERGED`` texels long, and its image is
the covered texel nearest the converged point, which must itself have the vertex in front and
within its bounds. A maximum a few texels from its solution (a score's peak shifted by the
texels' spacing, or narrower than a texel) is then found, and the image is the texel of the
solution rather than of the maximum. The Newton arithmetic is float64 (it decides, it is not an
output's bits); scores are the search's own (``_evaluate``).
"""

import numpy as np

from .._numba import kernel, like
from ..constants import IMAGE_BOUND_FACTOR, IMAGE_CONVERGED, IMAGE_FOLD_RATIO, IMAGE_SEED_STEPS, IMAGE_STEPS
from ._hierarchy import _contains
from ._kernels import _evaluate

# verdicts of a texel reached (trace records)
ACCEPTED = 0
NOT_A_MAXIMUM = 1
BEHIND = 2
NEWTON_FAR = 3
NEWTON_SINGULAR = 4
MERGED = 5
OVERFLOW = 6
NOT_CONVERGED = 7
CANNOT_REFLECT = 8
# record columns: row, col (crop texel), verdict, score, converged row, converged col, image row, image col
RECORD_WIDTH = 8
# candidate columns: image row, image col, score, converged row, converged col
CAND_WIDTH = 5


@kernel(inline=True)
def _reflected(g, fp):
    """The reflected eye ray ``I - 2 (N.I) N``, ``I = -U``, at a packed texel."""
    ix, iy, iz = -g[6], -g[7], -g[8]
    k = like(2.0, fp) * ((g[3] * ix + g[4] * iy) + g[5] * iz)
    return ix - k * g[3], iy - k * g[4], iz - k * g[5]


@kernel
def dilated_base(lo, hi, G, mask, fp, sph, cone):
    """Rows ``lo .. hi - 1`` of level 0, ``sph`` and ``cone`` (size, size, 4), -1 on entry: per
    covered texel the dilated sphere (point, ``IMAGE_BOUND_FACTOR`` x largest neighbour distance)
    and cone (reflected ray, ``IMAGE_BOUND_FACTOR`` x largest neighbour angle)."""
    h, w = mask.shape
    factor = like(IMAGE_BOUND_FACTOR, fp)
    for r in range(lo, hi):
        for c in range(w):
            if not mask[r, c]:
                continue
            g = G[r, c]
            ax, ay, az = _reflected(g, fp)
            rad = like(0.0, fp)
            ang = like(0.0, fp)
            for dr in range(-1, 2):
                for dc in range(-1, 2):
                    rr, cc = r + dr, c + dc
                    if rr < 0 or rr >= h or cc < 0 or cc >= w or not mask[rr, cc] or (dr == 0 and dc == 0):
                        continue
                    q = G[rr, cc]
                    dx, dy, dz = q[0] - g[0], q[1] - g[1], q[2] - g[2]
                    rad = max(rad, np.sqrt((dx * dx + dy * dy) + dz * dz))
                    bx, by, bz = _reflected(q, fp)
                    cx, cy, cz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
                    a = np.arctan2(np.sqrt((cx * cx + cy * cy) + cz * cz), (ax * bx + ay * by) + az * bz)
                    ang = max(ang, a)
            sph[r, c, 0] = g[0]
            sph[r, c, 1] = g[1]
            sph[r, c, 2] = g[2]
            sph[r, c, 3] = rad * factor
            cone[r, c, 0] = ax
            cone[r, c, 1] = ay
            cone[r, c, 2] = az
            cone[r, c, 3] = ang * factor


@kernel(inline=True)
def _residual(G, r, c, v, t, out):
    """``h - N`` at texel (r, c) in the tangent basis ``t`` (2, 3), float64, into ``out`` (2,)."""
    g = G[r, c]
    px, py, pz = np.float64(g[0]), np.float64(g[1]), np.float64(g[2])
    bx, by, bz = np.float64(v[0]) - px, np.float64(v[1]) - py, np.float64(v[2]) - pz
    n = np.sqrt((bx * bx + by * by) + bz * bz)
    if n > 0.0:
        bx, by, bz = bx / n, by / n, bz / n
    hx, hy, hz = np.float64(g[6]) + bx, np.float64(g[7]) + by, np.float64(g[8]) + bz
    n = np.sqrt((hx * hx + hy * hy) + hz * hz)
    if n > 0.0:
        hx, hy, hz = hx / n, hy / n, hz / n
    dx, dy, dz = hx - np.float64(g[3]), hy - np.float64(g[4]), hz - np.float64(g[5])
    for k in range(2):
        out[k] = (dx * t[k, 0] + dy * t[k, 1]) + dz * t[k, 2]


@kernel(inline=True)
def _tangent_basis(g, t):
    """A tangent basis (2, 3) of the texel's normal: ``t0 = normalize(N x e)`` with ``e`` the
    axis of N's smallest component (the first of equals), ``t1 = N x t0``; float64."""
    nx, ny, nz = np.float64(g[3]), np.float64(g[4]), np.float64(g[5])
    ax, ay, az = abs(nx), abs(ny), abs(nz)
    if ax <= ay and ax <= az:
        ex, ey, ez = 1.0, 0.0, 0.0
    elif ay <= az:
        ex, ey, ez = 0.0, 1.0, 0.0
    else:
        ex, ey, ez = 0.0, 0.0, 1.0
    x, y, z = ny * ez - nz * ey, nz * ex - nx * ez, nx * ey - ny * ex
    n = np.sqrt((x * x + y * y) + z * z)
    t[0, 0], t[0, 1], t[0, 2] = x / n, y / n, z / n
    t[1, 0] = ny * t[0, 2] - nz * t[0, 1]
    t[1, 1] = nz * t[0, 0] - nx * t[0, 2]
    t[1, 2] = nx * t[0, 1] - ny * t[0, 0]


@kernel
def newton(G, mask, r, c, v, t, work):
    """One Newton step on ``h - N = 0`` from texel (r, c): ``(ok, d_row, d_col)``; ``ok`` is False
    when the texel has no covered neighbour along an axis or the 2x2 Jacobian is singular.
    ``t`` (2, 3) and ``work`` (5, 2) float64 are work arrays."""
    if not jacobian(G, mask, r, c, v, t, work):
        return False, 0.0, 0.0
    jc0, jc1, jr0, jr1 = work[1, 0], work[1, 1], work[2, 0], work[2, 1]
    det = jc0 * jr1 - jr0 * jc1
    if not det != 0.0:
        return False, 0.0, 0.0
    # J (d_col, d_row) = -r0, by Cramer's rule
    d_col = (-work[0, 0] * jr1 + work[0, 1] * jr0) / det
    d_row = (-work[0, 1] * jc0 + work[0, 0] * jc1) / det
    if not (np.isfinite(d_col) and np.isfinite(d_row)):
        return False, 0.0, 0.0
    return True, d_row, d_col


@kernel
def jacobian(G, mask, r, c, v, t, work):
    """The residual at texel (r, c) (``work[0]``) and the columns of its 2x2 Jacobian by central
    differences, one-sided beside an uncovered texel (``work[1]`` along the columns,
    ``work[2]`` along the rows), in the tangent basis ``t`` of the texel; False when an axis has
    no covered neighbour."""
    h, w = mask.shape
    _tangent_basis(G[r, c], t)
    _residual(G, r, c, v, t, work[0])
    # column derivative (work[1]) then row derivative (work[2]): central, one-sided at the rim
    for axis in range(2):
        dr, dc = (0, 1) if axis == 0 else (1, 0)
        ra, ca, rb, cb = r + dr, c + dc, r - dr, c - dc
        fa = 0 <= ra < h and 0 <= ca < w and mask[ra, ca]
        fb = 0 <= rb < h and 0 <= cb < w and mask[rb, cb]
        d = work[1 + axis]
        if fa and fb:
            _residual(G, ra, ca, v, t, work[3])
            _residual(G, rb, cb, v, t, work[4])
            d[0] = (work[3, 0] - work[4, 0]) * 0.5
            d[1] = (work[3, 1] - work[4, 1]) * 0.5
        elif fa:
            _residual(G, ra, ca, v, t, work[3])
            d[0] = work[3, 0] - work[0, 0]
            d[1] = work[3, 1] - work[0, 1]
        elif fb:
            _residual(G, rb, cb, v, t, work[4])
            d[0] = work[0, 0] - work[4, 0]
            d[1] = work[0, 1] - work[4, 1]
        else:
            return False
    return True


@kernel
def _judge(G, mask, sph, cone, sizes0, r, c, v, reach, fp, t, work):
    """The verdict on texel (r, c) (ACCEPTED or the first reason it is not an image), its score,
    its image texel (row, col) and converged point (row, col) (:func:`converge`)."""
    h, w = mask.shape
    s = _evaluate(G, r, c, v, False, fp)
    for dr in range(-1, 2):
        for dc in range(-1, 2):
            rr, cc = r + dr, c + dc
            if rr < 0 or rr >= h or cc < 0 or cc >= w or not mask[rr, cc] or (dr == 0 and dc == 0):
                continue
            if _evaluate(G, rr, cc, v, False, fp) > s:
                return NOT_A_MAXIMUM, s, r, c, np.float64(r), np.float64(c)
    g = G[r, c]
    if not ((v[0] - g[0]) * g[3] + (v[1] - g[1]) * g[4]) + (v[2] - g[2]) * g[5] > like(0.0, fp):
        return BEHIND, s, r, c, np.float64(r), np.float64(c)
    verdict, ir, ic, lr, lc = converge(G, mask, sph, cone, sizes0, r, c, v, reach, fp, t, work)
    return verdict, s, ir, ic, lr, lc


@kernel
def converge(G, mask, sph, cone, sizes0, r, c, v, reach, fp, t, work):
    """Newton's iteration on ``h - N = 0`` from texel (r, c), texel to texel (each step from the
    texel nearest the last step's point, ``floor(x + 0.5)``): ``(verdict, image row, image col,
    converged row, converged col)``. ACCEPTED when, within ``IMAGE_STEPS`` steps, a step or the
    move of the step's point from the last one's (from (r, c) at first) is at most
    ``IMAGE_CONVERGED`` texels, or the iteration steps back to the neighbour it came from (its
    point is then the middle of the two texels' points), its point at most ``reach`` texels from
    (r, c), and the image
    (the covered texel nearest the point, else the texel the step was taken from) has the vertex
    in front and within its dilated bounds; NEWTON_FAR when a step leaves the mirror or the
    reach, NEWTON_SINGULAR, NOT_CONVERGED or CANNOT_REFLECT otherwise."""
    h, w = mask.shape
    cr, cc = r, c
    pr, pc = -1, -1  # the texel stood on before (cr, cc)
    lr, lc = np.float64(r), np.float64(c)
    tol = IMAGE_CONVERGED * IMAGE_CONVERGED
    for _ in range(IMAGE_STEPS):
        ok, d_row, d_col = newton(G, mask, cr, cc, v, t, work)
        if not ok:
            return NEWTON_SINGULAR, cr, cc, lr, lc
        # the point moves by less than the step when two texels both point at one place
        mr, mc = cr + d_row - lr, cc + d_col - lc
        done = d_row * d_row + d_col * d_col <= tol or mr * mr + mc * mc <= tol
        nr, nc = int(np.floor(cr + d_row + 0.5)), int(np.floor(cc + d_col + 0.5))
        if not done and nr == pr and nc == pc and abs(cr - pr) <= 1 and abs(cc - pc) <= 1:
            # back and forth between two neighbours (a peak narrower than a texel): the
            # solution lies between them, at the middle of their points
            done = True
            lr, lc = (lr + (cr + d_row)) * 0.5, (lc + (cc + d_col)) * 0.5
            nr, nc = int(np.floor(lr + 0.5)), int(np.floor(lc + 0.5))
        else:
            lr, lc = cr + d_row, cc + d_col
        if (lr - r) * (lr - r) + (lc - c) * (lc - c) > reach * reach:
            return NEWTON_FAR, cr, cc, lr, lc
        inside = 0 <= nr < h and 0 <= nc < w and mask[nr, nc]
        if done:
            if inside:
                cr, cc = nr, nc
            g = G[cr, cc]
            if not ((v[0] - g[0]) * g[3] + (v[1] - g[1]) * g[4]) + (v[2] - g[2]) * g[5] > like(0.0, fp):
                return CANNOT_REFLECT, cr, cc, lr, lc
            q = cr * sizes0 + cc
            if not _contains(sph[q], cone[q], v, like(1.0, fp), like(1.0, fp), fp):
                return CANNOT_REFLECT, cr, cc, lr, lc
            return ACCEPTED, cr, cc, lr, lc
        if not inside:
            return NEWTON_FAR, cr, cc, lr, lc
        pr, pc = cr, cc
        cr, cc = nr, nc
    return NOT_CONVERGED, cr, cc, lr, lc


@kernel
def enumerate_one(G, mask, sph, cone, offsets, sizes, n_levels, v, reach, merge_dist, fp, stack, cand, t, work,
                  record, n_record):
    """Every texel of one vertex that is an image (before merging), found by descending into
    every cell whose dilated cone meets the vertex (children in the order top-left, top-right,
    bottom-left, bottom-right), then the solutions beside a fold (:func:`seed_folds`). Accepted
    texels go to ``cand`` (K, CAND_WIDTH) in the order reached; ``record`` (may have no rows)
    receives every texel judged.

    Returns (accepted, visited cells, pruned cells, judged texels, n_record)."""
    one = like(1.0, fp)
    n_cand = 0
    visited = 0
    pruned = 0
    judged = 0
    top = n_levels - 1
    stack[0, 0] = top
    stack[0, 1] = 0
    stack[0, 2] = 0
    sp = 0
    q = offsets[top]
    if _contains(sph[q], cone[q], v, one, one, fp):
        sp = 1
    else:
        pruned += 1
    base = sizes[0]
    while sp > 0:
        sp -= 1
        lvl, i, j = stack[sp, 0], stack[sp, 1], stack[sp, 2]
        visited += 1
        if lvl == 0:
            if i >= mask.shape[0] or j >= mask.shape[1]:
                continue
            judged += 1
            verdict, s, ir, ic, lr, lc = _judge(G, mask, sph, cone, base, i, j, v, reach, fp, t, work)
            if verdict == ACCEPTED:
                if n_cand < cand.shape[0]:
                    cand[n_cand, 0] = ir
                    cand[n_cand, 1] = ic
                    cand[n_cand, 2] = s
                    cand[n_cand, 3] = lr
                    cand[n_cand, 4] = lc
                    n_cand += 1
                else:
                    verdict = OVERFLOW
            if verdict != NOT_A_MAXIMUM and n_record < record.shape[0]:
                record[n_record, 0] = i
                record[n_record, 1] = j
                record[n_record, 2] = verdict
                record[n_record, 3] = s
                record[n_record, 4] = lr
                record[n_record, 5] = lc
                record[n_record, 6] = ir
                record[n_record, 7] = ic
                n_record += 1
            continue
        child = lvl - 1
        n = sizes[child]
        for k in range(3, -1, -1):
            ci = 2 * i + k // 2
            cj = 2 * j + k % 2
            q = offsets[child] + ci * n + cj
            if _contains(sph[q], cone[q], v, one, one, fp):
                stack[sp, 0] = child
                stack[sp, 1] = ci
                stack[sp, 2] = cj
                sp += 1
            else:
                pruned += 1
    n_cand, n_record = seed_folds(G, mask, sph, cone, base, v, reach, merge_dist, fp, cand, n_cand, t, work, record,
                                  n_record)
    return n_cand, visited, pruned, judged, n_record


@kernel
def seed_folds(G, mask, sph, cone, sizes0, v, reach, merge_dist, fp, cand, n_cand, t, work, record, n_record):
    """Solutions without a maximum of their own: beside a fold two solutions can share one peak
    of the score. At each accepted image (in the order of image row, col, converged row, col)
    whose 2x2 Jacobian is nearly singular (``|det| <
    IMAGE_FOLD_RATIO`` times the sum of its squared entries), Newton's iteration
    (:func:`converge`) is started from the covered texels nearest the converged point moved 2 to
    IMAGE_SEED_STEPS texels along the Jacobian's null direction, both ways; a start with the
    vertex in front and within its bounds whose iteration is accepted, at least ``merge_dist``
    texels from every candidate's point and on another texel, is one more candidate (its score the
    start's). Returns ``(n_cand, n_record)``."""
    h, w = mask.shape
    n_first = n_cand
    order = np.empty(n_first, dtype=np.int64)  # by image row, col, converged row, col
    for a in range(n_first):
        b = a - 1
        while b >= 0 and (cand[order[b], 0], cand[order[b], 1], cand[order[b], 3], cand[order[b], 4]) > \
                (cand[a, 0], cand[a, 1], cand[a, 3], cand[a, 4]):
            order[b + 1] = order[b]
            b -= 1
        order[b + 1] = a
    for m in range(n_first):
        a = order[m]
        ir, ic = int(cand[a, 0]), int(cand[a, 1])
        if not jacobian(G, mask, ir, ic, v, t, work):
            continue
        jc0, jc1, jr0, jr1 = work[1, 0], work[1, 1], work[2, 0], work[2, 1]
        aa = jc0 * jc0 + jc1 * jc1
        bb = jc0 * jr0 + jc1 * jr1
        cc = jr0 * jr0 + jr1 * jr1
        det = jc0 * jr1 - jr0 * jc1
        if not (aa + cc > 0.0 and abs(det) < IMAGE_FOLD_RATIO * (aa + cc)):
            continue
        # the null direction of J: the eigenvector of J^T J of the smaller eigenvalue, (col, row)
        half = (aa - cc) * 0.5
        lam = (aa + cc) * 0.5 - np.sqrt(half * half + bb * bb)
        x0, x1 = bb, lam - aa
        y0, y1 = lam - cc, bb
        if x0 * x0 + x1 * x1 >= y0 * y0 + y1 * y1:
            dc, dr = x0, x1
        else:
            dc, dr = y0, y1
        n = np.sqrt(dc * dc + dr * dr)
        if not n > 0.0:
            continue
        dc, dr = dc / n, dr / n
        for k in range(2, IMAGE_SEED_STEPS + 1):
            for sign in (1.0, -1.0):
                sr = int(np.floor(cand[a, 3] + sign * k * dr + 0.5))
                sc = int(np.floor(cand[a, 4] + sign * k * dc + 0.5))
                if not (0 <= sr < h and 0 <= sc < w and mask[sr, sc]):
                    continue
                g = G[sr, sc]
                if not ((v[0] - g[0]) * g[3] + (v[1] - g[1]) * g[4]) + (v[2] - g[2]) * g[5] > like(0.0, fp):
                    continue
                if not _contains(sph[sr * sizes0 + sc], cone[sr * sizes0 + sc], v, like(1.0, fp), like(1.0, fp), fp):
                    continue
                verdict, qr, qc, lr, lc = converge(G, mask, sph, cone, sizes0, sr, sc, v, reach, fp, t, work)
                if verdict != ACCEPTED:
                    continue
                new = True
                for b in range(n_cand):
                    er, ec = cand[b, 3] - lr, cand[b, 4] - lc
                    if (cand[b, 0] == qr and cand[b, 1] == qc) or er * er + ec * ec < merge_dist * merge_dist:
                        new = False
                        break
                if not new or n_cand >= cand.shape[0]:
                    continue
                s = _evaluate(G, sr, sc, v, False, fp)
                cand[n_cand, 0] = qr
                cand[n_cand, 1] = qc
                cand[n_cand, 2] = s
                cand[n_cand, 3] = lr
                cand[n_cand, 4] = lc
                n_cand += 1
                if n_record < record.shape[0]:
                    record[n_record, 0] = sr
                    record[n_record, 1] = sc
                    record[n_record, 2] = ACCEPTED
                    record[n_record, 3] = s
                    record[n_record, 4] = lr
                    record[n_record, 5] = lc
                    record[n_record, 6] = qr
                    record[n_record, 7] = qc
                    n_record += 1
    return n_cand, n_record


@kernel
def merge(cand, n_cand, first_r, first_c, first_lr, first_lc, merge_dist, keep, used):
    """Merge accepted maxima of one solution: with the walk's image ``(first_r, first_c)`` (its
    converged point ``(first_lr, first_lc)``) kept first when ``first_r >= 0``, then the others by
    score (highest first; ties to the smaller image row, then col), each dropped when its image
    texel is a kept one's or its converged point lies within ``merge_dist`` texels of a kept one's. ``keep`` (K,) int64 receives the kept
    rows of ``cand`` (-1 for the walk's image); returns how many, the walk's first, the others
    in row-major order. ``used`` (>= n_cand,) bool is a work array."""
    n_keep = 0
    if first_r >= 0:
        keep[0] = -1
        n_keep = 1
    m2 = merge_dist * merge_dist
    for a in range(n_cand):
        used[a] = False
    while True:
        b = -1
        for a in range(n_cand):
            if used[a]:
                continue
            if b < 0 or cand[a, 2] > cand[b, 2] or (cand[a, 2] == cand[b, 2] and (
                    cand[a, 0] < cand[b, 0] or (cand[a, 0] == cand[b, 0] and cand[a, 1] < cand[b, 1]))):
                b = a
        if b < 0:
            break
        used[b] = True
        near = False
        for m in range(n_keep):
            k = keep[m]
            if k < 0:
                lr, lc = first_lr, first_lc
                same = cand[b, 0] == first_r and cand[b, 1] == first_c
            else:
                lr, lc = cand[k, 3], cand[k, 4]
                same = cand[b, 0] == cand[k, 0] and cand[b, 1] == cand[k, 1]
            dr, dc = cand[b, 3] - lr, cand[b, 4] - lc
            if same or dr * dr + dc * dc < m2:
                near = True
                break
        if not near and n_keep < keep.shape[0]:
            keep[n_keep] = b
            n_keep += 1
    # the others in row-major order (insertion sort; a handful of rows)
    lo = 1 if first_r >= 0 else 0
    for a in range(lo + 1, n_keep):
        x = keep[a]
        b = a - 1
        while b >= lo and (cand[keep[b], 0] > cand[x, 0] or (cand[keep[b], 0] == cand[x, 0] and
                                                             cand[keep[b], 1] > cand[x, 1])):
            keep[b + 1] = keep[b]
            b -= 1
        keep[b + 1] = x
    return n_keep


@kernel
def enumerate_all(lo, hi, G, mask, sph, cone, offsets, sizes, n_levels, vertices, origin, first, reach, merge_dist,
                  fp, count, pixel, stats):
    """Vertices ``lo .. hi - 1``: :func:`enumerate_one`, then the walk's texel ``first[i]`` (crop
    coordinates, -1 for none) judged without the 3x3 maximum test (the walk's own neighbourhood
    made it a maximum) and its image kept first when it has one (:func:`first_walk`), then
    :func:`merge`. Writes
    ``count[i]``, ``pixel[i, :count]`` (crop coordinates) and ``stats[i]`` (visited, pruned,
    judged, accepted before merging)."""
    cand = np.empty((pixel.shape[1] * 4, CAND_WIDTH), dtype=np.float64)
    keep = np.empty(pixel.shape[1], dtype=np.int64)
    used = np.empty(cand.shape[0], dtype=np.bool_)
    stack = np.empty((3 * n_levels + 4, 3), dtype=np.int64)
    t = np.empty((2, 3), dtype=np.float64)
    work = np.empty((5, 2), dtype=np.float64)
    v = np.empty(3, dtype=G.dtype)
    empty = np.empty((0, RECORD_WIDTH), dtype=np.float64)
    for i in range(lo, hi):
        for k in range(3):
            v[k] = like(vertices[i, k] - origin[k], fp)
        n_cand, visited, pruned, judged, _ = enumerate_one(G, mask, sph, cone, offsets, sizes, n_levels, v, reach,
                                                           merge_dist, fp, stack, cand, t, work, empty, 0)
        fr, fc, flr, flc = first_walk(G, mask, sph, cone, sizes[0], first[i, 0], first[i, 1], v, reach, fp, t, work)
        n_keep = merge(cand, n_cand, fr, fc, flr, flc, merge_dist, keep, used)
        for m in range(n_keep):
            if keep[m] < 0:
                pixel[i, m, 0] = fr
                pixel[i, m, 1] = fc
            else:
                pixel[i, m, 0] = np.int32(cand[keep[m], 0])
                pixel[i, m, 1] = np.int32(cand[keep[m], 1])
        count[i] = n_keep
        stats[i, 0] = visited
        stats[i, 1] = pruned
        stats[i, 2] = judged
        stats[i, 3] = n_cand


@kernel
def first_walk(G, mask, sph, cone, sizes0, r, c, v, reach, fp, t, work):
    """The image of the walk's texel (r, c), the first image: ``(image row, image col, Newton
    row, Newton col)`` when (r, c) is covered, the vertex lies in front of its tangent plane and
    within the texel's dilated bounds (``sph``, ``cone``: level 0 first, ``sizes0`` texels a row),
    and Newton's iteration from it converges (:func:`converge`: the image is the texel nearest
    the converged point, as for every other maximum, so it lies within a pixel of the exact
    point where the walk's own maximum can lie farther); ``(-1, -1, 0, 0)`` otherwise."""
    h, w = mask.shape
    if r < 0 or r >= h or c < 0 or c >= w or not mask[r, c]:
        return -1, -1, 0.0, 0.0
    g = G[r, c]
    if not ((v[0] - g[0]) * g[3] + (v[1] - g[1]) * g[4]) + (v[2] - g[2]) * g[5] > like(0.0, fp):
        return -1, -1, 0.0, 0.0
    q = r * sizes0 + c
    if not _contains(sph[q], cone[q], v, like(1.0, fp), like(1.0, fp), fp):
        return -1, -1, 0.0, 0.0
    verdict, ir, ic, lr, lc = converge(G, mask, sph, cone, sizes0, r, c, v, reach, fp, t, work)
    if verdict != ACCEPTED:
        return -1, -1, 0.0, 0.0
    return ir, ic, lr, lc
