"""The depth test keeping the two nearest fragments per pixel (for the G-buffer's depth margin)."""

import numpy as np

from .._numba import kernel
from ..constants import SUBPIXEL_HALF, SUBPIXEL_ONE


@kernel
def raster_two_tiles(lo, hi, starts, items, X, Y, Z, tri, bbox, area, bias, height, tile, tiles_x, r_org, c_org,
                     depth, index, depth2, index2):
    """:func:`refsoft.raster._kernels.raster_tiles` (no peeling) of tiles ``lo .. hi - 1`` (run
    over every tile by :func:`refsoft._parallel.parallel_range`, each tile's pixels written by one
    thread) that also keeps, per pixel, the nearest fragment other than the winner: ``depth2``
    (float32, initialised to +inf) and ``index2`` (clip triangle, initialised to -1).

    The winner is exactly raster_tiles's (same coverage, same float64 depth rounded to float32,
    LESS, the first drawn winning equal depths). A fragment that does not win but is LESS than
    ``depth2`` becomes the second; a winner's predecessor moves to second place. A fragment at
    the winner's depth (a tie the first drawn won) is therefore a second fragment at margin 0.
    """
    rh, rw = depth.shape
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
            b0, b1, b2 = np.int64(bias[t, 0]), np.int64(bias[t, 1]), np.int64(bias[t, 2])
            s0 = -(y2 - y1) * SUBPIXEL_ONE
            s1 = -(y0 - y2) * SUBPIXEL_ONE
            s2 = -(y1 - y0) * SUBPIXEL_ONE
            px0 = np.int64(c0) * SUBPIXEL_ONE + SUBPIXEL_HALF
            for r in range(r0, r1 + 1):
                py = np.int64(height - 1 - r) * SUBPIXEL_ONE + SUBPIXEL_HALF
                e0 = (x2 - x1) * (py - y1) - (y2 - y1) * (px0 - x1) + b0
                e1 = (x0 - x2) * (py - y2) - (y0 - y2) * (px0 - x2) + b1
                e2 = (x1 - x0) * (py - y0) - (y1 - y0) * (px0 - x0) + b2
                rr = r - r_org
                inside = False
                for c in range(c0, c1 + 1):
                    if (e0 | e1 | e2) >= 0:
                        inside = True
                        z = ((np.float64(e0 - b0) * z0 + np.float64(e1 - b1) * z1)
                             + np.float64(e2 - b2) * z2) * inv_area
                        zf = np.float32(min(max(z, 0.0), 1.0))
                        cc = c - c_org
                        if zf < depth[rr, cc]:
                            if index[rr, cc] >= 0:
                                depth2[rr, cc] = depth[rr, cc]
                                index2[rr, cc] = index[rr, cc]
                            depth[rr, cc] = zf
                            index[rr, cc] = t
                        elif zf < depth2[rr, cc]:
                            depth2[rr, cc] = zf
                            index2[rr, cc] = t
                    elif inside:
                        break
                    e0 += s0
                    e1 += s1
                    e2 += s2
