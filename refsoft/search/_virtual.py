"""Kernels of the unfolded virtual vertex (``virtual="unfold"``, see
:func:`refsoft.search.virtual_vertices`): V' on the eye's ray through the reflection point, at the
length of the reflected path.

For an exact reflection point R, mirroring V across R's tangent plane and unfolding the path
O -> R -> V onto the ray O -> R give the same point. For a reflection point quantised to a texel
they differ: the mirror moves V' by about ``2 |V - R|`` times the texel's normal error (large for
distant vertices, and near the silhouette, where one texel spans a wide range of normals), while
the unfolded V' always projects onto R itself, with the depth of the path length.
"""

import numpy as np
from numba import prange

from .._numba import kernel, like
from ._kernels import CULLED, HIDDEN, _normalize, _virtual_one


@kernel(inline=True)
def unfold_one(vx, vy, vz, px, py, pz, nx, ny, nz, ex, ey, ez, fl, mode, fp):
    """One vertex relative to the G-buffer's origin: ``P + normalize(P - O) |V - P|`` where the
    reflection is visible; the hidden-vertex rule ``mode`` (as :func:`_kernels._virtual_one`)
    where HIDDEN; V where CULLED."""
    if (fl & CULLED) or (fl & HIDDEN):
        return _virtual_one(vx, vy, vz, px, py, pz, nx, ny, nz, fl, mode, fp)
    dx, dy, dz = vx - px, vy - py, vz - pz
    length = np.sqrt((dx * dx + dy * dy) + dz * dz)
    ux, uy, uz = _normalize(px - ex, py - ey, pz - ez, fp)
    return px + ux * length, py + uy * length, pz + uz * length


@kernel(parallel=True)
def unfold_from_texels(P, N, pixel, vertices, origin, eye, flags, mode, fp, out):
    """Unfolded virtual vertices from each vertex's reflection texel (``vertices`` world
    float64, made relative to ``origin`` and rounded to the working precision here; ``eye``
    relative, working precision)."""
    for i in prange(vertices.shape[0]):
        vx = like(vertices[i, 0] - origin[0], fp)
        vy = like(vertices[i, 1] - origin[1], fp)
        vz = like(vertices[i, 2] - origin[2], fp)
        r = pixel[i, 0] if pixel[i, 0] >= 0 else 0
        c = pixel[i, 1] if pixel[i, 1] >= 0 else 0
        x, y, z = unfold_one(vx, vy, vz, P[r, c, 0], P[r, c, 1], P[r, c, 2], N[r, c, 0], N[r, c, 1], N[r, c, 2],
                             eye[0], eye[1], eye[2], flags[i], mode, fp)
        out[i, 0] = x
        out[i, 1] = y
        out[i, 2] = z


@kernel(parallel=True)
def unfold_from_points(p, n, vertices, origin, eye, flags, mode, fp, out):
    """Unfolded virtual vertices from per-vertex surface points ``p`` and normals ``n``
    (relative to ``origin``)."""
    for i in prange(vertices.shape[0]):
        vx = like(vertices[i, 0] - origin[0], fp)
        vy = like(vertices[i, 1] - origin[1], fp)
        vz = like(vertices[i, 2] - origin[2], fp)
        x, y, z = unfold_one(vx, vy, vz, p[i, 0], p[i, 1], p[i, 2], n[i, 0], n[i, 1], n[i, 2], eye[0], eye[1],
                             eye[2], flags[i], mode, fp)
        out[i, 0] = x
        out[i, 1] = y
        out[i, 2] = z
