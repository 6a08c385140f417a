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

from .._numba import kernel, readonly
from .._parallel import parallel_range
from ._threads import SERIAL_MAX_VERTICES
from ..constants import SUBPIXEL_BITS, SUBPIXEL_HALF, SUBPIXEL_ONE

# Number of clip planes: near, then x <= g w, x >= -g w, y <= g w, y >= -g w.
N_PLANES = 5
MAX_POLY = 3 + N_PLANES


def transform_points(points, matrix):
    """``(matrix @ [p, 1])`` for every point, summed left to right, float64. (N, 3) -> (N, 4).

    ``points`` (N, 3) and ``matrix`` (4, 4): C-contiguous float64 arrays, writable or not (the
    kernel sees read-only views: one specialisation)."""
    out = np.empty((len(points), 4), dtype=np.float64)
    # microseconds of work for a few thousand points: no hand-off to other threads
    parallel_range(_transform_points, len(points), readonly(points), readonly(matrix), out,
                   serial=len(points) <= SERIAL_MAX_VERTICES)
    return out


@kernel
def _transform_points(lo, hi, points, matrix, out):
    """Rows ``lo .. hi - 1`` of :func:`transform_points` into ``out`` (N, 4) float64."""
    for i in range(lo, hi):
        x, y, z = points[i, 0], points[i, 1], points[i, 2]
        for r in range(4):
            out[i, r] = ((matrix[r, 0] * x + matrix[r, 1] * y) + matrix[r, 2] * z) + matrix[r, 3]


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
def _clip_polygon(c0, c1, c2, gx, gy, poly_c, poly_b, tmp_c, tmp_b):
    """Sutherland-Hodgman against every plane. Returns the vertex count (0 if nothing is left).
    ``poly_c`` (MAX_POLY, 4), ``poly_b`` (MAX_POLY, 3): the polygon's clip coordinates and
    barycentrics, written; ``tmp_c``, ``tmp_b``: work arrays of the same shapes."""
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


@kernel
def count_clip_triangles(lo, hi, clip, faces, codes, gx, gy, counts, clipped, poly_c, poly_b, tmp_c, tmp_b):
    """Per input triangle ``f`` in ``lo .. hi - 1``: ``counts[f]``, the clip triangles it
    produces (0 when culled by a plane), and ``clipped[f]``, the same count when it was clipped,
    0 when it passes whole (int64 (F,) each). The last four: :func:`clip_work` (each triangle
    sets them afresh)."""
    for f in range(lo, hi):
        o0 = codes[faces[f, 0]]
        o1 = codes[faces[f, 1]]
        o2 = codes[faces[f, 2]]
        clipped[f] = 0
        if (o0 | o1 | o2) == 0:
            counts[f] = 1
        elif (o0 & o1 & o2) != 0:
            counts[f] = 0
        else:
            n = _clip_polygon(clip[faces[f, 0]], clip[faces[f, 1]], clip[faces[f, 2]], gx, gy, poly_c, poly_b, tmp_c,
                              tmp_b)
            counts[f] = n - 2 if n >= 3 else 0
            clipped[f] = counts[f]


@kernel
def _snap_xy(v):
    """Window coordinate ``(v + 1) * (size / 2)`` snapped to 1/256 px, round half to even."""
    return np.int32(np.rint(v * np.float64(SUBPIXEL_ONE)))


@kernel
def _window(c, width, height):
    """Window coordinates of clip vertex ``c``: snapped x, y (int64, 1/256 px), z_w, 1/w."""
    return (np.int64(_snap_xy((c[0] / c[3] + 1.0) * (0.5 * width))),
            np.int64(_snap_xy((c[1] / c[3] + 1.0) * (0.5 * height))),
            0.5 * (c[2] / c[3]) + 0.5, 1.0 / c[3])


@kernel
def vertex_setup(lo, hi, clip, gx, gy, width, height, codes, out_xy, out_zw):
    """Per vertex ``i`` in ``lo .. hi - 1``, in one pass: its outcode ``codes[i]`` (uint8 (V,),
    bit p set when it is outside clip plane p) and, for a vertex inside every plane, its window
    coordinates (others: zeros, never used): snapped ``x``, ``y`` in ``out_xy`` int32 (V, 2) and
    ``z``, ``1/w`` in ``out_zw`` float64 (V, 2), as :func:`_window` computes them (a vertex shared
    by many triangles is set up once, like a GPU's post-transform cache)."""
    for i in range(lo, hi):
        c = clip[i]
        code = _outcodes(c, gx, gy)
        codes[i] = code
        if code != 0:
            out_xy[i, 0] = 0
            out_xy[i, 1] = 0
            out_zw[i, 0] = 0.0
            out_zw[i, 1] = 0.0
            continue
        x, y, z, iw = _window(c, width, height)
        out_xy[i, 0] = x
        out_xy[i, 1] = y
        out_zw[i, 0] = z
        out_zw[i, 1] = iw


@kernel
def _emit(t, f, x0, y0, z0, w0, x1, y1, z1, w1, x2, y2, z2, w2, width, height, region, cull,
          X, Y, Z, IW, tri, valid, bbox, area, bias):
    """Store clip triangle ``t`` of input triangle ``f`` counter-clockwise on screen, with its
    doubled area, edge biases and pixel box. Returns True when vertices 1 and 2 were swapped.

    ``cull``: 0 keeps both windings; 1 keeps only clockwise triangles (snapped signed area < 0,
    y up), 2 only counter-clockwise ones (> 0); a culled triangle is stored but not valid."""
    a2 = (x1 - x0) * (y2 - y0) - (y1 - y0) * (x2 - x0)
    kept = cull == 0 or (cull == 1 and a2 < 0) or (cull == 2 and a2 > 0)
    swapped = a2 < 0
    if swapped:  # clockwise on screen: swap vertices 1 and 2 (both windings are drawn)
        a2 = -a2
        x1, y1, z1, w1, x2, y2, z2, w2 = x2, y2, z2, w2, x1, y1, z1, w1
    X[t, 0] = x0
    X[t, 1] = x1
    X[t, 2] = x2
    Y[t, 0] = y0
    Y[t, 1] = y1
    Y[t, 2] = y2
    Z[t, 0] = z0
    Z[t, 1] = z1
    Z[t, 2] = z2
    IW[t, 0] = w0
    IW[t, 1] = w1
    IW[t, 2] = w2
    tri[t] = f
    area[t] = a2
    # Edge i runs from vertex i+1 to vertex i+2 (opposite vertex i). Inclusive (bias 0) for left
    # edges (dy < 0) and bottom edges (dy == 0, dx > 0) of a counter-clockwise triangle, y up.
    bias[t, 0] = 0 if (y2 - y1 < 0 or (y2 == y1 and x2 - x1 > 0)) else -1
    bias[t, 1] = 0 if (y0 - y2 < 0 or (y0 == y2 and x0 - x2 > 0)) else -1
    bias[t, 2] = 0 if (y1 - y0 < 0 or (y1 == y0 and x1 - x0 > 0)) else -1
    xmin = min(x0, min(x1, x2))
    xmax = max(x0, max(x1, x2))
    ymin = min(y0, min(y1, y2))
    ymax = max(y0, max(y1, y2))
    # pixel centres lie at ONE k + HALF: first and last k whose centre lies in [min, max];
    # ceil(n / ONE) = (n + ONE - 1) >> BITS and floor(n / ONE) = n >> BITS (arithmetic shifts)
    k0 = max((xmin - SUBPIXEL_HALF + (SUBPIXEL_ONE - 1)) >> SUBPIXEL_BITS, 0)
    k1 = min((xmax - SUBPIXEL_HALF) >> SUBPIXEL_BITS, width - 1)
    j0 = max((ymin - SUBPIXEL_HALF + (SUBPIXEL_ONE - 1)) >> SUBPIXEL_BITS, 0)
    j1 = min((ymax - SUBPIXEL_HALF) >> SUBPIXEL_BITS, height - 1)
    # clamp to the region rasterized (rows region[0]..region[1], cols region[2]..region[3])
    top = max(height - 1 - j1, region[0])
    bottom = min(height - 1 - j0, region[1])
    k0 = max(k0, region[2])
    k1 = min(k1, region[3])
    bbox[t, 0] = k0
    bbox[t, 1] = k1
    bbox[t, 2] = top
    bbox[t, 3] = bottom
    valid[t] = kept and a2 != 0 and k0 <= k1 and top <= bottom
    return swapped


@kernel
def emit_clip_triangles(lo, hi, clip, faces, codes, win_xy, win_zw, offsets, clip_offsets, gx, gy, width, height,
                        region, cull, X, Y, Z, IW, slot, B, tri, valid, bbox, area, bias, poly_c, poly_b, tmp_c, tmp_b):
    """Clip, snap and set up the input triangles ``lo .. hi - 1``.

    ``cull`` (0 none, 1 keep clockwise, 2 keep counter-clockwise) is decided per clip triangle
    on its snapped window coordinates (:func:`_emit`): exact integer arithmetic, as GL culls.

    ``offsets[f]`` is the first output slot of face f; ``clip_offsets[f]`` the first row of the
    barycentric table ``B`` for the clip triangles of a face that was clipped. Writes the clip
    triangles: snapped ``X``, ``Y`` (T, 3) int32 (1/256 px, y up); window depth ``Z`` and ``IW``
    = 1/w (T, 3) float64; ``slot`` (T,) int32, the row of ``B`` (K, 3, 3) float64 holding the
    clip vertices' barycentrics w.r.t. the input triangle, or for an unclipped triangle -1 (identity)
    or -2 (vertices 1 and 2 swapped); ``tri`` (T,) int32 input triangle; ``valid`` (T,) bool; pixel ``bbox`` (T, 4)
    int32 (col min, col max, row min, row max), clamped to ``region`` (row min, row max, col
    min, col max, inclusive: the part of the viewport rasterized); doubled ``area`` (T,) int64 > 0 when valid;
    edge ``bias`` (T, 3) int8 (0 inclusive, -1 exclusive). ``T = offsets[-1]``, ``K =
    clip_offsets[-1]``; the rows of input triangle ``f`` are ``offsets[f] .. offsets[f + 1] - 1``
    (and ``clip_offsets[f] ..`` of ``B``): written by its own iteration only. The last four:
    :func:`clip_work` (each triangle sets them afresh).
    """
    for f in range(lo, hi):
        start = offsets[f]
        count = offsets[f + 1] - start
        if count == 0:
            continue
        if clip_offsets[f + 1] == clip_offsets[f]:  # inside every plane: no clipping
            v0, v1, v2 = faces[f, 0], faces[f, 1], faces[f, 2]
            swapped = _emit(start, np.int64(f),
                            np.int64(win_xy[v0, 0]), np.int64(win_xy[v0, 1]), win_zw[v0, 0], win_zw[v0, 1],
                            np.int64(win_xy[v1, 0]), np.int64(win_xy[v1, 1]), win_zw[v1, 0], win_zw[v1, 1],
                            np.int64(win_xy[v2, 0]), np.int64(win_xy[v2, 1]), win_zw[v2, 0], win_zw[v2, 1],
                            width, height, region, cull, X, Y, Z, IW, tri, valid, bbox, area, bias)
            slot[start] = -2 if swapped else -1
            continue
        n = _clip_polygon(clip[faces[f, 0]], clip[faces[f, 1]], clip[faces[f, 2]], gx, gy, poly_c, poly_b, tmp_c, tmp_b)
        for j in range(n - 2):
            t = start + j
            b = clip_offsets[f] + j
            x0, y0, z0, w0 = _window(poly_c[0], width, height)
            x1, y1, z1, w1 = _window(poly_c[j + 1], width, height)
            x2, y2, z2, w2 = _window(poly_c[j + 2], width, height)
            swapped = _emit(t, np.int64(f), x0, y0, z0, w0, x1, y1, z1, w1, x2, y2, z2, w2, width, height, region, cull,
                            X, Y, Z, IW, tri, valid, bbox, area, bias)
            i1, i2 = (j + 2, j + 1) if swapped else (j + 1, j + 2)
            for k in range(3):
                B[b, 0, k] = poly_b[0, k]
                B[b, 1, k] = poly_b[i1, k]
                B[b, 2, k] = poly_b[i2, k]
            slot[t] = b


def clip_work():
    """Work arrays of one part of the clipping kernels: the polygon's clip coordinates
    (MAX_POLY, 4) and barycentrics (MAX_POLY, 3) float64, and the same again for each plane's
    pass."""
    return (np.empty((MAX_POLY, 4)), np.empty((MAX_POLY, 3)), np.empty((MAX_POLY, 4)), np.empty((MAX_POLY, 3)))


def setup_region(clip, faces, width, height, r0, r1, c0, c1, cull, guard_band, small=False):
    """Every triangle clipped, snapped and set up for the region rows ``r0:r1``, columns
    ``c0:c1`` of a ``width`` x ``height`` viewport (the calls of :func:`refsoft.raster.rasterize`,
    shared with the two-fragment pass): :func:`emit_clip_triangles`'s arrays ``X, Y, Z, IW,
    slot, B, tri, valid, bbox, area, bias``. ``cull``: 0 none, 1 clockwise, 2 counter-clockwise
    kept; ``guard_band`` in pixels; ``small``: every pass on the calling thread alone
    (:func:`refsoft._parallel.parallel_range`'s ``serial``)."""
    gx, gy = 2.0 * guard_band / width, 2.0 * guard_band / height
    nv, nf = len(clip), len(faces)
    codes = np.empty(nv, dtype=np.uint8)
    win_xy = np.empty((nv, 2), dtype=np.int32)
    win_zw = np.empty((nv, 2), dtype=np.float64)
    parallel_range(vertex_setup, nv, clip, gx, gy, width, height, codes, win_xy, win_zw, serial=small)
    if not codes.any():  # every vertex inside every plane: one clip triangle per face, none clipped
        offsets = np.arange(nf + 1, dtype=np.int64)
        clip_offsets = np.zeros(nf + 1, dtype=np.int64)
    else:
        counts = np.empty(nf, dtype=np.int64)
        clipped = np.empty(nf, dtype=np.int64)
        parallel_range(count_clip_triangles, nf, clip, faces, codes, gx, gy, counts, clipped, serial=small,
                       work=clip_work)
        offsets = np.zeros(nf + 1, dtype=np.int64)
        np.cumsum(counts, out=offsets[1:])
        clip_offsets = np.zeros(nf + 1, dtype=np.int64)
        np.cumsum(clipped, out=clip_offsets[1:])
    t, k = int(offsets[-1]), int(clip_offsets[-1])
    out = (np.empty((t, 3), dtype=np.int32), np.empty((t, 3), dtype=np.int32), np.empty((t, 3), dtype=np.float64),
           np.empty((t, 3), dtype=np.float64), np.empty(t, dtype=np.int32), np.empty((k, 3, 3), dtype=np.float64),
           np.empty(t, dtype=np.int32), np.empty(t, dtype=np.bool_), np.empty((t, 4), dtype=np.int32),
           np.empty(t, dtype=np.int64), np.empty((t, 3), dtype=np.int8))
    parallel_range(emit_clip_triangles, nf, clip, faces, codes, win_xy, win_zw, offsets, clip_offsets, gx, gy, width,
                   height, np.array([r0, r1 - 1, c0, c1 - 1], dtype=np.int64), cull, *out, serial=small,
                   work=clip_work)
    return out
