"""Small linear algebra written out in elementwise NumPy, in a fixed order of operations.

NumPy's ``@``, ``np.dot``, a 1-D ``np.linalg.norm`` and ``np.linalg.inv`` go through the BLAS and
LAPACK NumPy was built with (OpenBLAS in the wheels), which picks a kernel for the machine's CPU
at run time: the same product of two 4x4 matrices then differs in the last bit between an
AVX-512 machine and an AVX2 one (measured: the golden set's cameras and world meshes changed).
The oracle's inputs (camera matrices, world meshes, shading's light) are computed here instead,
so that its outputs are the same on every machine: each result below is a sum of products taken
left to right, ``(a0 b0 + a1 b1) + a2 b2``, with IEEE arithmetic only (no fused multiply-add).
"""

from __future__ import annotations

import math

import numpy as np


def dot3(a, b) -> np.ndarray:
    """``(a0 b0 + a1 b1) + a2 b2`` over the last axis (broadcasting), float64 for float64 input."""
    a = np.asarray(a)
    b = np.asarray(b)
    return (a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1]) + a[..., 2] * b[..., 2]


def norm3(a) -> np.ndarray:
    """``sqrt(dot3(a, a))``: the length over the last axis."""
    return np.sqrt(dot3(a, a))


def unit3(a) -> np.ndarray:
    """``a / norm3(a)`` for one vector (shape (3,)); raises on the zero vector."""
    a = np.asarray(a, dtype=np.float64)
    n = float(norm3(a))
    if n == 0.0:
        raise ValueError("cannot normalise the zero vector")
    return a / n


def matmul(a, b) -> np.ndarray:
    """The matrix product ``a @ b`` of 2-D float64 arrays (shapes (m, k) and (k, n)), each entry
    summed over ``k`` left to right."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    if a.ndim != 2 or b.ndim != 2 or a.shape[1] != b.shape[0]:
        raise ValueError(f"matmul of shapes {a.shape} and {b.shape}")
    out = a[:, 0, None] * b[0]
    for j in range(1, a.shape[1]):
        out = out + a[:, j, None] * b[j]
    return out


def matvec(m, v) -> np.ndarray:
    """``m @ v`` for a 2-D ``m`` (r, k) and a vector ``v`` (k,)."""
    return matmul(m, np.asarray(v, dtype=np.float64).reshape(-1, 1))[:, 0]


def rows_times(points, m) -> np.ndarray:
    """``points @ m.T`` for points (N, k) and a matrix (r, k): each row's product with ``m``, summed
    over ``k`` left to right. (N, r) float64."""
    p = np.asarray(points, dtype=np.float64)
    m = np.asarray(m, dtype=np.float64)
    out = p[:, 0, None] * m[:, 0]
    for j in range(1, m.shape[1]):
        out = out + p[:, j, None] * m[:, j]
    return out


def affine_points(points, matrix) -> np.ndarray:
    """``points @ M[:3, :3].T + M[:3, 3]`` for points (N, 3) and an affine 4x4 ``M``."""
    m = np.asarray(matrix, dtype=np.float64)
    return rows_times(points, m[:3, :3]) + m[:3, 3]


def homogeneous(points, matrix) -> np.ndarray:
    """``[points, 1] @ M.T`` for points (N, 3) and a 4x4 ``M``: (N, 4) clip-style coordinates."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    m = np.asarray(matrix, dtype=np.float64)
    return rows_times(p, m[:, :3]) + m[:, 3]


def det3(m) -> float:
    """The determinant of a 3x3 matrix by the rule of Sarrus, in a fixed order."""
    m = np.asarray(m, dtype=np.float64)
    return float((m[0, 0] * (m[1, 1] * m[2, 2] - m[1, 2] * m[2, 1])
                  - m[0, 1] * (m[1, 0] * m[2, 2] - m[1, 2] * m[2, 0]))
                 + m[0, 2] * (m[1, 0] * m[2, 1] - m[1, 1] * m[2, 0]))


def inv3(m) -> np.ndarray:
    """The inverse of a 3x3 matrix: its adjugate over its determinant (exact formula, fixed order;
    accurate for the well-conditioned rotation-and-scale matrices of scene transforms)."""
    m = np.asarray(m, dtype=np.float64)
    d = det3(m)
    if d == 0.0 or not math.isfinite(d):
        raise ValueError("singular 3x3 matrix")
    adj = np.array([
        [m[1, 1] * m[2, 2] - m[1, 2] * m[2, 1], m[0, 2] * m[2, 1] - m[0, 1] * m[2, 2],
         m[0, 1] * m[1, 2] - m[0, 2] * m[1, 1]],
        [m[1, 2] * m[2, 0] - m[1, 0] * m[2, 2], m[0, 0] * m[2, 2] - m[0, 2] * m[2, 0],
         m[0, 2] * m[1, 0] - m[0, 0] * m[1, 2]],
        [m[1, 0] * m[2, 1] - m[1, 1] * m[2, 0], m[0, 1] * m[2, 0] - m[0, 0] * m[2, 1],
         m[0, 0] * m[1, 1] - m[0, 1] * m[1, 0]],
    ])
    return adj / d


def inv_affine(matrix) -> np.ndarray:
    """The inverse of an affine 4x4 matrix ``[R t; 0 1]``: ``[R^-1, -R^-1 t; 0 1]``."""
    m = np.asarray(matrix, dtype=np.float64)
    out = np.eye(4)
    r = inv3(m[:3, :3])
    out[:3, :3] = r
    out[:3, 3] = -matvec(r, m[:3, 3])
    return out


def inv(matrix) -> np.ndarray:
    """The inverse of a small square matrix (a 4x4 view-projection) by Gauss-Jordan elimination
    with partial pivoting, in Python floats: the same operations in the same order on every
    machine (LAPACK's ``getri`` behind ``np.linalg.inv`` runs a CPU-specific kernel)."""
    a = [[float(x) for x in row] for row in np.asarray(matrix, dtype=np.float64)]
    n = len(a)
    if any(len(row) != n for row in a):
        raise ValueError("inv needs a square matrix")
    out = [[1.0 if i == j else 0.0 for j in range(n)] for i in range(n)]
    for col in range(n):
        pivot = max(range(col, n), key=lambda r: abs(a[r][col]))  # first of equal magnitudes
        if a[pivot][col] == 0.0 or not math.isfinite(a[pivot][col]):
            raise ValueError("singular matrix")
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
    return np.array(out)
