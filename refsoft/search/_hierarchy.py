"""Kernels of the ray-cone hierarchy search (Szabo 2013, chapter 4).

Level 0 holds, per covered G-buffer pixel of the (cropped, power-of-two padded) buffer, a sphere
(the surface point, radius 0) and a cone (the reflected eye ray, half-angle 0); empty texels have
radius and angle -1. Level l+1 bounds each 2x2 block of level l with the thesis's boundSphere
and boundCone, pairing (top-left, top-right) and (bottom-left, bottom-right), then the two
results. A search pops texels from a stack, top level first, pushing the children whose
enlarged cone contains the vertex (a cone-sphere test, the apex uncertainty as the sphere's
radius), following every branch whose cone contains the vertex; under each level-1 texel reached
it scores the covered base pixels with the linear search's score, and the best of all is the
result. When no base pixel is reached, the traversal restarts with cones and spheres enlarged
by the factors (compounding), up to ``MAX_ENLARGEMENTS`` times.
"""

import numpy as np

from .._numba import kernel, like
from ..constants import LONE_MARGIN, NO_SCORE
from ._kernels import RECORD_WIDTH as WALK_RECORD_WIDTH
from ._kernels import STOP_CAPPED, _evaluate, end_walk, walk

#: Restarts with enlarged cones and spheres before a search gives up (flag CAPPED).
MAX_ENLARGEMENTS = 8
# record columns: attempt, level, row, col, outcome (1 pushed / 0 rejected / 2 popped / 3 chosen)
RECORD_WIDTH = 5
#: Vertices searched by one thread one after another (its work arrays are allocated once per group).
SEARCH_GROUP = 256


@kernel(inline=True)
def _norm(x, y, z, fp):
    return np.sqrt((x * x + y * y) + z * z)


@kernel
def base_level(lo, hi, G, mask, fp, sph, cone):
    """Rows ``lo .. hi - 1`` (of the G-buffer's h) of level 0, ``sph`` and ``cone`` (size, size,
    4), -1 on entry: spheres (x, y, z, r) and cones (dx, dy, dz, a) from the packed G-buffer ``G``
    (P, N, U = normalize(O - P)) at its covered pixels; the reflected eye ray is ``I - 2 (N.I)
    N`` with ``I = -U``."""
    w = mask.shape[1]
    two = like(2.0, fp)
    for r in range(lo, hi):
        for c in range(w):
            if not mask[r, c]:
                continue
            g = G[r, c]
            ix, iy, iz = -g[6], -g[7], -g[8]
            k = two * ((g[3] * ix + g[4] * iy) + g[5] * iz)
            sph[r, c, 0] = g[0]
            sph[r, c, 1] = g[1]
            sph[r, c, 2] = g[2]
            sph[r, c, 3] = like(0.0, fp)
            cone[r, c, 0] = ix - k * g[3]
            cone[r, c, 1] = iy - k * g[4]
            cone[r, c, 2] = iz - k * g[5]
            cone[r, c, 3] = like(0.0, fp)


@kernel
def _bound_sphere(a, b, fp):
    """The thesis's boundSphere, with one fix: a sphere that already contains the other is
    returned as it is (the thesis's formula would cut it)."""
    if a[3] < like(0.0, fp):
        return b[0], b[1], b[2], b[3]
    if b[3] < like(0.0, fp):
        return a[0], a[1], a[2], a[3]
    dx, dy, dz = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    d = _norm(dx, dy, dz, fp)
    if d + b[3] <= a[3]:
        return a[0], a[1], a[2], a[3]
    if d + a[3] <= b[3]:
        return b[0], b[1], b[2], b[3]
    half = like(0.5, fp)
    s = (b[3] - a[3]) / d
    return (a[0] + half * (dx + dx * s), a[1] + half * (dy + dy * s), a[2] + half * (dz + dz * s),
            (d + a[3] + b[3]) * half)


@kernel
def _bound_cone(a, b, fp):
    """The thesis's boundCone: the normalised sum of the axes, half the angle between them plus
    the larger half-angle (pi when the axes are opposite); the angle by atan2, not acos."""
    if a[3] < like(0.0, fp):
        return b[0], b[1], b[2], b[3]
    if b[3] < like(0.0, fp):
        return a[0], a[1], a[2], a[3]
    sx, sy, sz = a[0] + b[0], a[1] + b[1], a[2] + b[2]
    n = _norm(sx, sy, sz, fp)
    if n == like(0.0, fp):
        return a[0], a[1], a[2], like(np.pi, fp)
    # the angle between the axes as atan2(|a x b|, a . b): acos(a . b) loses ~4e-4 rad in float32
    # for nearly parallel axes (the cones would then not contain their children)
    cx = a[1] * b[2] - a[2] * b[1]
    cy = a[2] * b[0] - a[0] * b[2]
    cz = a[0] * b[1] - a[1] * b[0]
    ang = np.arctan2(_norm(cx, cy, cz, fp), (a[0] * b[0] + a[1] * b[1]) + a[2] * b[2])
    return sx / n, sy / n, sz / n, ang * like(0.5, fp) + max(a[3], b[3])


@kernel(inline=True)
def _store(dst, x):
    dst[0] = x[0]
    dst[1] = x[1]
    dst[2] = x[2]
    dst[3] = x[3]


@kernel
def next_level(lo, hi, sph, cone, fp, s_out, c_out):
    """Rows ``lo .. hi - 1`` of level l+1, ``s_out`` and ``c_out`` (size, size, 4), from level l
    ``sph`` and ``cone`` (2 size, 2 size, 4)."""
    size = s_out.shape[0]
    ta = np.empty(4, dtype=sph.dtype)  # work arrays, once per part
    tb = np.empty(4, dtype=sph.dtype)
    for i in range(lo, hi):
        for j in range(size):
            r, c = 2 * i, 2 * j
            # (top-left, top-right), (bottom-left, bottom-right), then the two results
            _store(ta, _bound_sphere(sph[r, c], sph[r, c + 1], fp))
            _store(tb, _bound_sphere(sph[r + 1, c], sph[r + 1, c + 1], fp))
            _store(s_out[i, j], _bound_sphere(ta, tb, fp))
            _store(ta, _bound_cone(cone[r, c], cone[r, c + 1], fp))
            _store(tb, _bound_cone(cone[r + 1, c], cone[r + 1, c + 1], fp))
            _store(c_out[i, j], _bound_cone(ta, tb, fp))


@kernel(inline=True)
def _contains(s, cn, v, kc, ks, fp):
    """The cone of texel (sphere ``s``, cone ``cn``), enlarged by ``kc`` (angle) and ``ks``
    (apex radius), meets the vertex: a cone-sphere test with the apex at the sphere's centre."""
    if cn[3] < like(0.0, fp):
        return False
    r = s[3] * ks
    wx, wy, wz = v[0] - s[0], v[1] - s[1], v[2] - s[2]
    dist = _norm(wx, wy, wz, fp)
    if dist <= r:
        return True
    cx = wy * cn[2] - wz * cn[1]
    cy = wz * cn[0] - wx * cn[2]
    cz = wx * cn[1] - wy * cn[0]
    ang = np.arctan2(_norm(cx, cy, cz, fp), (wx * cn[0] + wy * cn[1]) + wz * cn[2])  # well-conditioned near 0
    a = min(cn[3] * kc, like(np.pi, fp))
    return ang <= a + np.arcsin(min(r / dist, like(1.0, fp)))


@kernel
def traverse(G, sph_levels, cone_levels, offsets, sizes, n_levels, v, kc0, ks0, fc, fs, break_level, cap, fp,
             stack, record, n_record):
    """One vertex's search. ``sph_levels`` / ``cone_levels`` are the levels concatenated (level
    l's texel (i, j) at ``offsets[l] + i * sizes[l] + j``). Every branch whose cones contain the
    vertex is followed (depth first, children in the order top-left, top-right, bottom-left,
    bottom-right); at level ``max(break_level, 1)`` the covered base pixels under the texel are
    scored with the search's score ``s`` and the best of all those reached is the result (the
    first of equal scores). Returns (row, col, tests, found, n_record)."""
    tests = 0
    kc, ks = kc0, ks0
    top = n_levels - 1
    stop_level = max(break_level, 1)
    for attempt in range(MAX_ENLARGEMENTS + 1):
        best = like(NO_SCORE, fp)
        br, bc = -1, -1
        stack[0, 0] = top
        stack[0, 1] = 0
        stack[0, 2] = 0
        sp = 1
        while sp > 0:
            sp -= 1
            lvl, i, j = stack[sp, 0], stack[sp, 1], stack[sp, 2]
            if n_record < record.shape[0]:
                record[n_record, 0] = attempt
                record[n_record, 1] = lvl
                record[n_record, 2] = i
                record[n_record, 3] = j
                record[n_record, 4] = 2
                n_record += 1
            if lvl <= stop_level:
                side = 1 << lvl
                base = sizes[0]
                for r in range(i * side, (i + 1) * side):
                    for c in range(j * side, (j + 1) * side):
                        q = offsets[0] + r * base + c
                        if cone_levels[q, 3] < like(0.0, fp):
                            continue
                        s = _evaluate(G, r, c, v, False, fp)
                        tests += 1
                        if s > best:
                            best = s
                            br, bc = r, c
                continue
            child = lvl - 1
            n = sizes[child]
            # push in reverse so that top-left, top-right, bottom-left, bottom-right pop in order
            for k in range(3, -1, -1):
                ci = 2 * i + k // 2
                cj = 2 * j + k % 2
                q = offsets[child] + ci * n + cj
                tests += 1
                ok = _contains(sph_levels[q], cone_levels[q], v, kc, ks, fp)
                if n_record < record.shape[0]:
                    record[n_record, 0] = attempt
                    record[n_record, 1] = child
                    record[n_record, 2] = ci
                    record[n_record, 3] = cj
                    record[n_record, 4] = 1 if ok else 0
                    n_record += 1
                if ok:
                    stack[sp, 0] = child
                    stack[sp, 1] = ci
                    stack[sp, 2] = cj
                    sp += 1
            if tests >= cap:
                break
        if br >= 0:
            if n_record < record.shape[0]:
                record[n_record, 0] = attempt
                record[n_record, 1] = 0
                record[n_record, 2] = br
                record[n_record, 3] = bc
                record[n_record, 4] = 3
                n_record += 1
            return br, bc, tests, True, n_record
        if tests >= cap:
            break
        kc *= fc
        ks *= fs
    return -1, -1, tests, False, n_record


@kernel
def search_all(lo, hi, G, mask, sph_levels, cone_levels, offsets, sizes, n_levels, vertices, origin, fc, fs,
               break_level, cap, inverse_search, start_r, start_c, fp, pixel, best, margin, iterations, flags):
    """The vertices of groups ``lo .. hi - 1`` (SEARCH_GROUP vertices each; run over every group
    by :func:`refsoft._parallel.parallel_range`): the hierarchy traversal, then HIDDEN / BORDER as
    the linear search sets them and, for a hidden vertex with ``inverse_search``, the inverse
    crosshair walk from there. A traversal that fails ends at the start pixel with CAPPED."""
    n = vertices.shape[0]
    h, w = mask.shape
    empty = np.empty((0, 5), dtype=np.float64)
    empty_walk = np.empty((0, WALK_RECORD_WIDTH), dtype=best.dtype)
    for g in range(lo, hi):
        stack = np.empty((3 * n_levels + 4, 3), dtype=np.int64)
        scratch = np.empty((2, 9), dtype=best.dtype)
        seen = np.zeros((2, 9), dtype=np.bool_)
        v = np.empty(3, dtype=best.dtype)
        for i in range(g * SEARCH_GROUP, min(n, (g + 1) * SEARCH_GROUP)):
            for k in range(3):
                v[k] = like(vertices[i, k] - origin[k], fp)
            r, c, tests, found, _ = traverse(G, sph_levels, cone_levels, offsets, sizes, n_levels, v, like(1.0, fp),
                                             like(1.0, fp), fc, fs, break_level, cap, fp, stack, empty, 0)
            if not found:
                r, c = start_r, start_c
            s = _evaluate(G, r, c, v, False, fp)
            m = like(LONE_MARGIN, fp)
            border = False
            for dr, dc in ((0, -1), (-1, 0), (0, 1), (1, 0)):
                rr, cc = r + dr, c + dc
                if rr < 0 or rr >= h or cc < 0 or cc >= w or not mask[rr, cc]:
                    border = True
            fl, tests, inverse = end_walk(0, 0, tests, not found, border, 0, v[0], v[1], v[2], G, G, r, c, 3,
                                          inverse_search, fp)
            if inverse:
                r, c, s, m, it, stop, border, _ = walk(G, mask, v, r, c, 5, cap, True, fp, empty_walk, 0, 1, scratch,
                                                       seen)
                fl, tests, _ = end_walk(fl, tests, it, stop == STOP_CAPPED, border, 1, v[0], v[1], v[2], G, G, r, c,
                                        3, inverse_search, fp)
            pixel[i, 0] = r
            pixel[i, 1] = c
            best[i] = s
            margin[i] = m
            iterations[i] = tests
            flags[i] = fl
