"""Kernels of :mod:`refsoft.search.several` (float64): the per-pixel acceptance of candidate
virtual triangles (``accept``, and ``accept_near`` over the pruning's ray lists), the pruning's ray
tests (``rays_near``, ``rays_near_every``), the candidates' screen bounds (``screen_bounds``), the
linked triples and the walks' nearest images. Their references: ``tests/naive_several_pool.py``
(``accept``, the plain pixel-by-candidate loop, bit for bit), ``tests/naive_several.py``
(``rays_near``, ``screen``, in NumPy) and ``tests/naive_images.py`` (``trace_reflections``, the
same ray test over every scene triangle)."""

import numpy as np

from .._numba import kernel


@kernel
def accept(lo, hi, r0, c0, valid, span, origin, direction, screen, bbox, dilate, real, run, best_t, best_c, best_uv,
           tested, seen):
    """For box rows ``lo .. hi - 1`` (run by :func:`refsoft._parallel.parallel_range`; each row
    writes only its own outputs): every candidate whose dilated screen triangle covers a valid
    pixel's centre has its real triangle intersected by the pixel's reflected ray
    (Moller-Trumbore); a hit with ``t > 0`` inside the triangle, nearer than the pixel's best
    so far, wins (ties keep the earlier candidate).

    The candidates are the outer loop (each one's data read once, its set-up made once); every
    pixel still sees them in index order, so the result is the row-by-row loop's. Consecutive
    candidates with the same real triangle (a run) test a pixel's ray once: a later one's
    intersection is the first one's, which was taken or refused already.

    Parameters
    ----------
    r0, c0 : int
        The box's first row and column (``screen`` is in view pixels).
    valid : (h, w) bool
        Box pixels with a reflected ray.
    span : (h, 2) int64
        Per box row its valid pixels' first box column and last plus one (first >= last: none).
    origin, direction : (h, w, 3) float64
        The reflected ray of each box pixel.
    screen : (C, 3, 2) float64
        The candidates' virtual vertices in view pixels (x = column, y = row, pixel centres at .5).
    bbox : (C, 4) int64
        Dilated bounds (row0, row1, col0, col1), half-open, in box rows and view columns.
    dilate : (C,) float64
        Dilation in pixels; negative: the projection is unusable, the whole bbox is tested.
    real : (C, 3, 3) float64
        The candidates' real triangles (world space).
    run : (C,) int64
        Non-decreasing; equal for consecutive candidates whose real triangles are the same bits.
    best_t, best_c, best_uv, tested
        Outputs per box pixel: nearest accepted t (inf none), its candidate (-1), its
        barycentrics (u, v) and whether any candidate covered it.
    seen : (h, w) int64
        Work per box pixel, -1 on entry: the run that last tested its ray.
    """
    for c in range(screen.shape[0]):
        _raster_one(c, lo, hi, r0, c0, valid, span, origin, direction, screen, bbox, dilate, real, run, best_t,
                    best_c, best_uv, tested, seen)


@kernel
def accept_untracked(lo, hi, r0, c0, valid, span, origin, direction, screen, bbox, dilate, real, origins, slack, best_t,
                     best_c, best_uv):
    """:func:`accept` without runs and without ``tested`` (each candidate its own run): the same
    ``best_t``, ``best_c`` and ``best_uv`` (a later candidate with the same real triangle meets a
    ray at the same ``t``, which does not replace the first), without two writes at every pixel
    a candidate covers.

    A pixel whose best hit is already nearer than the candidate's real triangle can be is not
    tested (it could not be replaced): ``origins`` (7,) (:func:`ray_bounds`) bounds every valid
    pixel's ray origin (min x, y, z, max x, y, z) and direction's length, so a ray meets the
    triangle at no ``t`` below the distance between that box and the triangle's over that length,
    and the test is left out where this exceeds the best ``t`` by more than ``slack`` times
    ``|t| + 1`` (far above the rounding of Moller-Trumbore, as in the traced acceptance: no hit
    that would win is ever left out)."""
    # written out rather than through _raster_one with its bookkeeping turned off: that way the
    # loop ran 1.5x slower on the ants' eyes (tens of thousands of candidates a few pixels wide)
    for c in range(screen.shape[0]):
        row0, row1 = max(lo, bbox[c, 0]), min(hi, bbox[c, 1])
        if row0 >= row1:
            continue
        ax, ay, bx, by, cx, cy, sign, lab, lbc, lca, d, plain = _outline(c, screen, dilate)
        p0x, p0y, p0z, e1x, e1y, e1z, e2x, e2y, e2z = _real_edges(real, c)
        near = _nearest_reach(real, c, origins)
        # narrowed to exactly the columns that pass the three edge tests, unless an edge's values
        # are too large to narrow: then each column is tested
        k1, a1, b1 = _edge(ax, ay, bx, by, sign, -d * lab)
        k2, a2, b2 = _edge(bx, by, cx, cy, sign, -d * lbc)
        k3, a3, b3 = _edge(cx, cy, ax, ay, sign, -d * lca)
        tests = not plain and (k1 == LOOSE or k2 == LOOSE or k3 == LOOSE)
        bc0, bc1 = bbox[c, 2], bbox[c, 3]
        for r in range(row0, row1):
            y = r + r0 + 0.5
            col0, col1 = max(bc0, c0 + span[r, 0]), min(bc1, c0 + span[r, 1])
            if col0 >= col1:
                continue
            if not plain:
                col0, col1 = _narrow_row(k1, a1, b1, col0, col1, y, ax, ay, bx, by, sign, -d * lab)
                col0, col1 = _narrow_row(k2, a2, b2, col0, col1, y, bx, by, cx, cy, sign, -d * lbc)
                col0, col1 = _narrow_row(k3, a3, b3, col0, col1, y, cx, cy, ax, ay, sign, -d * lca)
            for col in range(col0, col1):
                j = col - c0
                if not valid[r, j]:
                    continue
                bt = best_t[r, j]
                if near > bt + slack * (abs(bt) + 1.0):
                    continue
                if tests:
                    x = col + 0.5
                    if not _inside(x, y, ax, ay, bx, by, cx, cy, sign, lab, lbc, lca, d):
                        continue
                t, u, v = _meet(origin[r, j, 0], origin[r, j, 1], origin[r, j, 2], direction[r, j, 0],
                                direction[r, j, 1], direction[r, j, 2], p0x, p0y, p0z, e1x, e1y, e1z, e2x, e2y, e2z)
                if t > 0.0 and t < bt:
                    best_t[r, j] = t
                    best_c[r, j] = c
                    best_uv[r, j, 0] = u
                    best_uv[r, j, 1] = v


@kernel(inline=True)
def _outline(c, screen, dilate):
    """Candidate ``c``'s screen corners, the sign of its area, its edges' lengths, its dilation
    and whether it is tested by its dilated box alone (a sliver or an unusable projection)."""
    ax, ay = screen[c, 0, 0], screen[c, 0, 1]
    bx, by = screen[c, 1, 0], screen[c, 1, 1]
    cx, cy = screen[c, 2, 0], screen[c, 2, 1]
    area = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    sign = 1.0 if area >= 0.0 else -1.0
    lab = np.sqrt((bx - ax) * (bx - ax) + (by - ay) * (by - ay))
    lbc = np.sqrt((cx - bx) * (cx - bx) + (cy - by) * (cy - by))
    lca = np.sqrt((ax - cx) * (ax - cx) + (ay - cy) * (ay - cy))
    d = dilate[c]
    plain = d < 0.0 or abs(area) <= 1e-12 * (lab + lbc + lca) * (lab + lbc + lca)
    return ax, ay, bx, by, cx, cy, sign, lab, lbc, lca, d, plain


@kernel(inline=True)
def _inside(x, y, ax, ay, bx, by, cx, cy, sign, lab, lbc, lca, d):
    """Whether the point (x, y) passes the three edge tests of the screen triangle (ax, ay), (bx,
    by), (cx, cy) dilated by ``d`` (:func:`_outline`'s values): each edge's signed distance times
    its length, inside positive, at least ``-d`` times its length."""
    fab = sign * ((bx - ax) * (y - ay) - (by - ay) * (x - ax))
    fbc = sign * ((cx - bx) * (y - by) - (cy - by) * (x - bx))
    fca = sign * ((ax - cx) * (y - cy) - (ay - cy) * (x - cx))
    return not (fab < -d * lab or fbc < -d * lbc or fca < -d * lca)


@kernel(inline=True)
def _real_edges(real, c):
    """Candidate ``c``'s real triangle as Moller-Trumbore takes it: its first corner and the
    edges from it to the other two (9 floats)."""
    p0x, p0y, p0z = real[c, 0, 0], real[c, 0, 1], real[c, 0, 2]
    return (p0x, p0y, p0z, real[c, 1, 0] - p0x, real[c, 1, 1] - p0y, real[c, 1, 2] - p0z, real[c, 2, 0] - p0x,
            real[c, 2, 1] - p0y, real[c, 2, 2] - p0z)


@kernel(inline=True)
def _nearest_reach(real, c, origins):
    """The distance between the box ``origins[:6]`` (min x, y, z, max x, y, z) and candidate
    ``c``'s real triangle's box over the longest direction ``origins[6]``: no ray from the box
    meets the triangle at a lower ``t``. 0 where a value is not finite (nothing is left out)."""
    g2 = 0.0
    for k in range(3):
        a, b, e = real[c, 0, k], real[c, 1, k], real[c, 2, k]
        if not (np.isfinite(a) and np.isfinite(b) and np.isfinite(e)):
            return 0.0
        g = max(0.0, max(min(a, min(b, e)) - origins[3 + k], origins[k] - max(a, max(b, e))))
        g2 += g * g
    near = np.sqrt(g2) / origins[6]
    return near if np.isfinite(near) else 0.0


@kernel
def bounds_area(bbox, h, c0, c1):
    """The pixels of the box (rows ``0 .. h - 1``, view columns ``c0 .. c1 - 1``) the candidates'
    bounds ``bbox`` (C, 4) cover, summed over the candidates (float64)."""
    total = 0.0
    for c in range(bbox.shape[0]):
        rows = min(max(bbox[c, 1], 0), h) - min(max(bbox[c, 0], 0), h)
        cols = min(max(bbox[c, 3], c0), c1) - min(max(bbox[c, 2], c0), c1)
        if rows > 0 and cols > 0:
            total += float(rows * cols)
    return total


@kernel
def ray_bounds(lo, hi, valid, origin, direction, out):
    """For box rows ``lo .. hi - 1`` (run by :func:`refsoft._parallel.parallel_range`): ``out[r]``
    (7,) the bounds of the row's valid rays, min x, y, z and max x, y, z of their origins and the
    largest length of their directions (inf, -inf and 0 for a row without one)."""
    for r in range(lo, hi):
        for k in range(3):
            out[r, k] = np.inf
            out[r, 3 + k] = -np.inf
        out[r, 6] = 0.0
        for j in range(valid.shape[1]):
            if not valid[r, j]:
                continue
            for k in range(3):
                out[r, k] = min(out[r, k], origin[r, j, k])
                out[r, 3 + k] = max(out[r, 3 + k], origin[r, j, k])
            dx, dy, dz = direction[r, j, 0], direction[r, j, 1], direction[r, j, 2]
            out[r, 6] = max(out[r, 6], np.sqrt((dx * dx + dy * dy) + dz * dz))


@kernel(inline=True)
def _meet(ox, oy, oz, dx, dy, dz, p0x, p0y, p0z, e1x, e1y, e1z, e2x, e2y, e2z):
    """Moller-Trumbore: ``(t, u, v)`` of the ray's hit inside the triangle ``p0 + u e1 + v e2``,
    ``t = -1`` where it misses (or runs parallel)."""
    px, py, pz = dy * e2z - dz * e2y, dz * e2x - dx * e2z, dx * e2y - dy * e2x
    det = (e1x * px + e1y * py) + e1z * pz
    if det == 0.0:
        return -1.0, 0.0, 0.0
    inv = 1.0 / det
    sx, sy, sz = ox - p0x, oy - p0y, oz - p0z
    u = ((sx * px + sy * py) + sz * pz) * inv
    if u < 0.0 or u > 1.0:
        return -1.0, 0.0, 0.0
    qx, qy, qz = sy * e1z - sz * e1y, sz * e1x - sx * e1z, sx * e1y - sy * e1x
    v = ((dx * qx + dy * qy) + dz * qz) * inv
    if v < 0.0 or u + v > 1.0:
        return -1.0, 0.0, 0.0
    return ((e2x * qx + e2y * qy) + e2z * qz) * inv, u, v


@kernel(inline=True)
def _raster_one(c, lo, hi, r0, c0, valid, span, origin, direction, screen, bbox, dilate, real, run, best_t, best_c,
                best_uv, tested, seen):
    """:func:`accept` for candidate ``c`` on box rows ``lo .. hi - 1``."""
    row0, row1 = max(lo, bbox[c, 0]), min(hi, bbox[c, 1])
    if row0 >= row1:
        return
    ax, ay, bx, by, cx, cy, sign, lab, lbc, lca, d, plain = _outline(c, screen, dilate)
    p0x, p0y, p0z, e1x, e1y, e1z, e2x, e2y, e2z = _real_edges(real, c)
    for r in range(row0, row1):
        y = r + r0 + 0.5
        # only the row's valid columns
        col0, col1 = max(bbox[c, 2], c0 + span[r, 0]), min(bbox[c, 3], c0 + span[r, 1])
        if col0 >= col1:
            continue
        if not plain:
            col0, col1 = _narrow(col0, col1, y, ax, ay, bx, by, sign, -d * lab)
            col0, col1 = _narrow(col0, col1, y, bx, by, cx, cy, sign, -d * lbc)
            col0, col1 = _narrow(col0, col1, y, cx, cy, ax, ay, sign, -d * lca)
        for col in range(col0, col1):
            j = col - c0
            if not valid[r, j] or seen[r, j] == run[c]:  # tested by this run: nothing to change
                continue
            if not plain:
                x = col + 0.5
                # signed distances to the three edges, inside positive
                if not _inside(x, y, ax, ay, bx, by, cx, cy, sign, lab, lbc, lca, d):
                    continue
            tested[r, j] = True
            seen[r, j] = run[c]
            t, u, v = _meet(origin[r, j, 0], origin[r, j, 1], origin[r, j, 2], direction[r, j, 0], direction[r, j, 1],
                            direction[r, j, 2], p0x, p0y, p0z, e1x, e1y, e1z, e2x, e2y, e2z)
            if t > 0.0 and t < best_t[r, j]:
                best_t[r, j] = t
                best_c[r, j] = c
                best_uv[r, j, 0] = u
                best_uv[r, j, 1] = v


@kernel
def accept_near(lo, hi, r0, c0, valid, span, origin, direction, ray_row, ray_col, ray_origin, ray_direction, screen,
                bbox, dilate, real, run, first, last, ray, best_t, best_c, best_uv, tested, seen):
    """:func:`accept` over each candidate's rays that may hit its real triangle (``ray[first[c]:
    last[c]]``, ascending) instead of every pixel it covers: the same cover test, the same ray
    test and the same order of candidates per pixel, so where the lists hold every ray that
    can hit, ``best_t``, ``best_c`` and ``best_uv`` are :func:`accept`'s bit for bit (``tested``
    marks only the pixels of the lists that a candidate covers). A candidate without a list
    (``first[c] < 0``) is tested at every pixel it covers, as :func:`accept` does.

    Parameters
    ----------
    ray_row, ray_col : (R,) int64
        Each ray's box pixel, in row-major order.
    ray_origin, ray_direction : (R, 3) float64
        The rays (``origin``, ``direction`` at those pixels).
    first, last : (C,) int64
    ray : (K,) int64
        Ray indices, ascending within each candidate's list.
    r0, c0, valid, span, origin, direction, screen, bbox, dilate, real, run, best_t, best_c, best_uv, tested, seen
        As :func:`accept`.
    """
    n = screen.shape[0]
    for c in range(n):
        if first[c] < 0:
            _raster_one(c, lo, hi, r0, c0, valid, span, origin, direction, screen, bbox, dilate, real, run, best_t,
                        best_c, best_uv, tested, seen)
            continue
        row0, row1 = max(lo, bbox[c, 0]), min(hi, bbox[c, 1])
        if row0 >= row1:
            continue
        a = _first_on_row(ray_row, ray, first[c], last[c], row0)
        b = _first_on_row(ray_row, ray, a, last[c], row1)
        if a >= b:
            continue
        ax, ay, bx, by, cx, cy, sign, lab, lbc, lca, d, plain = _outline(c, screen, dilate)
        p0x, p0y, p0z, e1x, e1y, e1z, e2x, e2y, e2z = _real_edges(real, c)
        for q in range(a, b):
            k = ray[q]
            r, j = ray_row[k], ray_col[k]
            col = j + c0
            if col < bbox[c, 2] or col >= bbox[c, 3] or seen[r, j] == run[c]:
                continue
            if not plain:
                y = r + r0 + 0.5
                x = col + 0.5
                if not _inside(x, y, ax, ay, bx, by, cx, cy, sign, lab, lbc, lca, d):
                    continue
            tested[r, j] = True
            seen[r, j] = run[c]
            dx, dy, dz = ray_direction[k, 0], ray_direction[k, 1], ray_direction[k, 2]
            px, py, pz = dy * e2z - dz * e2y, dz * e2x - dx * e2z, dx * e2y - dy * e2x
            det = (e1x * px + e1y * py) + e1z * pz
            if det == 0.0:
                continue
            inv = 1.0 / det
            sx, sy, sz = ray_origin[k, 0] - p0x, ray_origin[k, 1] - p0y, ray_origin[k, 2] - p0z
            u = ((sx * px + sy * py) + sz * pz) * inv
            if u < 0.0 or u > 1.0:
                continue
            qx, qy, qz = sy * e1z - sz * e1y, sz * e1x - sx * e1z, sx * e1y - sy * e1x
            v = ((dx * qx + dy * qy) + dz * qz) * inv
            if v < 0.0 or u + v > 1.0:
                continue
            t = ((e2x * qx + e2y * qy) + e2z * qz) * inv
            if t > 0.0 and t < best_t[r, j]:
                best_t[r, j] = t
                best_c[r, j] = c
                best_uv[r, j, 0] = u
                best_uv[r, j, 1] = v


@kernel(inline=True)
def _first_on_row(ray_row, ray, lo, hi, row):
    """The first ``q`` of ``lo .. hi - 1`` with ``ray_row[ray[q]] >= row`` (``hi`` if none;
    ``ray[lo:hi]`` ascending, so their rows are)."""
    while lo < hi:
        mid = (lo + hi) // 2
        if ray_row[ray[mid]] < row:
            lo = mid + 1
        else:
            hi = mid
    return lo


@kernel(inline=True)
def _fails(col, y, ax, ay, bx, by, sign, limit):
    """Whether column ``col`` fails the edge test of :func:`_narrow` (the expression of
    :func:`_inside` for one edge)."""
    x = col + 0.5
    return sign * ((bx - ax) * (y - ay) - (by - ay) * (x - ax)) < limit


#: How an edge narrows a row's columns (:func:`_edge`): not at all (values too large: each column
#: is tested), all or none (an edge along the rows), a prefix or a suffix of them.
LOOSE, ALONG, PREFIX, SUFFIX = 0, 1, 2, 3


@kernel(inline=True)
def _edge(ax, ay, bx, by, sign, limit):
    """How the edge test of :func:`_narrow` narrows a row (LOOSE, ALONG, PREFIX or SUFFIX; its
    value is monotone in ``x``, each rounded operation being so), and where on row centre ``y``
    it changes, estimated as ``a + (y - ay) * b`` (the edge's equation solved for ``x``)."""
    if not (abs(ax) < 1e100 and abs(ay) < 1e100 and abs(bx) < 1e100 and abs(by) < 1e100 and abs(limit) < 1e100):
        return LOOSE, 0.0, 0.0
    if by - ay == 0.0:
        return ALONG, 0.0, 0.0
    # sign * (by - ay) > 0: the value falls as x grows
    return (PREFIX if sign * (by - ay) > 0.0 else SUFFIX), ax - sign * limit / (by - ay), (bx - ax) / (by - ay)


@kernel(inline=True)
def _narrow_row(kind, a, b, col0, col1, y, ax, ay, bx, by, sign, limit):
    """The columns of ``col0 .. col1 - 1`` on row centre ``y`` that pass the edge test
    ``sign * ((bx - ax) * (y - ay) - (by - ay) * (x - ax)) >= limit`` at ``x = col + 0.5``, for an
    edge :func:`_edge` made ``(kind, a, b)`` of: from the estimate, moved column by column to where
    the test itself (:func:`_fails`) changes, so exactly the columns a bisection with the test
    finds (LOOSE: all, tested by the caller; ALONG: the first column's test decides for all)."""
    if kind == LOOSE:
        return col0, col1
    if kind == ALONG:
        if col0 < col1 and _fails(col0, y, ax, ay, bx, by, sign, limit):
            return col0, col0
        return col0, col1
    # the estimate only saves steps (one not finite is clamped to the range): the loops decide
    guess = np.ceil(a + (y - ay) * b - 0.5)
    k = col0
    if guess > col1:
        k = col1
    elif guess >= col0:
        k = int(guess)
    if kind == PREFIX:  # k becomes the first failing column
        while k > col0 and _fails(k - 1, y, ax, ay, bx, by, sign, limit):
            k -= 1
        while k < col1 and not _fails(k, y, ax, ay, bx, by, sign, limit):
            k += 1
        return col0, k
    while k > col0 and not _fails(k - 1, y, ax, ay, bx, by, sign, limit):  # k: the first passing one
        k -= 1
    while k < col1 and _fails(k, y, ax, ay, bx, by, sign, limit):
        k += 1
    return k, col1


@kernel(inline=True)
def _narrow(col0, col1, y, ax, ay, bx, by, sign, limit):
    """The columns of ``col0 .. col1 - 1`` that may pass :func:`accept`'s test of the edge from
    (ax, ay) to (bx, by) on row centre ``y`` (:func:`_narrow_row`; an edge along the rows or
    with values too large is not narrowed). The caller still tests each column; this only skips
    columns that fail."""
    kind, a, b = _edge(ax, ay, bx, by, sign, limit)
    if kind == ALONG:
        return col0, col1
    return _narrow_row(kind, a, b, col0, col1, y, ax, ay, bx, by, sign, limit)


@kernel(inline=True)
def _is_linked(linked, key_base, i, j):
    """Whether images ``i`` and ``j`` are linked: ``min * key_base + max`` in the sorted ``linked``."""
    key = min(i, j) * key_base + max(i, j)
    lo, hi = 0, linked.shape[0]
    while lo < hi:
        mid = (lo + hi) // 2
        if linked[mid] < key:
            lo = mid + 1
        else:
            hi = mid
    return lo < linked.shape[0] and linked[lo] == key


@kernel
def linked_triples(lo, hi, faces, offset, count, linked, key_base, limit, start, out, fill):
    """Faces ``lo .. hi - 1`` (run by :func:`refsoft._parallel.parallel_range`; each face writes
    only its own outputs): the triples (i, j, k) of images of its corners (``offset[v] ..
    offset[v] + count[v] - 1``) linked pairwise, in nested-loop order (first corner slowest), at
    most ``limit``. ``fill`` False: writes each face's number of triples into ``start[f]``;
    True: writes them into ``out`` (T, 3) int64 from row ``start[f]``."""
    for f in range(lo, hi):
        a, b, c = faces[f, 0], faces[f, 1], faces[f, 2]
        n = 0
        pos = start[f] if fill else 0
        for i in range(offset[a], offset[a] + count[a]):
            if n >= limit:
                break
            for j in range(offset[b], offset[b] + count[b]):
                if n >= limit:
                    break
                if not _is_linked(linked, key_base, i, j):
                    continue
                for k in range(offset[c], offset[c] + count[c]):
                    if not (_is_linked(linked, key_base, j, k) and _is_linked(linked, key_base, i, k)):
                        continue
                    if fill:
                        out[pos + n, 0] = i
                        out[pos + n, 1] = j
                        out[pos + n, 2] = k
                    n += 1
                    if n >= limit:
                        break
        if not fill:
            start[f] = n


@kernel
def nearest_image(lo, hi, end, target, start, count, pixel, reach, out):
    """Walks ``lo .. hi - 1`` (run by :func:`refsoft._parallel.parallel_range`; each walk writes
    only ``out[w]``): the image of vertex ``target[w]`` (rows ``start[v] .. start[v] + count[v] -
    1`` of ``pixel`` (M, 2) int32) nearest the walk's end ``end[w]`` (Chebyshev; the first of
    equals), or -1 when none is within ``reach`` texels."""
    for w in range(lo, hi):
        v = target[w]
        best, best_d = -1, reach + 1
        for j in range(start[v], start[v] + count[v]):
            d = max(abs(np.int64(pixel[j, 0]) - end[w, 0]), abs(np.int64(pixel[j, 1]) - end[w, 1]))
            if d < best_d:
                best, best_d = j, d
        out[w] = best


@kernel
def rays_near(lo, hi, real, origin, direction, length, first, last, ray, margin, parallel, start, out, fill):
    """Triangles ``lo .. hi - 1`` (run by :func:`refsoft._parallel.parallel_range`; each writes
    only its own outputs): the rays among ``ray[first[f]:last[f]]`` that may hit triangle ``f``,
    in order. A ray is left out only when Moller-Trumbore (float64, :func:`accept`'s arithmetic)
    puts it clearly off the triangle: ``u`` or ``v`` below ``-margin``, ``u + v`` above
    ``1 + margin``, or ``t`` below ``-margin * (|e1| + |e2|)``; a ray within ``parallel`` of the
    plane (``|det| <= parallel * (|d| (|e1| |e2|))``) or with a non-finite value is kept.

    Parameters
    ----------
    real : (F, 3, 3) float64
        The triangles (world space).
    origin, direction : (R, 3) float64
        The rays.
    length : (R,) float64
        ``|direction|``: ``sqrt((dx * dx + dy * dy) + dz * dz)``.
    first, last : (F,) int64
        Each triangle's rays to test: ``ray[first[f]:last[f]]``.
    ray : (K,) int64
        Ray indices.
    margin, parallel : float
        ``constants.SEVERAL_PRUNE_MARGIN``, ``constants.SEVERAL_PRUNE_PARALLEL``.
    start : (F,) int64
        ``fill`` False: written, each triangle's number of rays kept; True: read, where its rays
        go in ``out``.
    out : (T,) int64
        ``fill`` True: the kept ray indices, triangle by triangle.
    """
    for f in range(lo, hi):
        n = 0
        pos = start[f] if fill else 0
        tri = _triangle(real, f, margin, parallel)
        for q in range(first[f], last[f]):
            r = ray[q]
            if not _may_hit(tri, origin[r, 0], origin[r, 1], origin[r, 2], direction[r, 0], direction[r, 1],
                            direction[r, 2], length[r], margin):
                continue
            if fill:
                out[pos + n] = r
            n += 1
        if not fill:
            start[f] = n


#: Rays per block of :func:`rays_near_every` (its seven float64 columns stay in the cache while
#: every triangle of a part is tested against them).
RAY_BLOCK = 2048


@kernel
def rays_near_every(lo, hi, real, rays, margin, parallel, count, start, at, out, fill):
    """:func:`rays_near` with every ray for every triangle (the same test, the same lists), the
    rays taken a block at a time for all triangles ``lo .. hi - 1``.

    Parameters
    ----------
    rays : (7, R) float64
        Origins (x, y, z), directions (x, y, z) and direction lengths, one row each.
    count : (F,) int64
        ``fill`` False: written, each triangle's number of rays kept; True: read (a triangle
        without any is skipped).
    start : (F,) int64
        ``fill`` True: where each triangle's rays go in ``out``.
    at : (F,) int64
        Work: each triangle's next place in ``out`` (or count).
    real, margin, parallel, out, fill
        As :func:`rays_near`.
    """
    n_rays = rays.shape[1]
    for f in range(lo, hi):
        at[f] = start[f] if fill else 0
    for b0 in range(0, n_rays, RAY_BLOCK):
        b1 = min(n_rays, b0 + RAY_BLOCK)
        for f in range(lo, hi):
            if fill and count[f] == 0:
                continue
            n = at[f]
            tri = _triangle(real, f, margin, parallel)
            for r in range(b0, b1):
                if not _may_hit(tri, rays[0, r], rays[1, r], rays[2, r], rays[3, r], rays[4, r], rays[5, r],
                                rays[6, r], margin):
                    continue
                if fill:
                    out[n] = r
                n += 1
            at[f] = n
    if not fill:
        for f in range(lo, hi):
            count[f] = at[f]


@kernel(inline=True)
def _triangle(real, f, margin, parallel):
    """Triangle ``f``'s corner, edges and the two limits of :func:`_may_hit`."""
    p0x, p0y, p0z = real[f, 0, 0], real[f, 0, 1], real[f, 0, 2]
    e1x, e1y, e1z = real[f, 1, 0] - p0x, real[f, 1, 1] - p0y, real[f, 1, 2] - p0z
    e2x, e2y, e2z = real[f, 2, 0] - p0x, real[f, 2, 1] - p0y, real[f, 2, 2] - p0z
    l1 = np.sqrt((e1x * e1x + e1y * e1y) + e1z * e1z)
    l2 = np.sqrt((e2x * e2x + e2y * e2y) + e2z * e2z)
    return p0x, p0y, p0z, e1x, e1y, e1z, e2x, e2y, e2z, parallel * (l1 * l2), -margin * (l1 + l2)


@kernel(inline=True)
def _may_hit(tri, ox, oy, oz, dx, dy, dz, length, margin):
    """:func:`rays_near`'s test of one ray against a triangle (:func:`_triangle`): False when
    clearly off."""
    p0x, p0y, p0z, e1x, e1y, e1z, e2x, e2y, e2z, flat, t_min = tri
    px, py, pz = dy * e2z - dz * e2y, dz * e2x - dx * e2z, dx * e2y - dy * e2x
    det = (e1x * px + e1y * py) + e1z * pz
    # the tests say "clearly off": a NaN fails them and the ray is kept
    if abs(det) <= flat * length:
        return True
    inv = 1.0 / det
    sx, sy, sz = ox - p0x, oy - p0y, oz - p0z
    u = ((sx * px + sy * py) + sz * pz) * inv
    if u < -margin or u > 1.0 + margin:
        return False
    qx, qy, qz = sy * e1z - sz * e1y, sz * e1x - sx * e1z, sx * e1y - sy * e1x
    v = ((dx * qx + dy * qy) + dz * qz) * inv
    if v < -margin or u + v > 1.0 + margin:
        return False
    t = ((e2x * qx + e2y * qy) + e2z * qz) * inv
    return not t < t_min


@kernel
def screen_bounds(lo, hi, clip, corner, width, height, r0, r1, c0, c1, pixels, fraction, screen, bbox, dilate, odd):
    """Candidates ``lo .. hi - 1`` (run by :func:`refsoft._parallel.parallel_range`; each writes
    only its own rows): the view-pixel positions of its virtual vertices from their clip
    coordinates, its dilated bounds and dilation, as ``refsoft.search.acceptance._screen_numpy``
    computes them (the same operations in the same order). A candidate with a vertex at or behind
    the eye plane has zeros, the whole box and -1. ``odd[c]`` is set where a value is not finite
    (the caller recomputes those rows with NumPy, whose NaN rules this does not copy).

    Parameters
    ----------
    clip : (n, 4) float64
        Clip coordinates of the virtual vertices.
    corner : (C, 3) int64
        Each candidate's rows of ``clip``.
    width, height : float
        The view's size.
    r0, r1, c0, c1 : int
        The box.
    pixels, fraction : float
        ``SEVERAL_DILATE_PIXELS``, ``SEVERAL_DILATE_FRACTION``.
    screen : (C, 3, 2) float64
    bbox : (C, 4) int64
    dilate : (C,) float64
    odd : (C,) bool
    """
    for c in range(lo, hi):
        good = clip[corner[c, 0], 3] > 0.0 and clip[corner[c, 1], 3] > 0.0 and clip[corner[c, 2], 3] > 0.0
        if not good:
            for k in range(3):
                screen[c, k, 0] = 0.0
                screen[c, k, 1] = 0.0
            bbox[c, 0], bbox[c, 1], bbox[c, 2], bbox[c, 3] = 0, r1 - r0, c0, c1
            dilate[c] = -1.0
            odd[c] = False
            continue
        bad = False
        for k in range(3):
            i = corner[c, k]
            wv = clip[i, 3]
            x = (clip[i, 0] / wv + 1.0) * 0.5 * width
            y = (1.0 - clip[i, 1] / wv) * 0.5 * height
            bad = bad or not (np.isfinite(x) and np.isfinite(y))
            screen[c, k, 0] = x
            screen[c, k, 1] = y
        bad = dilated_bounds(c, screen[c, 0, 0], screen[c, 0, 1], screen[c, 1, 0], screen[c, 1, 1], screen[c, 2, 0],
                             screen[c, 2, 1], bad, pixels, fraction, r0, bbox, dilate)
        odd[c] = bad


@kernel(inline=True)
def dilated_bounds(c, x0, y0, x1, y1, x2, y2, bad, pixels, fraction, r0, bbox, dilate):
    """Candidate ``c``'s dilation (``pixels`` plus ``fraction`` of its longest screen edge) and its
    dilated bounds in box rows and view columns, written to ``dilate[c]`` and ``bbox[c]`` from its
    corners' view-pixel positions, unless ``bad`` (a position that is not finite) or the dilation
    is not finite: returns whether either was (the row is left to the caller's NumPy)."""
    d = dilation(x0, y0, x1, y1, x2, y2, pixels, fraction)
    if bad or not np.isfinite(d):
        return True
    bbox[c, 0], bbox[c, 1], bbox[c, 2], bbox[c, 3] = dilated_box(x0, y0, x1, y1, x2, y2, d, r0)
    dilate[c] = d
    return False


@kernel(inline=True)
def dilation(x0, y0, x1, y1, x2, y2, pixels, fraction):
    """``pixels`` plus ``fraction`` of the longest edge of the screen triangle (x0, y0), (x1, y1),
    (x2, y2) (no branch: a loop of it vectorizes)."""
    edge = np.sqrt((x0 - x1) * (x0 - x1) + (y0 - y1) * (y0 - y1))
    e = np.sqrt((x1 - x2) * (x1 - x2) + (y1 - y2) * (y1 - y2))
    edge = e if e > edge else edge
    e = np.sqrt((x2 - x0) * (x2 - x0) + (y2 - y0) * (y2 - y0))
    edge = e if e > edge else edge
    return pixels + fraction * edge


@kernel(inline=True)
def dilated_box(x0, y0, x1, y1, x2, y2, d, r0):
    """The pixel bounds (row0, row1, col0, col1), half-open, rows from ``r0``, whose centres the
    screen triangle dilated by ``d`` may cover (finite values: each clamped to 2**30)."""
    big = float(1 << 30)
    lo_x, hi_x = min(x0, x1, x2) - d, max(x0, x1, x2) + d
    lo_y, hi_y = min(y0, y1, y2) - d, max(y0, y1, y2) + d
    return (np.int64(np.floor(min(max(lo_y - 0.5, -big), big))) - r0,
            np.int64(np.ceil(min(max(hi_y - 0.5, -big), big))) + 1 - r0,
            np.int64(np.floor(min(max(lo_x - 0.5, -big), big))),
            np.int64(np.ceil(min(max(hi_x - 0.5, -big), big))) + 1)


@kernel
def flat_bounds(lo, hi, loose, corner, screen, pixels, r0, bbox, dilate):
    """Candidates ``lo .. hi - 1`` of a flat mirror (run by :func:`refsoft._parallel.
    parallel_range`): each one whose projection is usable (``dilate >= 0``) and none of whose
    corners ``corner[c]`` is ``loose`` dilated by ``pixels`` alone (:func:`dilated_bounds` with no
    fraction of its longest edge), its ``bbox`` and ``dilate`` rewritten; the others (and one
    whose values turn out not finite) left as they are."""
    for c in range(lo, hi):
        if dilate[c] < 0.0 or loose[corner[c, 0]] or loose[corner[c, 1]] or loose[corner[c, 2]]:
            continue
        b0, b1, b2, b3, d = bbox[c, 0], bbox[c, 1], bbox[c, 2], bbox[c, 3], dilate[c]
        if dilated_bounds(c, screen[c, 0, 0], screen[c, 0, 1], screen[c, 1, 0], screen[c, 1, 1], screen[c, 2, 0],
                          screen[c, 2, 1], False, pixels, 0.0, r0, bbox, dilate):
            bbox[c, 0], bbox[c, 1], bbox[c, 2], bbox[c, 3], dilate[c] = b0, b1, b2, b3, d
