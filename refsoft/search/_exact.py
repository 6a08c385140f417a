"""Kernel of :mod:`refsoft.search.exact` (float64): which virtual triangles can be candidates of a
box's exact acceptance. Its reference: ``tests/search/test_exact.py`` (the same test in NumPy)."""

import numpy as np

from .._numba import kernel
from ..raster._rays import unit_normal


@kernel
def reaching(lo, hi, clip, faces, flags, lost, width, height, r0, r1, c0, c1, pixels, fraction, band, sat, keep):
    """Triangles ``lo .. hi - 1`` (run by :func:`refsoft._parallel.parallel_range`; each writes
    only its own entry): ``keep[t]`` is False where a vertex has a flag in ``lost`` or where the
    triangle's screen bounds, widened by the acceptance's dilation (``pixels + fraction *`` its
    longest screen edge) and one pixel more, stay off the box ``r0 .. r1, c0 .. c1`` (view rows
    and columns), or, with ``band``, whose widened bounds hold no pixel of the band; True
    otherwise, and always for a triangle with a vertex at or behind the eye plane or a screen
    position that is not finite.

    Parameters
    ----------
    clip : (n, 4) float64
        The vertices' clip coordinates.
    faces : (m, 3) int64
    flags : (n,) uint8
    lost : uint8
    width, height : float
        The view's size.
    r0, r1, c0, c1 : float
        The box.
    pixels, fraction : float
        ``SEVERAL_DILATE_PIXELS``, ``SEVERAL_DILATE_FRACTION``.
    band : bool
        Whether ``sat`` holds the pixels drawn.
    sat : (r1 - r0 + 1, c1 - c0 + 1) int64
        The summed-area table of the pixels drawn over the box (``sat[i, j]``: those in box rows
        ``< i`` and columns ``< j``).
    keep : (m,) bool
    """
    for t in range(lo, hi):
        a, b, c = faces[t, 0], faces[t, 1], faces[t, 2]
        if (flags[a] & lost) or (flags[b] & lost) or (flags[c] & lost):
            keep[t] = False
            continue
        if not (clip[a, 3] > 0.0 and clip[b, 3] > 0.0 and clip[c, 3] > 0.0):
            keep[t] = True
            continue
        xa = (clip[a, 0] / clip[a, 3] + 1.0) * 0.5 * width
        ya = (1.0 - clip[a, 1] / clip[a, 3]) * 0.5 * height
        xb = (clip[b, 0] / clip[b, 3] + 1.0) * 0.5 * width
        yb = (1.0 - clip[b, 1] / clip[b, 3]) * 0.5 * height
        xc = (clip[c, 0] / clip[c, 3] + 1.0) * 0.5 * width
        yc = (1.0 - clip[c, 1] / clip[c, 3]) * 0.5 * height
        edge = max(np.sqrt((xa - xb) ** 2 + (ya - yb) ** 2), np.sqrt((xb - xc) ** 2 + (yb - yc) ** 2),
                   np.sqrt((xc - xa) ** 2 + (yc - ya) ** 2))
        if not np.isfinite(edge):
            keep[t] = True
            continue
        reach = pixels + fraction * edge + 1.0
        off = (max(xa, xb, xc) + reach < c0 or min(xa, xb, xc) - reach > c1
               or max(ya, yb, yc) + reach < r0 or min(ya, yb, yc) - reach > r1)
        if band and not off:  # pixel centres at .5: rows y0 .. y1 - 1 of the box may be covered
            y0 = max(int(np.floor(min(ya, yb, yc) - reach - 0.5)), int(r0)) - int(r0)
            y1 = min(int(np.ceil(max(ya, yb, yc) + reach - 0.5)) + 1, int(r1)) - int(r0)
            x0 = max(int(np.floor(min(xa, xb, xc) - reach - 0.5)), int(c0)) - int(c0)
            x1 = min(int(np.ceil(max(xa, xb, xc) + reach - 0.5)) + 1, int(c1)) - int(c0)
            off = y0 >= y1 or x0 >= x1 or sat[y1, x1] - sat[y0, x1] - sat[y1, x0] + sat[y0, x0] == 0
        keep[t] = not off


@kernel
def corners(lo, hi, points, corner, out):
    """Triangles ``lo .. hi - 1``: ``out[t] = points[corner[t]]`` ((3, 3) each; NumPy's fancy
    indexing of the same, without its per-element cost on hundreds of thousands of corners)."""
    for t in range(lo, hi):
        for i in range(3):
            k = corner[t, i]
            out[t, i, 0], out[t, i, 1], out[t, i, 2] = points[k, 0], points[k, 1], points[k, 2]


@kernel
def shade_accepted(lo, hi, best_c, best_uv, corner, normals, cand_object, table, light, ambient, diffuse, colour, rid):
    """Box rows ``lo .. hi - 1`` (run by :func:`refsoft._parallel.parallel_range`; each writes only
    its own rows): at each pixel with a winning candidate ``c = best_c[r, j] >= 0`` the normal
    interpolated at its barycentrics ``best_uv[r, j]`` from its corners' normals, renormalised
    (zero stays zero), shaded as :func:`refsoft.raster.shade` does (float32), and its object.
    The same operations in the same order as :func:`refsoft.search.acceptance.shade_winners`
    (its reference), without its temporaries.

    Parameters
    ----------
    best_c : (h, w) int64
    best_uv : (h, w, 2) float64
    corner : (C, 3) int64
        Each candidate's rows of ``normals``.
    normals : (n, 3) float64
    cand_object : (C,) int32
    table : (K + 1, 3) float32
        Object colours by id.
    light : (3,) float32
    ambient, diffuse : float32
    colour : (h, w, 3) float32
        Zeros on entry; written where covered.
    rid : (h, w) int32
        Zeros on entry; written where covered.
    """
    for r in range(lo, hi):
        for j in range(best_c.shape[1]):
            c = best_c[r, j]
            if c < 0:
                continue
            u, v = best_uv[r, j, 0], best_uv[r, j, 1]
            nx, ny, nz = unit_normal(normals, corner[c, 0], corner[c, 1], corner[c, 2], (1.0 - u) - v, u, v)
            lam = abs((np.float32(nx) * light[0] + np.float32(ny) * light[1]) + np.float32(nz) * light[2])
            k = ambient + diffuse * lam
            obj = cand_object[c]
            colour[r, j, 0] = table[obj, 0] * k
            colour[r, j, 1] = table[obj, 1] * k
            colour[r, j, 2] = table[obj, 2] * k
            rid[r, j] = obj
