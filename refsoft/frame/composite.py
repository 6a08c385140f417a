"""The composite (DESIGN section 5): a reflector's pixels show what its reflection method found
there, blended with the reflector's own colour; the same for every method."""

from __future__ import annotations

import numpy as np


def composite(colour, reflected, view_color, vcol, vid, covered, box, reflectivity):
    """Blend one reflector's reflection into the frame over ``box = (r0, r1, c0, c1)``, in
    place: where the reflection covers the stencil, ``colour = rho * reflected colour + (1 - rho)
    * reflector colour`` (float32) and ``reflected`` takes the reflected object id.

    Parameters
    ----------
    colour : ndarray (H, W, 3) float32, written
    reflected : ndarray (H, W) int32, written
    view_color : ndarray (H, W, 3) float32
        The main view's colour (the reflector's own).
    vcol, vid, covered : ndarray (h, w, 3) float32, (h, w) int32, (h, w) bool
        The reflection over the box (:class:`refsoft.seam.ReflectorResult`).
    box : (int, int, int, int)
    reflectivity : float
    """
    r0, r1, c0, c1 = box
    rho = np.float32(reflectivity)
    out_c = colour[r0:r1, c0:c1]
    out_c[covered] = rho * vcol[covered] + (np.float32(1) - rho) * view_color[r0:r1, c0:c1][covered]
    reflected[r0:r1, c0:c1][covered] = vid[covered]
