"""Kernels of the traced acceptance (:func:`refsoft.search.acceptance.nearest`, float64): the
acceptance of ``_several.accept_untracked`` turned around. Instead of every candidate testing
every pixel its dilated screen triangle covers, every pixel's reflected ray walks a bounding
volume hierarchy over the candidates' real triangles and tests the triangles whose boxes it
crosses nearer than its best hit so far; a hit counts when the candidate's dilated screen triangle
covers the pixel (``accept_untracked``'s cover test, the same expressions). The winner is the
same: the nearest hit, ties to the lowest candidate (``accept_untracked`` takes the candidates in
index order and a later one replaces the best only when strictly nearer), with the same
Moller-Trumbore arithmetic, so ``best_t``, ``best_c`` and ``best_uv`` are the same bits.

The hierarchy is implicit: leaves of :data:`LEAF` consecutive candidates, each level's node ``i``
the parent of the level below's nodes ``2 i`` and ``2 i + 1``. The candidates keep their order: a
mesh's faces in order lie near each other, in the scene and in the image. Each node holds its 3D
box, widened by a margin far above the rounding of any test (a ray that Moller-Trumbore finds
inside a triangle never misses its boxes), and the screen bounds of its candidates.

Reference: ``tests/search/test_traced.py`` checks every output against the plain loop bit
for bit (``tests/naive_several_pool.py``).
"""

import numpy as np

from .._numba import kernel
from ._several import _inside, _meet, _outline, _real_edges

#: Candidates per leaf of the hierarchy.
LEAF = 4


@kernel
def leaf_boxes(lo, hi, real, bbox, boxes, rects):
    """Leaves ``lo .. hi - 1`` (run by :func:`refsoft._parallel.parallel_range`): the box (min x,
    y, z, max x, y, z) of the real triangles ``leaf * LEAF .. (leaf + 1) * LEAF - 1`` (NaN in its
    first value when one of theirs is not finite), and the bounds (row0, row1, col0, col1) of
    their dilated screen bounds ``bbox``. :func:`widen` then adds the margin."""
    n = real.shape[0]
    for leaf in range(lo, hi):
        mnx = mny = mnz = np.inf
        mxx = mxy = mxz = -np.inf
        finite = True
        rects[leaf, 0], rects[leaf, 1] = bbox[leaf * LEAF, 0], bbox[leaf * LEAF, 1]
        rects[leaf, 2], rects[leaf, 3] = bbox[leaf * LEAF, 2], bbox[leaf * LEAF, 3]
        for c in range(leaf * LEAF, min(n, (leaf + 1) * LEAF)):
            rects[leaf, 0], rects[leaf, 1] = min(rects[leaf, 0], bbox[c, 0]), max(rects[leaf, 1], bbox[c, 1])
            rects[leaf, 2], rects[leaf, 3] = min(rects[leaf, 2], bbox[c, 2]), max(rects[leaf, 3], bbox[c, 3])
            for i in range(3):
                x, y, z = real[c, i, 0], real[c, i, 1], real[c, i, 2]
                finite = finite and np.isfinite(x) and np.isfinite(y) and np.isfinite(z)
                mnx, mny, mnz = min(mnx, x), min(mny, y), min(mnz, z)
                mxx, mxy, mxz = max(mxx, x), max(mxy, y), max(mxz, z)
        boxes[leaf, 0], boxes[leaf, 1], boxes[leaf, 2] = mnx if finite else np.nan, mny, mnz
        boxes[leaf, 3], boxes[leaf, 4], boxes[leaf, 5] = mxx, mxy, mxz


@kernel
def widen(n, boxes, fraction):
    """The leaves' boxes ``boxes[:n]`` widened on every side by ``fraction`` times the largest
    ``|coordinate|`` among them plus one (the largest of the triangles': a box's sides are their
    coordinates). Returns that coordinate; NaN, with nothing widened, when a box holds a value that
    is not finite."""
    big = 0.0
    for leaf in range(n):
        for q in range(6):
            x = boxes[leaf, q]
            if not np.isfinite(x):
                return np.nan
            big = max(big, abs(x))
    margin = fraction * (big + 1.0)
    for leaf in range(n):
        for q in range(3):
            boxes[leaf, q] = boxes[leaf, q] - margin
            boxes[leaf, 3 + q] = boxes[leaf, 3 + q] + margin
    return big


@kernel
def parent_boxes(start, size, boxes, rects):
    """Every level above the leaves: level ``k``'s node ``i`` (row ``start[k] + i`` of ``boxes``
    and ``rects``, ``size[k]`` nodes) bounds level ``k - 1``'s nodes ``2 i`` and ``2 i + 1`` (when
    there)."""
    for k in range(1, start.shape[0]):
        below, n_below = start[k - 1], size[k - 1]
        for i in range(size[k]):
            a = below + 2 * i
            row = start[k] + i
            for q in range(6):
                boxes[row, q] = boxes[a, q]
            for q in range(4):
                rects[row, q] = rects[a, q]
            if 2 * i + 1 < n_below:
                b = a + 1
                for q in range(3):
                    boxes[row, q] = min(boxes[row, q], boxes[b, q])
                    boxes[row, q + 3] = max(boxes[row, q + 3], boxes[b, q + 3])
                rects[row, 0], rects[row, 1] = min(rects[row, 0], rects[b, 0]), max(rects[row, 1], rects[b, 1])
                rects[row, 2], rects[row, 3] = min(rects[row, 2], rects[b, 2]), max(rects[row, 3], rects[b, 3])


@kernel
def accept_traced(lo, hi, r0, c0, valid, origin, direction, screen, bbox, dilate, real, start, size, boxes, rects,
                  slack, best_t, best_c, best_uv, stack, entry):
    """For box rows ``lo .. hi - 1`` (run by :func:`refsoft._parallel.parallel_range`; each pixel
    writes only its own outputs): ``accept_untracked``'s ``best_t``, ``best_c`` and ``best_uv``.

    Parameters
    ----------
    r0, c0, valid, origin, direction, screen, bbox, dilate, real
        As ``_several.accept_untracked``.
    start, size : (L,) int64
        Each level's first row in ``boxes`` and its node count (level 0: the leaves; the last:
        the root).
    boxes : (B, 6) float64
        Every node's widened box.
    rects : (B, 4) int64
        Every node's bounds of its candidates' ``bbox`` (a pixel outside meets none of them).
    slack : float
        A node is entered while its entry ``t`` is below the pixel's best times ``1 + slack``
        (plus ``slack``): the rounding of the box test never hides a tie.
    best_t, best_c, best_uv
        Outputs, initialised to inf, -1 and 0.
    stack, entry : (S,) int64, (S,) float64
        Work: the nodes still to visit and their entries (S >= 2 * L).
    """
    n = real.shape[0]
    top = start.shape[0] - 1
    for r in range(lo, hi):
        y = r + r0 + 0.5
        for j in range(valid.shape[1]):
            if not valid[r, j]:
                continue
            ox, oy, oz = origin[r, j, 0], origin[r, j, 1], origin[r, j, 2]
            dx, dy, dz = direction[r, j, 0], direction[r, j, 1], direction[r, j, 2]
            # reciprocals for the box tests alone (0 where the ray runs parallel to an axis)
            ix = 1.0 / dx if dx != 0.0 else 0.0
            iy = 1.0 / dy if dy != 0.0 else 0.0
            iz = 1.0 / dz if dz != 0.0 else 0.0
            col = j + c0
            x = col + 0.5
            bt = np.inf
            bc = -1
            bu = bv = 0.0
            depth = 0
            enter = _enter(boxes, rects, start[top], r, col, ox, oy, oz, dx, dy, dz, ix, iy, iz)
            if enter < np.inf:
                stack[0], entry[0] = top << 40, enter  # level * 2**40 + node
                depth = 1
            while depth > 0:
                depth -= 1
                level, node = stack[depth] >> 40, stack[depth] & ((1 << 40) - 1)
                if entry[depth] > bt + slack * (abs(bt) + 1.0):  # beyond the best hit
                    continue
                if level == 0:
                    for c in range(node * LEAF, min(n, (node + 1) * LEAF)):
                        if r < bbox[c, 0] or r >= bbox[c, 1] or col < bbox[c, 2] or col >= bbox[c, 3]:
                            continue
                        p0x, p0y, p0z, e1x, e1y, e1z, e2x, e2y, e2z = _real_edges(real, c)
                        t, u, v = _meet(ox, oy, oz, dx, dy, dz, p0x, p0y, p0z, e1x, e1y, e1z, e2x, e2y, e2z)
                        if not (t > 0.0) or t > bt or (t == bt and c > bc):
                            continue
                        if not _covers(c, screen, dilate, x, y):
                            continue
                        bt, bc, bu, bv = t, c, u, v
                    continue
                a = 2 * node
                below = start[level - 1]
                ta = _enter(boxes, rects, below + a, r, col, ox, oy, oz, dx, dy, dz, ix, iy, iz)
                tb = np.inf
                if a + 1 < size[level - 1]:
                    tb = _enter(boxes, rects, below + a + 1, r, col, ox, oy, oz, dx, dy, dz, ix, iy, iz)
                if tb < ta:  # the nearer child last on the stack: visited first
                    a, ta, tb = a + 1, tb, ta
                    b = a - 1
                else:
                    b = a + 1
                if tb < np.inf:
                    stack[depth], entry[depth] = ((level - 1) << 40) + b, tb
                    depth += 1
                if ta < np.inf:
                    stack[depth], entry[depth] = ((level - 1) << 40) + a, ta
                    depth += 1
            if bc >= 0:
                best_t[r, j] = bt
                best_c[r, j] = bc
                best_uv[r, j, 0] = bu
                best_uv[r, j, 1] = bv


@kernel(inline=True)
def _covers(c, screen, dilate, x, y):
    """``accept_untracked``'s cover test of candidate ``c`` at the pixel centre (x, y) (its bounds
    already passed): the dilated screen triangle's three edge tests, or none for a sliver or an
    unusable projection."""
    ax, ay, bx, by, cx, cy, sign, lab, lbc, lca, d, plain = _outline(c, screen, dilate)
    return plain or _inside(x, y, ax, ay, bx, by, cx, cy, sign, lab, lbc, lca, d)


@kernel(inline=True)
def _enter(boxes, rects, row, r, col, ox, oy, oz, dx, dy, dz, ix, iy, iz):
    """The ray's entry ``t`` into node ``row``'s box (clamped at 0: its origin inside), inf where
    the pixel (r, col) lies outside the node's screen bounds, or the ray misses the box or leaves
    it behind its origin. An axis the ray runs parallel to constrains nothing but that the origin
    lies within the slab. ``ix, iy, iz``: the direction's reciprocals (0 where it is 0)."""
    if r < rects[row, 0] or r >= rects[row, 1] or col < rects[row, 2] or col >= rects[row, 3]:
        return np.inf
    t0, t1 = 0.0, np.inf
    t0, t1 = _slab(t0, t1, boxes[row, 0], boxes[row, 3], ox, dx, ix)
    t0, t1 = _slab(t0, t1, boxes[row, 1], boxes[row, 4], oy, dy, iy)
    t0, t1 = _slab(t0, t1, boxes[row, 2], boxes[row, 5], oz, dz, iz)
    return t0 if t0 <= t1 else np.inf


@kernel(inline=True)
def _slab(t0, t1, lo, hi, o, d, inv):
    """``(t0, t1)`` narrowed by one axis' slab ``lo <= o + t d <= hi`` (``inv = 1 / d``)."""
    if d == 0.0:
        if o < lo or o > hi:
            return np.inf, -np.inf
        return t0, t1
    a, b = (lo - o) * inv, (hi - o) * inv
    if a > b:
        a, b = b, a
    return max(t0, a), min(t1, b)
