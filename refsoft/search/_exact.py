"""Kernel of :mod:`refsoft.search.exact` (float64): which virtual triangles can be candidates of a
box's exact acceptance. Its reference: ``tests/search/test_exact.py`` (the same test in NumPy)."""

import numpy as np

from .._numba import kernel


@kernel
def reaching(lo, hi, clip, faces, flags, lost, width, height, r0, r1, c0, c1, pixels, fraction, keep):
    """Triangles ``lo .. hi - 1`` (run by :func:`refsoft._parallel.parallel_range`; each writes
    only its own entry): ``keep[t]`` is False where a vertex has a flag in ``lost`` or where the
    triangle's screen bounds, widened by the acceptance's dilation (``pixels + fraction *`` its
    longest screen edge) and one pixel more, stay off the box ``r0 .. r1, c0 .. c1`` (view rows
    and columns); True otherwise, and always for a triangle with a vertex at or behind the eye
    plane or a screen position that is not finite.

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
        keep[t] = not off
