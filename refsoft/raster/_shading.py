"""The 8-bit conversion kernel: in one pass what the NumPy formula of
:func:`refsoft.raster.to_uint8` does with several temporaries, with the same float64 arithmetic
(tested bit for bit against it). Shading is fused with interpolation
(:func:`refsoft.raster._kernels.shade_visible`)."""

import numpy as np
from numba import prange

from .._numba import kernel

#: Elements per parallel chunk of the flat kernels.
_CHUNK = 1 << 16


@kernel(parallel=True)
def to_uint8_flat(c, out):
    """``out[i] = rint(clip(float64(c[i]), 0, 1) * 255)`` (round half to even; NaN gives 0)."""
    n = c.shape[0]
    for k in prange((n + _CHUNK - 1) // _CHUNK):
        for i in range(k * _CHUNK, min(n, (k + 1) * _CHUNK)):
            x = np.float64(c[i])
            if not x > 0.0:
                out[i] = 0
            elif x >= 1.0:
                out[i] = 255
            else:
                out[i] = np.uint8(np.rint(x * 255.0))
