"""Triangle setup kernels: vertex transform, homogeneous clipping, snapping, bounding boxes.

Output: the *clip triangles* — what is left of each input triangle after clipping against the
near plane (``z_c + w_c >= 0``) and, only where a triangle reaches that far, a guard band of
``GUARD_BAND_PIXELS`` around the viewport centre (so 64-bit edge functions cannot overflow). A
clipped polygon is fanned from its first vertex; every clip vertex carries its barycentric
coordinates with respect to the original triangle, so attributes are interpolated from the
original vertices. Intersections are always computed from the inside vertex towards the outside
one, so two triangles sharing a clipped edge get bit-identical new vertices.
"""

import numpy as np
from numba import prange

from .._numba import kernel

# Number of clip planes: near, then x <= g w, x >= -g w, y <= g w, y >= -g w.
N_PLANES = 5
MAX_POLY = 3 + N_PLANES


@kernel(parallel=True)
def transform_points(points, matrix):
    """``(matrix @ [p, 1])`` for every point, summed left to right, float64. (N, 3) -> (N, 4)."""
    n = points.shape[0]
    out = np.empty((n, 4), dtype=np.float64)
    for i in prange(n):
        x, y, z = points[i, 0], points[i, 1], points[i, 2]
        for r in range(4):
            out[i, r] = ((matrix[r, 0] * x + matrix[r, 1] * y) + matrix[r, 2] * z) + matrix[r, 3]
    return out


@kernel
def _plane_distance(c, plane, gx, gy):
    if plane == 0:
        return c[2] + c[3]
    if plane == 1:
        return gx * c[3] - c[0]
    if plane == 2:
        return gx * c[3] + c[0]
    if plane == 3:
        return gy * c[3] - c[1]
    return gy * c[3] + c[1]


@kernel
def _clip_polygon(c0, c1, c2, gx, gy, poly_c, poly_b):
    """Sutherland-Hodgman against every plane. Returns the vertex count (0 if nothing is left)."""
    tmp_c = np.empty((MAX_POLY, 4))
    tmp_b = np.empty((MAX_POLY, 3))
    for k in range(4):
        poly_c[0, k] = c0[k]
        poly_c[1, k] = c1[k]
        poly_c[2, k] = c2[k]
    for k in range(3):
        poly_b[0, k] = 0.0
        poly_b[1, k] = 0.0
        poly_b[2, k] = 0.0
    poly_b[0, 0] = 1.0
    poly_b[1, 1] = 1.0
    poly_b[2, 2] = 1.0
    n = 3
    for plane in range(N_PLANES):
        m = 0
        for i in range(n):
            j = (i + 1) % n
            di = _plane_distance(poly_c[i], plane, gx, gy)
            dj = _plane_distance(poly_c[j], plane, gx, gy)
            if di >= 0.0:
                for k in range(4):
                    tmp_c[m, k] = poly_c[i, k]
                for k in range(3):
                    tmp_b[m, k] = poly_b[i, k]
                m += 1
            if (di >= 0.0) != (dj >= 0.0):
                # from the inside vertex a towards the outside vertex b
                a, b, da, db = (i, j, di, dj) if di >= 0.0 else (j, i, dj, di)
                t = da / (da - db)
                for k in range(4):
                    tmp_c[m, k] = poly_c[a, k] + t * (poly_c[b, k] - poly_c[a, k])
                for k in range(3):
                    tmp_b[m, k] = poly_b[a, k] + t * (poly_b[b, k] - poly_b[a, k])
                m += 1
        n = m
        for i in range(n):
            for k in range(4):
                poly_c[i, k] = tmp_c[i, k]
            for k in range(3):
                poly_b[i, k] = tmp_b[i, k]
        if n < 3:
            return 0
    return n


@kernel
def _outcodes(c, gx, gy):
    """Bit p set when the vertex is outside plane p."""
    code = 0
    for p in range(N_PLANES):
        if _plane_distance(c, p, gx, gy) < 0.0:
            code |= 1 << p
    return code


@kernel(parallel=True)
def count_clip_triangles(clip, faces, gx, gy):
    """Clip triangles each input triangle produces (0 when culled by a plane), int64 (F,)."""
    nf = faces.shape[0]
    counts = np.zeros(nf, dtype=np.int64)
    for f in prange(nf):
        c0 = clip[faces[f, 0]]
        c1 = clip[faces[f, 1]]
        c2 = clip[faces[f, 2]]
        o0 = _outcodes(c0, gx, gy)
        o1 = _outcodes(c1, gx, gy)
        o2 = _outcodes(c2, gx, gy)
        if (o0 | o1 | o2) == 0:
            counts[f] = 1
        elif (o0 & o1 & o2) != 0:
            counts[f] = 0
        else:
            poly_c = np.empty((MAX_POLY, 4))
            poly_b = np.empty((MAX_POLY, 3))
            n = _clip_polygon(c0, c1, c2, gx, gy, poly_c, poly_b)
            counts[f] = n - 2 if n >= 3 else 0
    return counts


_IDENTITY = np.eye(3)


@kernel
def _snap_xy(v):
    """Window coordinate ``(v + 1) * (size / 2)`` snapped to 1/256 px, round half to even."""
    return np.int64(np.rint(v * 256.0))


@kernel
def _store_vertex(t, slot, c, b, width, height, X, Y, Z, IW, B):
    X[t, slot] = _snap_xy((c[0] / c[3] + 1.0) * (0.5 * width))
    Y[t, slot] = _snap_xy((c[1] / c[3] + 1.0) * (0.5 * height))
    Z[t, slot] = 0.5 * (c[2] / c[3]) + 0.5
    IW[t, slot] = 1.0 / c[3]
    for k in range(3):
        B[t, slot, k] = b[k]


@kernel
def _emit(t, f, c0, c1, c2, b0, b1, b2, width, height, X, Y, Z, IW, B, tri, valid, bbox, area, bias):
    """Store clip triangle ``t`` (clip vertices ``c*`` with barycentrics ``b*``), counter-clockwise."""
    _store_vertex(t, 0, c0, b0, width, height, X, Y, Z, IW, B)
    _store_vertex(t, 1, c1, b1, width, height, X, Y, Z, IW, B)
    _store_vertex(t, 2, c2, b2, width, height, X, Y, Z, IW, B)
    a2 = (X[t, 1] - X[t, 0]) * (Y[t, 2] - Y[t, 0]) - (Y[t, 1] - Y[t, 0]) * (X[t, 2] - X[t, 0])
    if a2 < 0:  # clockwise on screen: swap vertices 1 and 2 (both windings are drawn)
        a2 = -a2
        X[t, 1], X[t, 2] = X[t, 2], X[t, 1]
        Y[t, 1], Y[t, 2] = Y[t, 2], Y[t, 1]
        Z[t, 1], Z[t, 2] = Z[t, 2], Z[t, 1]
        IW[t, 1], IW[t, 2] = IW[t, 2], IW[t, 1]
        for k in range(3):
            B[t, 1, k], B[t, 2, k] = B[t, 2, k], B[t, 1, k]
    tri[t] = f
    area[t] = a2
    # Edge i runs from vertex i+1 to vertex i+2 (opposite vertex i). Inclusive (bias 0) for left
    # edges (dy < 0) and bottom edges (dy == 0, dx > 0) of a counter-clockwise triangle, y up.
    for i in range(3):
        a = (i + 1) % 3
        b = (i + 2) % 3
        dx = X[t, b] - X[t, a]
        dy = Y[t, b] - Y[t, a]
        bias[t, i] = 0 if (dy < 0 or (dy == 0 and dx > 0)) else -1
    xmin = min(X[t, 0], min(X[t, 1], X[t, 2]))
    xmax = max(X[t, 0], max(X[t, 1], X[t, 2]))
    ymin = min(Y[t, 0], min(Y[t, 1], Y[t, 2]))
    ymax = max(Y[t, 0], max(Y[t, 1], Y[t, 2]))
    # pixel centres lie at 256 k + 128: first and last k whose centre lies in [min, max]
    k0 = max(-((128 - xmin) // 256), 0)
    k1 = min((xmax - 128) // 256, width - 1)
    j0 = max(-((128 - ymin) // 256), 0)
    j1 = min((ymax - 128) // 256, height - 1)
    bbox[t, 0] = k0
    bbox[t, 1] = k1
    bbox[t, 2] = height - 1 - j1  # top row
    bbox[t, 3] = height - 1 - j0  # bottom row
    valid[t] = a2 != 0 and k0 <= k1 and j0 <= j1


@kernel(parallel=True)
def emit_clip_triangles(clip, faces, offsets, total, gx, gy, width, height):
    """Clip, snap and set up every triangle. ``offsets[f]`` is the first output slot of face f."""
    X = np.empty((total, 3), dtype=np.int64)
    Y = np.empty((total, 3), dtype=np.int64)
    Z = np.empty((total, 3), dtype=np.float64)
    IW = np.empty((total, 3), dtype=np.float64)
    B = np.empty((total, 3, 3), dtype=np.float64)
    tri = np.empty(total, dtype=np.int32)
    valid = np.empty(total, dtype=np.bool_)
    bbox = np.empty((total, 4), dtype=np.int64)
    area = np.empty(total, dtype=np.int64)
    bias = np.empty((total, 3), dtype=np.int64)
    nf = faces.shape[0]
    for f in prange(nf):
        start = offsets[f]
        count = offsets[f + 1] - start
        if count == 0:
            continue
        c0 = clip[faces[f, 0]]
        c1 = clip[faces[f, 1]]
        c2 = clip[faces[f, 2]]
        if count == 1 and (_outcodes(c0, gx, gy) | _outcodes(c1, gx, gy) | _outcodes(c2, gx, gy)) == 0:
            _emit(start, f, c0, c1, c2, _IDENTITY[0], _IDENTITY[1], _IDENTITY[2], width, height,
                  X, Y, Z, IW, B, tri, valid, bbox, area, bias)
            continue
        poly_c = np.empty((MAX_POLY, 4))
        poly_b = np.empty((MAX_POLY, 3))
        n = _clip_polygon(c0, c1, c2, gx, gy, poly_c, poly_b)
        for j in range(n - 2):
            _emit(start + j, f, poly_c[0], poly_c[j + 1], poly_c[j + 2], poly_b[0], poly_b[j + 1],
                  poly_b[j + 2], width, height, X, Y, Z, IW, B, tri, valid, bbox, area, bias)
    return X, Y, Z, IW, B, tri, valid, bbox, area, bias
