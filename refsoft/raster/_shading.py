"""Numba kernels for the full-image passes after rasterization: shading and 8-bit conversion.

They do in one pass what the NumPy formulas in :func:`refsoft.raster.shade` and
:func:`refsoft.raster.to_uint8` do with several temporaries, with the same float32 / float64
arithmetic in the same order (tested bit for bit against those formulas).
"""

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


@kernel(parallel=True)
def shade_ids(normals, object_id, table, light, ambient, diffuse, background, out):
    """``table[id] * (ambient + diffuse * |n . light|)`` per pixel (float32, the sum in the order
    x, y, z), ``background`` where ``id == 0``. ``table`` row 0 is unused."""
    h, w = object_id.shape
    for r in prange(h):
        for c in range(w):
            k = object_id[r, c]
            if k == 0:
                for ch in range(3):
                    out[r, c, ch] = background[ch]
                continue
            lam = abs(normals[r, c, 0] * light[0] + normals[r, c, 1] * light[1] + normals[r, c, 2] * light[2])
            f = ambient + diffuse * lam
            for ch in range(3):
                out[r, c, ch] = table[k, ch] * f


@kernel(parallel=True)
def object_ids(triangle, face_object, face_offset, object_id, local_triangle):
    """Per pixel: the object of the visible triangle (0: none) and the triangle's index within
    its object (-1: none). ``face_offset[k - 1]`` is object ``k``'s first triangle."""
    h, w = triangle.shape
    for r in prange(h):
        for c in range(w):
            t = triangle[r, c]
            if t < 0:
                object_id[r, c] = 0
                local_triangle[r, c] = -1
            else:
                k = face_object[t]
                object_id[r, c] = k
                local_triangle[r, c] = t - face_offset[k - 1]
