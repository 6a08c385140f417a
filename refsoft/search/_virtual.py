"""Virtual-vertex kernels (spec section 4.6; :func:`refsoft.search.virtual_vertices` is their public
face). Every vertex is relative to the G-buffer's origin, in the working precision ``fp``.

A visible reflection's V' is, by rule, mirrored across the reflection point's tangent plane
(``unfold=False``, the papers) or unfolded onto the eye's ray through the reflection point at
the length of the reflected path (``unfold=True``). For an exact reflection point R the two are
the same point; for one quantised to a texel they differ: the mirror moves V' by about
``2 |V - R|`` times the texel's normal error (large for distant vertices, and near the
silhouette, where one texel spans a wide range of normals), while the unfolded V' always
projects onto R itself, with the depth of the path length.
"""

import numpy as np

from .._numba import kernel, like
from ._kernels import CULLED, HIDDEN, _normalize


@kernel(inline=True)
def _virtual_one(vx, vy, vz, px, py, pz, nx, ny, nz, ex, ey, ez, fl, mode, unfold, fp):
    """One vertex: V where CULLED; by the hidden-vertex ``mode`` where HIDDEN (0 plane: P + N
    (2 d.N) - d, equation (1) verbatim; 1 search: V; 2 discard: the mirror); else the mirror
    ``V - 2 (d.N) N`` or, with ``unfold``, ``P + normalize(P - O) |V - P|``; the operations in
    the order ``virtual_vertices`` documents."""
    if fl & CULLED:
        return vx, vy, vz
    dx, dy, dz = vx - px, vy - py, vz - pz
    if unfold and not (fl & HIDDEN):
        length = np.sqrt((dx * dx + dy * dy) + dz * dz)
        ux, uy, uz = _normalize(px - ex, py - ey, pz - ez, fp)
        return px + ux * length, py + uy * length, pz + uz * length
    dn = (dx * nx + dy * ny) + dz * nz
    k = like(2.0, fp) * dn
    if fl & HIDDEN:
        if mode == 0:  # equation (1): P + N (2 d.N) - d
            return (px + nx * k) - dx, (py + ny * k) - dy, (pz + nz * k) - dz
        if mode == 1:
            return vx, vy, vz
    return vx - k * nx, vy - k * ny, vz - k * nz


@kernel
def virtual_from_texels(lo, hi, P, N, pixel, vertices, origin, eye, flags, mode, unfold, fp, out):
    """Virtual vertices ``lo .. hi - 1`` from each vertex's reflection texel (``vertices`` world
    float64, made relative to ``origin`` and rounded to the working precision here; ``eye``
    relative)."""
    for i in range(lo, hi):
        r = pixel[i, 0] if pixel[i, 0] >= 0 else 0
        c = pixel[i, 1] if pixel[i, 1] >= 0 else 0
        _store(out, i, vertices, origin, P[r, c, 0], P[r, c, 1], P[r, c, 2], N[r, c, 0], N[r, c, 1], N[r, c, 2], eye,
               flags[i], mode, unfold, fp)


@kernel
def virtual_from_points(lo, hi, p, n, vertices, origin, eye, flags, mode, unfold, fp, out):
    """Virtual vertices ``lo .. hi - 1`` from per-vertex surface points ``p`` and normals ``n``
    (relative)."""
    for i in range(lo, hi):
        _store(out, i, vertices, origin, p[i, 0], p[i, 1], p[i, 2], n[i, 0], n[i, 1], n[i, 2], eye, flags[i], mode,
               unfold, fp)


@kernel(inline=True)
def _store(out, i, vertices, origin, px, py, pz, nx, ny, nz, eye, fl, mode, unfold, fp):
    """Row ``i`` of ``out``: :func:`_virtual_one` of vertex ``i`` at the point (px, py, pz)."""
    vx = like(vertices[i, 0] - origin[0], fp)
    vy = like(vertices[i, 1] - origin[1], fp)
    vz = like(vertices[i, 2] - origin[2], fp)
    x, y, z = _virtual_one(vx, vy, vz, px, py, pz, nx, ny, nz, eye[0], eye[1], eye[2], fl, mode, unfold, fp)
    out[i, 0] = x
    out[i, 1] = y
    out[i, 2] = z
