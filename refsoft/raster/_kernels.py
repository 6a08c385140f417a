"""Binning, tile-parallel coverage/depth, and per-pixel attribute interpolation kernels.

Coverage is exact integer arithmetic on snapped coordinates: with vertices ``a``, ``b`` and a
pixel centre ``p`` (all in 1/256 px, y up), ``E(a, b, p) = (bx-ax)(py-ay) - (by-ay)(px-ax)``.
Each tile is rasterized by one thread, walking its triangles in index order, so the result does
not depend on the thread count.
"""

import numpy as np
from numba import prange

from .._numba import kernel


@kernel
def bin_triangles(valid, bbox, tile, tiles_x, tiles_y):
    """Per-tile lists of clip triangles (in index order) whose pixel box meets the tile.

    Returns ``(starts, items)``: tile ``k``'s triangles are ``items[starts[k]:starts[k+1]]``.
    """
    n_tiles = tiles_x * tiles_y
    counts = np.zeros(n_tiles + 1, dtype=np.int64)
    n = valid.shape[0]
    for t in range(n):
        if not valid[t]:
            continue
        for ty in range(bbox[t, 2] // tile, bbox[t, 3] // tile + 1):
            for tx in range(bbox[t, 0] // tile, bbox[t, 1] // tile + 1):
                counts[ty * tiles_x + tx + 1] += 1
    starts = np.cumsum(counts)
    fill = starts[:-1].copy()
    items = np.empty(starts[-1], dtype=np.int32)
    for t in range(n):
        if not valid[t]:
            continue
        for ty in range(bbox[t, 2] // tile, bbox[t, 3] // tile + 1):
            for tx in range(bbox[t, 0] // tile, bbox[t, 1] // tile + 1):
                k = ty * tiles_x + tx
                items[fill[k]] = t
                fill[k] += 1
    return starts, items


@kernel(parallel=True)
def raster_tiles(starts, items, X, Y, Z, bbox, area, bias, width, height, tile, tiles_x,
                 depth, index, peel, use_peel):
    """Depth-tested coverage. Writes ``depth`` (float32) and ``index`` (clip triangle, int32).

    A fragment's window depth is ``(e0 z0 + e1 z1 + e2 z2) * (1 / area)`` in float64, clamped to
    [0, 1] and rounded to float32; it is kept when it is LESS than the stored depth (and, when
    peeling, strictly greater than ``peel``).
    """
    n_tiles = starts.shape[0] - 1
    for k in prange(n_tiles):
        ty = k // tiles_x
        tx = k - ty * tiles_x
        r_lo = ty * tile
        r_hi = min(r_lo + tile, height) - 1
        c_lo = tx * tile
        c_hi = min(c_lo + tile, width) - 1
        for s in range(starts[k], starts[k + 1]):
            t = items[s]
            r0 = max(bbox[t, 2], r_lo)
            r1 = min(bbox[t, 3], r_hi)
            c0 = max(bbox[t, 0], c_lo)
            c1 = min(bbox[t, 1], c_hi)
            x0, x1, x2 = X[t, 0], X[t, 1], X[t, 2]
            y0, y1, y2 = Y[t, 0], Y[t, 1], Y[t, 2]
            b0, b1, b2 = bias[t, 0], bias[t, 1], bias[t, 2]
            z0, z1, z2 = Z[t, 0], Z[t, 1], Z[t, 2]
            inv_area = 1.0 / np.float64(area[t])
            # column steps of each edge function: E(c+1) = E(c) - (yb - ya) * 256
            s0 = -(y2 - y1) * 256
            s1 = -(y0 - y2) * 256
            s2 = -(y1 - y0) * 256
            px0 = np.int64(c0) * 256 + 128
            for r in range(r0, r1 + 1):
                py = np.int64(height - 1 - r) * 256 + 128
                e0 = (x2 - x1) * (py - y1) - (y2 - y1) * (px0 - x1)
                e1 = (x0 - x2) * (py - y2) - (y0 - y2) * (px0 - x2)
                e2 = (x1 - x0) * (py - y0) - (y1 - y0) * (px0 - x0)
                for c in range(c0, c1 + 1):
                    if e0 + b0 >= 0 and e1 + b1 >= 0 and e2 + b2 >= 0:
                        z = (np.float64(e0) * z0 + np.float64(e1) * z1 + np.float64(e2) * z2) * inv_area
                        z = min(max(z, 0.0), 1.0)
                        zf = np.float32(z)
                        if zf < depth[r, c] and (not use_peel or zf > peel[r, c]):
                            depth[r, c] = zf
                            index[r, c] = t
                    e0 += s0
                    e1 += s1
                    e2 += s2


@kernel(parallel=True)
def interpolate_rows(index, X, Y, IW, B, tri, faces, attributes, height, normalize, out):
    """Perspective-correct attributes of the visible triangle at every covered pixel.

    In the attributes' precision: ``a_i = e_i * (1 / w_i)``, ``l_i = a_i / (a0 + a1 + a2)``,
    original barycentrics ``b_j = l0 B[0, j] + l1 B[1, j] + l2 B[2, j]`` and
    ``out = b0 A[v0] + b1 A[v1] + b2 A[v2]``; with ``normalize``, ``out / |out|`` (zero stays
    zero). ``IW`` and ``B`` must already be in the attributes' dtype. Uncovered pixels are 0.
    """
    h, w = index.shape
    n_ch = attributes.shape[1]
    for r in prange(h):
        ef = np.empty(3, dtype=attributes.dtype)  # casts int64 edge values to the working dtype
        acc = np.empty(n_ch, dtype=attributes.dtype)
        py = np.int64(height - 1 - r) * 256 + 128
        for c in range(w):
            t = index[r, c]
            if t < 0:
                for ch in range(n_ch):
                    out[r, c, ch] = 0
                continue
            px = np.int64(c) * 256 + 128
            x0, x1, x2 = X[t, 0], X[t, 1], X[t, 2]
            y0, y1, y2 = Y[t, 0], Y[t, 1], Y[t, 2]
            ef[0] = (x2 - x1) * (py - y1) - (y2 - y1) * (px - x1)
            ef[1] = (x0 - x2) * (py - y2) - (y0 - y2) * (px - x2)
            ef[2] = (x1 - x0) * (py - y0) - (y1 - y0) * (px - x0)
            a0 = ef[0] * IW[t, 0]
            a1 = ef[1] * IW[t, 1]
            a2 = ef[2] * IW[t, 2]
            s = a0 + a1 + a2
            l0 = a0 / s
            l1 = a1 / s
            l2 = a2 / s
            bb0 = l0 * B[t, 0, 0] + l1 * B[t, 1, 0] + l2 * B[t, 2, 0]
            bb1 = l0 * B[t, 0, 1] + l1 * B[t, 1, 1] + l2 * B[t, 2, 1]
            bb2 = l0 * B[t, 0, 2] + l1 * B[t, 1, 2] + l2 * B[t, 2, 2]
            f = tri[t]
            v0, v1, v2 = faces[f, 0], faces[f, 1], faces[f, 2]
            for ch in range(n_ch):
                acc[ch] = bb0 * attributes[v0, ch] + bb1 * attributes[v1, ch] + bb2 * attributes[v2, ch]
            if normalize:
                sq = acc[0] * acc[0]
                for ch in range(1, n_ch):
                    sq += acc[ch] * acc[ch]
                length = np.sqrt(sq)
                for ch in range(n_ch):
                    out[r, c, ch] = acc[ch] / length if length > 0 else 0
            else:
                for ch in range(n_ch):
                    out[r, c, ch] = acc[ch]
