"""Binning, tile-parallel coverage/depth, and per-pixel attribute interpolation kernels.

Coverage is exact integer arithmetic on snapped coordinates: with vertices ``a``, ``b`` and a
pixel centre ``p`` (all in 1/256 px, y up), ``E(a, b, p) = (bx-ax)(py-ay) - (by-ay)(px-ax)``.
Each tile is rasterized by one thread, walking its triangles in index order, so the result does
not depend on the thread count.
"""

import numpy as np

from .._numba import kernel, like
from .._parallel import parallel_range
from ..constants import SUBPIXEL_HALF, SUBPIXEL_ONE


#: Triangles are binned in this many contiguous chunks, in parallel; the result does not
#: depend on it (nor on the thread count): each tile lists its triangles in index order.
BIN_CHUNKS = 16


def bin_triangles(valid, bbox, tile, tiles_x, tiles_y, r_org, c_org, serial=False):
    """Per-tile lists of clip triangles (in index order) whose pixel box meets the tile; tiles
    cover the rasterized region, whose first pixel is (r_org, c_org).

    Parameters
    ----------
    valid : ndarray, shape (T,), bool
    bbox : ndarray, shape (T, 4), int32
        Pixel boxes (col min, col max, row min, row max), inside the region where ``valid``.
    tile, tiles_x, tiles_y : int
        Tile size in pixels; tiles per row and per column of the region.
    r_org, c_org : int
    serial : bool
        Bin on the calling thread alone (:func:`refsoft._parallel.parallel_range`).

    Returns
    -------
    starts : ndarray, shape (tiles_x * tiles_y + 1,), int64
    items : ndarray, shape (starts[-1],), int32
        Tile ``k``'s triangles are ``items[starts[k]:starts[k+1]]``.
    """
    n_tiles = tiles_x * tiles_y
    counts = np.zeros((BIN_CHUNKS, n_tiles), dtype=np.int64)
    parallel_range(_bin_count, BIN_CHUNKS, valid, bbox, tile, tiles_x, r_org, c_org, counts, serial=serial)
    # exclusive prefix sum in (tile, chunk) order: chunk ch of tile k starts at fill[ch, k]
    by_tile = counts.T.reshape(-1)
    ends = np.cumsum(by_tile)
    fill = np.ascontiguousarray((ends - by_tile).reshape(n_tiles, BIN_CHUNKS).T)
    starts = np.empty(n_tiles + 1, dtype=np.int64)
    starts[:n_tiles] = fill[0]
    starts[n_tiles] = ends[-1]
    items = np.empty(ends[-1], dtype=np.int32)
    parallel_range(_bin_fill, BIN_CHUNKS, valid, bbox, tile, tiles_x, r_org, c_org, fill, items, serial=serial)
    return starts, items


@kernel
def _bin_count(lo, hi, valid, bbox, tile, tiles_x, r_org, c_org, counts):
    """Chunks ``lo .. hi - 1`` of the triangles (BIN_CHUNKS in all): ``counts[ch, k]`` (zero on
    entry) gains one for each triangle of chunk ``ch`` whose pixel box meets tile ``k``."""
    n = valid.shape[0]
    chunk = (n + BIN_CHUNKS - 1) // BIN_CHUNKS
    for ch in range(lo, hi):
        for t in range(ch * chunk, min(n, (ch + 1) * chunk)):
            if not valid[t]:
                continue
            for ty in range((bbox[t, 2] - r_org) // tile, (bbox[t, 3] - r_org) // tile + 1):
                for tx in range((bbox[t, 0] - c_org) // tile, (bbox[t, 1] - c_org) // tile + 1):
                    counts[ch, ty * tiles_x + tx] += 1


@kernel
def _bin_fill(lo, hi, valid, bbox, tile, tiles_x, r_org, c_org, fill, items):
    """Chunks ``lo .. hi - 1``, as :func:`_bin_count` counted them: each triangle of chunk ``ch``
    written at ``items[fill[ch, k]]`` for every tile ``k`` its box meets, in index order
    (``fill[ch, k]``, the first slot of chunk ``ch`` in tile ``k``, is advanced)."""
    n = valid.shape[0]
    chunk = (n + BIN_CHUNKS - 1) // BIN_CHUNKS
    for ch in range(lo, hi):
        for t in range(ch * chunk, min(n, (ch + 1) * chunk)):
            if not valid[t]:
                continue
            for ty in range((bbox[t, 2] - r_org) // tile, (bbox[t, 3] - r_org) // tile + 1):
                for tx in range((bbox[t, 0] - c_org) // tile, (bbox[t, 1] - c_org) // tile + 1):
                    k = ty * tiles_x + tx
                    items[fill[ch, k]] = t
                    fill[ch, k] += 1


#: float32 lanes of a SIMD register (AVX2): shade_visible shades whole multiples of it.
SIMD_LANES = 8

#: Snapped coordinates below this magnitude (1/256 px, 65536 px) keep every edge value at a pixel
#: centre of the viewport (at most MAX_IMAGE_EDGE px) below 2^51, so float64 holds it exactly.
EXACT_COORD = 1 << 24


@kernel
def _span(g, f, q, ja, jb):
    """``[ja, jb]`` narrowed to the ``j`` where ``g + j f >= q`` (float64 holding integers below
    2^53: ``g``, ``f``, ``q`` and the products are exact). ``ceil``/``floor`` of the rounded
    quotient equal those of the exact one where it matters (in [-1, ja, jb + 1]): a quotient of
    integers with divisor ``|f| < 2^34`` is either an integer, rounded exactly, or 2^-34 away from
    one, farther than its rounding error. Compiled apart, not inlined at Numba's level: raster_tiles
    then compiles faster (LLVM still inlines it)."""
    if f > 0.0:
        return max(ja, np.ceil((q - g) / f)), jb
    if f < 0.0:
        return ja, min(jb, np.floor((q - g) / f))
    if g >= q:
        return ja, jb
    return ja, ja - 1.0


@kernel
def raster_tiles(lo, hi, starts, items, X, Y, Z, tri, bbox, area, bias, width, height, tile, tiles_x, r_org, c_org,
                 depth, index, triangle, peel, use_peel):
    """Depth-tested coverage of tiles ``lo .. hi - 1`` (run over every tile by
    :func:`refsoft._parallel.parallel_range`, each tile's pixels written by one thread). Writes ``depth`` (float32), ``index`` (clip triangle, int32) and
    ``triangle`` (input triangle, int32).

    A pixel centre is covered when ``e_i + bias_i >= 0`` for the three edges (bias -1 makes an
    edge exclusive). A fragment's window depth is ``(e0 z0 + e1 z1 + e2 z2) * (1 / area)`` in
    float64, clamped to [0, 1] and rounded to float32; it is kept when it is LESS than the stored
    depth (and, when peeling, strictly greater than ``peel``).

    For a triangle whose snapped vertices are within ``EXACT_COORD``, every edge value at a pixel
    centre is an integer below 2^53, exact in float64: a row's covered columns are found at
    once (:func:`_span`) and only they are visited, the edge values stepped in float64 without
    error, so coverage and depth are the integer path's, bit for bit. Other triangles are
    scanned column by column in int64.
    """
    rh, rw = depth.shape  # the region rasterized, whose first pixel is (r_org, c_org)
    for k in range(lo, hi):
        ty = k // tiles_x
        tx = k - ty * tiles_x
        r_lo = r_org + ty * tile
        r_hi = min(r_lo + tile, r_org + rh) - 1
        c_lo = c_org + tx * tile
        c_hi = min(c_lo + tile, c_org + rw) - 1
        for s in range(starts[k], starts[k + 1]):
            t = items[s]
            r0 = max(bbox[t, 2], r_lo)
            r1 = min(bbox[t, 3], r_hi)
            c0 = max(bbox[t, 0], c_lo)
            c1 = min(bbox[t, 1], c_hi)
            x0, x1, x2 = np.int64(X[t, 0]), np.int64(X[t, 1]), np.int64(X[t, 2])
            y0, y1, y2 = np.int64(Y[t, 0]), np.int64(Y[t, 1]), np.int64(Y[t, 2])
            z0, z1, z2 = Z[t, 0], Z[t, 1], Z[t, 2]
            inv_area = 1.0 / np.float64(area[t])
            face = tri[t]
            b0, b1, b2 = np.int64(bias[t, 0]), np.int64(bias[t, 1]), np.int64(bias[t, 2])
            # column steps of each edge function: E(c+1) = E(c) - (yb - ya) * SUBPIXEL_ONE
            s0 = -(y2 - y1) * SUBPIXEL_ONE
            s1 = -(y0 - y2) * SUBPIXEL_ONE
            s2 = -(y1 - y0) * SUBPIXEL_ONE
            if max(max(abs(x0), abs(x1)), max(abs(x2), max(abs(y0), max(abs(y1), abs(y2))))) < EXACT_COORD:
                # every edge value below is an integer < 2^53: exact in float64
                pxl = np.int64(c0) * SUBPIXEL_ONE + SUBPIXEL_HALF
                f0, f1, f2 = np.float64(s0), np.float64(s1), np.float64(s2)
                q0, q1, q2 = np.float64(-b0), np.float64(-b1), np.float64(-b2)  # covered: E_i >= -bias_i
                last = np.float64(c1 - c0)
                for r in range(r0, r1 + 1):
                    py = np.int64(height - 1 - r) * SUBPIXEL_ONE + SUBPIXEL_HALF
                    g0 = np.float64((x2 - x1) * (py - y1) - (y2 - y1) * (pxl - x1))
                    g1 = np.float64((x0 - x2) * (py - y2) - (y0 - y2) * (pxl - x2))
                    g2 = np.float64((x1 - x0) * (py - y0) - (y1 - y0) * (pxl - x0))
                    ja, jb = _span(g0, f0, q0, 0.0, last)
                    ja, jb = _span(g1, f1, q1, ja, jb)
                    ja, jb = _span(g2, f2, q2, ja, jb)
                    if ja > jb:
                        continue
                    e0 = g0 + ja * f0
                    e1 = g1 + ja * f1
                    e2 = g2 + ja * f2
                    rr = r - r_org
                    drow = depth[rr]
                    for c in range(c0 - c_org + np.int64(ja), c0 - c_org + np.int64(jb) + 1):
                        z = ((e0 * z0 + e1 * z1) + e2 * z2) * inv_area
                        zf = np.float32(min(max(z, 0.0), 1.0))
                        if zf < drow[c] and (not use_peel or zf > peel[rr, c]):
                            drow[c] = zf
                            index[rr, c] = t
                            triangle[rr, c] = face
                        e0 += f0
                        e1 += f1
                        e2 += f2
                continue
            px0 = np.int64(c0) * SUBPIXEL_ONE + SUBPIXEL_HALF
            for r in range(r0, r1 + 1):
                py = np.int64(height - 1 - r) * SUBPIXEL_ONE + SUBPIXEL_HALF
                # biased edge values: covered when all three are >= 0
                e0 = (x2 - x1) * (py - y1) - (y2 - y1) * (px0 - x1) + b0
                e1 = (x0 - x2) * (py - y2) - (y0 - y2) * (px0 - x2) + b1
                e2 = (x1 - x0) * (py - y0) - (y1 - y0) * (px0 - x0) + b2
                drow = depth[r - r_org]
                inside = False
                for c in range(c0, c1 + 1):
                    if (e0 | e1 | e2) >= 0:
                        inside = True
                        z = ((np.float64(e0 - b0) * z0 + np.float64(e1 - b1) * z1)
                             + np.float64(e2 - b2) * z2) * inv_area
                        zf = np.float32(min(max(z, 0.0), 1.0))
                        if zf < drow[c - c_org] and (not use_peel or zf > peel[r - r_org, c - c_org]):
                            drow[c - c_org] = zf
                            index[r - r_org, c - c_org] = t
                            triangle[r - r_org, c - c_org] = face
                    elif inside:
                        break  # a triangle's covered pixels in a row are contiguous
                    e0 += s0
                    e1 += s1
                    e2 += s2


@kernel
def _barycentrics(t, r, c, height, X, Y, IW, slot, B, fp):
    """Perspective-correct barycentrics of pixel (r, c) w.r.t. the input triangle of clip
    triangle ``t``, computed in the precision of the scalar ``fp`` (``IW`` and ``B`` already
    in it).
    An unclipped triangle maps through the identity (``slot == -1``) or swaps vertices 1 and 2
    (``slot == -2``): both exact, equal to multiplying by the permutation matrix."""
    py = np.int64(height - 1 - r) * SUBPIXEL_ONE + SUBPIXEL_HALF
    px = np.int64(c) * SUBPIXEL_ONE + SUBPIXEL_HALF
    x0, x1, x2 = np.int64(X[t, 0]), np.int64(X[t, 1]), np.int64(X[t, 2])
    y0, y1, y2 = np.int64(Y[t, 0]), np.int64(Y[t, 1]), np.int64(Y[t, 2])
    a0 = like((x2 - x1) * (py - y1) - (y2 - y1) * (px - x1), fp) * IW[t, 0]
    a1 = like((x0 - x2) * (py - y2) - (y0 - y2) * (px - x2), fp) * IW[t, 1]
    a2 = like((x1 - x0) * (py - y0) - (y1 - y0) * (px - x0), fp) * IW[t, 2]
    s = a0 + a1 + a2
    l0 = a0 / s
    l1 = a1 / s
    l2 = a2 / s
    k = slot[t]
    if k == -1:
        return l0, l1, l2
    if k == -2:
        return l0, l2, l1
    b0 = l0 * B[k, 0, 0] + l1 * B[k, 1, 0] + l2 * B[k, 2, 0]
    b1 = l0 * B[k, 0, 1] + l1 * B[k, 1, 1] + l2 * B[k, 2, 1]
    b2 = l0 * B[k, 0, 2] + l1 * B[k, 1, 2] + l2 * B[k, 2, 2]
    return b0, b1, b2


@kernel
def interpolate_rows(lo, hi, index, X, Y, IW, slot, B, tri, faces, attributes, height, r_org, c_org, normalize, fp,
                     out, acc):
    """Perspective-correct attributes of the visible triangle at every covered pixel of rows
    ``lo .. hi - 1`` (run over every row by :func:`refsoft._parallel.parallel_range`).

    In the precision of the scalar ``fp`` (``np.float32(0)`` or ``np.float64(0)``, matching
    the dtype of ``attributes``, ``IW``, ``B`` and ``out``): ``a_i = e_i * (1 / w_i)``,
    ``l_i = a_i / (a0 + a1 + a2)``, original barycentrics
    ``b_j = l0 B[0, j] + l1 B[1, j] + l2 B[2, j]`` (``B`` the clip vertices' barycentrics,
    the identity for unclipped triangles) and ``out = b0 A[v0] + b1 A[v1] + b2 A[v2]``;
    with ``normalize``, ``out / |out|`` (zero stays zero). ``out`` must be zeroed: uncovered
    pixels are not written. ``index`` covers the rasterized region, whose first pixel is
    (``r_org``, ``c_org``) of a viewport ``height`` pixels high. ``acc``: a work array of one
    pixel's channels, (C,) like ``attributes``.
    """
    h, w = index.shape
    n_ch = attributes.shape[1]
    for r in range(lo, hi):
        irow = index[r]
        orow = out[r]
        for c in range(w):
            t = irow[c]
            if t < 0:
                continue
            b0, b1, b2 = _barycentrics(t, r + r_org, c + c_org, height, X, Y, IW, slot, B, fp)
            f = tri[t]
            v0, v1, v2 = faces[f, 0], faces[f, 1], faces[f, 2]
            for ch in range(n_ch):
                acc[ch] = b0 * attributes[v0, ch] + b1 * attributes[v1, ch] + b2 * attributes[v2, ch]
            if normalize:
                sq = acc[0] * acc[0]
                for ch in range(1, n_ch):
                    sq += acc[ch] * acc[ch]
                length = np.sqrt(sq)
                if length > 0:
                    for ch in range(n_ch):
                        orow[c, ch] = acc[ch] / length
            else:
                for ch in range(n_ch):
                    orow[c, ch] = acc[ch]


@kernel
def interpolate_pair(lo, hi, index, X, Y, IW, slot, B, tri, faces, attr_a, attr_b, height, r_org, c_org, fp, out_a,
                     out_b):
    """:func:`interpolate_rows` of two 3-vector attributes at once, the second renormalised (the
    G-buffer's positions and normals share each pixel's barycentrics), rows ``lo .. hi - 1``. Same
    arithmetic."""
    h, w = index.shape
    for r in range(lo, hi):
        irow = index[r]
        row_a = out_a[r]
        row_b = out_b[r]
        for c in range(w):
            t = irow[c]
            if t < 0:
                continue
            b0, b1, b2 = _barycentrics(t, r + r_org, c + c_org, height, X, Y, IW, slot, B, fp)
            f = tri[t]
            v0, v1, v2 = faces[f, 0], faces[f, 1], faces[f, 2]
            for ch in range(3):
                row_a[c, ch] = b0 * attr_a[v0, ch] + b1 * attr_a[v1, ch] + b2 * attr_a[v2, ch]
            n0 = b0 * attr_b[v0, 0] + b1 * attr_b[v1, 0] + b2 * attr_b[v2, 0]
            n1 = b0 * attr_b[v0, 1] + b1 * attr_b[v1, 1] + b2 * attr_b[v2, 1]
            n2 = b0 * attr_b[v0, 2] + b1 * attr_b[v1, 2] + b2 * attr_b[v2, 2]
            length = np.sqrt((n0 * n0 + n1 * n1) + n2 * n2)
            if length > 0:
                row_b[c, 0] = n0 / length
                row_b[c, 1] = n1 / length
                row_b[c, 2] = n2 / length


@kernel
def _shade_run(crow, orow, lrow, g0, g1, g2, f0, f1, f2, w0, w1, w2, swap, na0, na1, na2, nb0, nb1, nb2, nc0, nc1,
               nc2, lx, ly, lz, ambient, diffuse, k0, k1, k2, k, local):
    """:func:`shade_visible` along a run of one unclipped triangle (``swap``: vertices 1 and 2
    swapped) whose edge values are exact in float64 (``g_i + j f_i``, see :func:`raster_tiles`):
    ``np.float32`` of the exact float64 value is ``np.float32`` of the integer. Same float32
    arithmetic; without branches, so that the loop runs on SIMD lanes. Colours of
    ``len(crow) // 3`` pixels are written (those past the run are overwritten by the caller),
    ids and local triangles of the run's ``len(orow)``."""
    fp = np.float32(0)
    for j in range(crow.shape[0] // 3):
        fj = np.float64(np.int32(j))
        a0 = np.float32(g0 + fj * f0) * w0
        a1 = np.float32(g1 + fj * f1) * w1
        a2 = np.float32(g2 + fj * f2) * w2
        sa = a0 + a1 + a2
        l0 = a0 / sa
        l1 = a1 / sa
        l2 = a2 / sa
        b1 = l2 if swap else l1
        b2 = l1 if swap else l2
        n0 = l0 * na0 + b1 * nb0 + b2 * nc0
        n1 = l0 * na1 + b1 * nb1 + b2 * nc1
        n2 = l0 * na2 + b1 * nb2 + b2 * nc2
        length = np.sqrt((n0 * n0 + n1 * n1) + n2 * n2)
        pos = length > 0
        u0 = n0 / length
        u1 = n1 / length
        u2 = n2 / length
        lam = abs(((u0 if pos else fp) * lx + (u1 if pos else fp) * ly) + (u2 if pos else fp) * lz)
        sh = ambient + diffuse * lam
        crow[3 * j] = k0 * sh
        crow[3 * j + 1] = k1 * sh
        crow[3 * j + 2] = k2 * sh
    for j in range(orow.shape[0]):  # apart: stores to several arrays in one loop keep it scalar
        orow[j] = k
        lrow[j] = local


@kernel
def shade_visible(lo, hi, index, X, Y, IW, slot, B, tri, faces, normals, face_object, face_offset, table, light,
                  ambient, diffuse, stencil, use_stencil, height, r_org, c_org, color, object_id, local_triangle, flat):
    """Rows ``lo .. hi - 1`` (run over every row by :func:`refsoft._parallel.parallel_range`): the visible triangle's normal (:func:`interpolate_rows` in float32, renormalised), shaded
    as :func:`refsoft.raster._shading.shade_ids` does, in one pass: per pixel of the region
    ``color`` (h, w, 3) float32 ``table[k] * (ambient + diffuse * |n . light|)``, ``object_id``
    (h, w) int32 ``k = face_object[triangle]`` and ``local_triangle`` (h, w) int32 ``triangle -
    face_offset[k - 1]``; where nothing is drawn (or, with ``use_stencil``, ``stencil`` (h, w)
    bool is False) ``table[0]``, 0 and -1. Same float32 arithmetic in the same order as the
    two kernels it replaces, without their (h, w, 3) normal map. ``flat`` is ``color`` as one
    row (h w 3,): (r, c, ch) at 3 (r w + c) + ch, a stride SIMD code can see.

    Each row is walked as runs of pixels of one clip triangle, whose constants are loaded once
    per run; a run of an unclipped triangle within ``EXACT_COORD`` is shaded on SIMD lanes
    (:func:`_shade_run`), others pixel by pixel (:func:`_barycentrics`)."""
    h, w = index.shape
    fp = np.float32(0)
    lx, ly, lz = light[0], light[1], light[2]
    for r in range(lo, hi):
        irow = index[r]
        crow = color[r]
        py = np.int64(height - 1 - (r + r_org)) * SUBPIXEL_ONE + SUBPIXEL_HALF
        c = 0
        while c < w:
            t = irow[c]
            if t < 0 or (use_stencil and not stencil[r, c]):
                crow[c, 0] = table[0, 0]
                crow[c, 1] = table[0, 1]
                crow[c, 2] = table[0, 2]
                object_id[r, c] = 0
                local_triangle[r, c] = -1
                c += 1
                continue
            # a run of pixels of one triangle: its constants are loaded once
            end = c + 1
            while end < w and irow[end] == t and (not use_stencil or stencil[r, end]):
                end += 1
            x0, x1, x2 = np.int64(X[t, 0]), np.int64(X[t, 1]), np.int64(X[t, 2])
            y0, y1, y2 = np.int64(Y[t, 0]), np.int64(Y[t, 1]), np.int64(Y[t, 2])
            m = slot[t]
            f = tri[t]
            v0, v1, v2 = faces[f, 0], faces[f, 1], faces[f, 2]
            na0, na1, na2 = normals[v0, 0], normals[v0, 1], normals[v0, 2]
            nb0, nb1, nb2 = normals[v1, 0], normals[v1, 1], normals[v1, 2]
            nc0, nc1, nc2 = normals[v2, 0], normals[v2, 1], normals[v2, 2]
            k = face_object[f]
            k0, k1, k2 = table[k, 0], table[k, 1], table[k, 2]
            local = f - face_offset[k - 1]
            if m < 0 and max(max(abs(x0), abs(x1)), max(abs(x2), max(abs(y0), max(abs(y1), abs(y2))))) < EXACT_COORD:
                px = np.int64(c + c_org) * SUBPIXEL_ONE + SUBPIXEL_HALF
                e0 = (x2 - x1) * (py - y1) - (y2 - y1) * (px - x1)
                e1 = (x0 - x2) * (py - y2) - (y0 - y2) * (px - x2)
                e2 = (x1 - x0) * (py - y0) - (y1 - y0) * (px - x0)
                # whole SIMD widths: the pixels shaded past the run are shaded again by theirs,
                # later in this row (not past the row: another thread's)
                lanes = end - c if end - c < 2 else min(-(-(end - c) // SIMD_LANES) * SIMD_LANES, w - c)
                _shade_run(flat[3 * (r * w + c):3 * (r * w + c + lanes)], object_id[r, c:end],
                           local_triangle[r, c:end], np.float64(e0), np.float64(e1), np.float64(e2),
                           np.float64(-(y2 - y1) * SUBPIXEL_ONE), np.float64(-(y0 - y2) * SUBPIXEL_ONE),
                           np.float64(-(y1 - y0) * SUBPIXEL_ONE), IW[t, 0], IW[t, 1], IW[t, 2], m == -2, na0, na1,
                           na2, nb0, nb1, nb2, nc0, nc1, nc2, lx, ly, lz, ambient, diffuse, k0, k1, k2, k, local)
                c = end
                continue
            for cc in range(c, end):  # clipped, or beyond EXACT_COORD: pixel by pixel in int64
                b0, b1, b2 = _barycentrics(t, r + r_org, cc + c_org, height, X, Y, IW, slot, B, fp)
                n0 = b0 * na0 + b1 * nb0 + b2 * nc0
                n1 = b0 * na1 + b1 * nb1 + b2 * nc1
                n2 = b0 * na2 + b1 * nb2 + b2 * nc2
                length = np.sqrt((n0 * n0 + n1 * n1) + n2 * n2)
                if length > 0:
                    n0, n1, n2 = n0 / length, n1 / length, n2 / length
                else:  # interpolate_rows leaves such a pixel's normal zero
                    n0, n1, n2 = fp, fp, fp
                lam = abs((n0 * lx + n1 * ly) + n2 * lz)
                sh = ambient + diffuse * lam
                crow[cc, 0] = k0 * sh
                crow[cc, 1] = k1 * sh
                crow[cc, 2] = k2 * sh
                object_id[r, cc] = k
                local_triangle[r, cc] = local
            c = end



@kernel
def world_positions(lo, hi, r0, c0, c1, position, mask, origin, out):
    """For the G-buffer's rows ``r0 + lo .. r0 + hi - 1``, columns ``c0 .. c1 - 1`` (run by
    :func:`refsoft._parallel.parallel_range`): ``out = float32(float64(position) + origin)`` where
    ``mask``, zero elsewhere (the world positions rounded once to float32). ``position`` (H, W, 3)
    float32 or float64 relative to ``origin`` (3,) float64; ``out`` (H, W, 3) float32."""
    for r in range(r0 + lo, r0 + hi):
        for c in range(c0, c1):
            if mask[r, c]:
                for k in range(3):
                    out[r, c, k] = np.float32(np.float64(position[r, c, k]) + origin[k])
            else:
                for k in range(3):
                    out[r, c, k] = np.float32(0.0)
