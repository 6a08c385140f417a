"""Kernel of :mod:`refsoft.search.several`: the per-pixel acceptance of candidate virtual
triangles (float64). Its NumPy reference is ``tests/naive_images.py`` (``trace_reflections``,
the same ray test over every scene triangle)."""

import numpy as np

from .._numba import kernel


@kernel
def accept(lo, hi, r0, c0, valid, origin, direction, screen, bbox, dilate, real, best_t, best_c, best_uv, tested):
    """For box rows ``lo .. hi - 1`` (run by :func:`refsoft._parallel.parallel_range`; each row
    writes only its own outputs): every candidate whose dilated screen triangle covers a valid
    pixel's centre has its real triangle intersected by the pixel's reflected ray
    (Moller-Trumbore); a hit with ``t > 0`` inside the triangle, nearer than the pixel's best
    so far, wins (ties keep the earlier candidate).

    Parameters
    ----------
    r0, c0 : int
        The box's first row and column (``screen`` is in view pixels).
    valid : (h, w) bool
        Box pixels with a reflected ray.
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
    best_t, best_c, best_uv, tested
        Outputs per box pixel: nearest accepted t (inf none), its candidate (-1), its
        barycentrics (u, v) and whether any candidate covered it.
    """
    n = screen.shape[0]
    w = valid.shape[1]
    for r in range(lo, hi):
        y = r + r0 + 0.5
        for c in range(n):
            if r < bbox[c, 0] or r >= bbox[c, 1]:
                continue
            ax, ay = screen[c, 0, 0], screen[c, 0, 1]
            bx, by = screen[c, 1, 0], screen[c, 1, 1]
            cx, cy = screen[c, 2, 0], screen[c, 2, 1]
            area = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
            sign = 1.0 if area >= 0.0 else -1.0
            lab = np.sqrt((bx - ax) * (bx - ax) + (by - ay) * (by - ay))
            lbc = np.sqrt((cx - bx) * (cx - bx) + (cy - by) * (cy - by))
            lca = np.sqrt((ax - cx) * (ax - cx) + (ay - cy) * (ay - cy))
            d = dilate[c]
            # a sliver or an unusable projection: the dilated box alone
            plain = d < 0.0 or abs(area) <= 1e-12 * (lab + lbc + lca) * (lab + lbc + lca)
            p0x, p0y, p0z = real[c, 0, 0], real[c, 0, 1], real[c, 0, 2]
            e1x, e1y, e1z = real[c, 1, 0] - p0x, real[c, 1, 1] - p0y, real[c, 1, 2] - p0z
            e2x, e2y, e2z = real[c, 2, 0] - p0x, real[c, 2, 1] - p0y, real[c, 2, 2] - p0z
            for col in range(max(bbox[c, 2], c0), min(bbox[c, 3], c0 + w)):
                j = col - c0
                if not valid[r, j]:
                    continue
                if not plain:
                    x = col + 0.5
                    # signed distances to the three edges, inside positive
                    fab = sign * ((bx - ax) * (y - ay) - (by - ay) * (x - ax))
                    fbc = sign * ((cx - bx) * (y - by) - (cy - by) * (x - bx))
                    fca = sign * ((ax - cx) * (y - cy) - (ay - cy) * (x - cx))
                    if fab < -d * lab or fbc < -d * lbc or fca < -d * lca:
                        continue
                tested[r, j] = True
                dx, dy, dz = direction[r, j, 0], direction[r, j, 1], direction[r, j, 2]
                px, py, pz = dy * e2z - dz * e2y, dz * e2x - dx * e2z, dx * e2y - dy * e2x
                det = (e1x * px + e1y * py) + e1z * pz
                if det == 0.0:
                    continue
                inv = 1.0 / det
                sx, sy, sz = origin[r, j, 0] - p0x, origin[r, j, 1] - p0y, origin[r, j, 2] - p0z
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
