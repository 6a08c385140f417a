"""The 8-bit conversion kernel: in one pass what the NumPy formula of
:func:`refsoft.raster.to_uint8` does with several temporaries, with the same float64 arithmetic
(tested bit for bit against it). Shading is fused with interpolation
(:func:`refsoft.raster._kernels.shade_visible`)."""

import numpy as np

from .._numba import kernel


@kernel
def to_uint8_flat(lo, hi, c, out):
    """``out[i] = rint(clip(float64(c[i]), 0, 1) * 255)`` (round half to even; NaN gives 0) for
    ``i`` in ``lo .. hi - 1`` (run over every element by :func:`refsoft._parallel.parallel_range`)."""
    for i in range(lo, hi):
        x = np.float64(c[i])
        if not x > 0.0:
            out[i] = 0
        elif x >= 1.0:
            out[i] = 255
        else:
            out[i] = np.uint8(np.rint(x * 255.0))
