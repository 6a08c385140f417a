"""The G-buffer camera (spec section 4.5): the view camera, or its wider frustum.

``widen`` > 1 widens the field of view from the same eye, ``tan(fov'/2) = widen * tan(fov/2)``
(orthographic: ``ortho_height * widen``), at ``ceil(widen * width) x ceil(widen * height)``
pixels (or ``gbuffer_size``). The matrix is computed on the host in float64 with Python's
``math`` and NumPy's ``@``, as refsoft's camera does (``gluPerspective`` / ``glOrtho`` times the
case's view matrix), so it is the oracle's ``gbuffer_view_proj_K`` bit for bit.
"""

from __future__ import annotations

import math

import numpy as np


def projection_matrix(camera: dict, width: int, height: int, fov_y=None, ortho_height=None) -> np.ndarray:
    """``gluPerspective`` (or ``glOrtho``) of a camera record at a size, float64 (4, 4)."""
    n, f = float(camera["near"]), float(camera["far"])
    aspect = width / height
    m = np.zeros((4, 4))
    if camera["projection"] == "perspective":
        t = 1.0 / math.tan(math.radians(fov_y) / 2.0)
        m[0, 0] = t / aspect
        m[1, 1] = t
        m[2, 2] = (f + n) / (n - f)
        m[2, 3] = 2.0 * f * n / (n - f)
        m[3, 2] = -1.0
    else:
        top = ortho_height / 2.0
        right = top * aspect
        m[0, 0] = 1.0 / right
        m[1, 1] = 1.0 / top
        m[2, 2] = -2.0 / (f - n)
        m[2, 3] = -(f + n) / (f - n)
        m[3, 3] = 1.0
    return m


def gbuffer_camera(frame, options: dict):
    """``(view_proj (4, 4) float64, width, height)`` of the G-buffer camera of a frame."""
    cam = frame.camera
    widen = float(options.get("widen", 1.0))
    size = options.get("gbuffer_size")
    if widen == 1.0 and size is None:
        return frame.view_proj, int(cam["width"]), int(cam["height"])
    w = int(math.ceil(cam["width"] * widen)) if size is None else int(size[0])
    h = int(math.ceil(cam["height"] * widen)) if size is None else int(size[1])
    if cam["projection"] == "orthographic":
        proj = projection_matrix(cam, w, h, ortho_height=float(cam["ortho_height"]) * widen)
    else:
        fov = math.degrees(2.0 * math.atan(widen * math.tan(math.radians(float(cam["fov_y"])) / 2.0)))
        proj = projection_matrix(cam, w, h, fov_y=fov)
    return proj @ frame.view, w, h


def _inverse(matrix) -> list:
    """The inverse of a 4x4 matrix by Gauss-Jordan elimination with partial pivoting (the first
    of equal magnitudes), in Python floats: refsoft's ``linalg.inv``, operation for operation,
    so that the result is the oracle's bit for bit."""
    a = [[float(x) for x in row] for row in np.asarray(matrix, dtype=np.float64)]
    n = len(a)
    out = [[1.0 if i == j else 0.0 for j in range(n)] for i in range(n)]
    for col in range(n):
        pivot = max(range(col, n), key=lambda r: abs(a[r][col]))
        if a[pivot][col] == 0.0 or not math.isfinite(a[pivot][col]):
            raise ValueError("singular view-projection matrix")
        a[col], a[pivot] = a[pivot], a[col]
        out[col], out[pivot] = out[pivot], out[col]
        p = a[col][col]
        a[col] = [x / p for x in a[col]]
        out[col] = [x / p for x in out[col]]
        for r in range(n):
            if r != col and a[r][col] != 0.0:
                f = a[r][col]
                a[r] = [x - f * y for x, y in zip(a[r], a[col])]
                out[r] = [x - f * y for x, y in zip(out[r], out[col])]
    return out


def view_direction(view_proj, width: int, height: int) -> np.ndarray:
    """An orthographic camera's unit view direction, float64 (3,), as refsoft's camera gives it
    (the ray through pixel (0, 0)): the pixel's centre unprojected at window depth -1 and 1 by
    the inverse view-projection (rows times columns summed left to right), the far point minus
    the near one, divided by its length ``sqrt((x x + y y) + z z)``."""
    x = (0.0 + 0.5) / width * 2.0 - 1.0
    y = (height - 0.0 - 0.5) / height * 2.0 - 1.0
    inv = _inverse(view_proj)

    def unproject(z):
        v = [x, y, z, 1.0]
        h = [((v[0] * m[0] + v[1] * m[1]) + v[2] * m[2]) + v[3] * m[3] for m in inv]
        return [h[i] / h[3] for i in range(3)]

    near, far = unproject(-1.0), unproject(1.0)
    d = np.array([far[i] - near[i] for i in range(3)])
    return d / math.sqrt((d[0] * d[0] + d[1] * d[1]) + d[2] * d[2])
