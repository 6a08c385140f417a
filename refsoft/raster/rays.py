"""Eye rays through pixels and their reflections off a reflector's visible triangles (float64).

The truth (:mod:`refsoft.truth.raytrace`) traces these rays; the drawing of every image
(:mod:`refsoft.search.several`) accepts pixels with them, so both use the same rays.
"""

from __future__ import annotations

import numpy as np

from .. import linalg


def ray_triangle(origins, directions, a, b, c):
    """Intersect rays with the planes of triangles (Moller-Trumbore, float64).

    Parameters
    ----------
    origins, directions : ndarray, shape (N, 3)
    a, b, c : ndarray, shape (N, 3)
        Triangle corners, one triangle per ray.

    Returns
    -------
    t : ndarray, shape (N,)
        Ray parameter of the hit (``origin + t * direction``); NaN where the ray is parallel.
    bary : ndarray, shape (N, 3)
        Barycentrics of the hit w.r.t. (a, b, c) (they may leave [0, 1] by rounding at edges).
    """
    e1 = b - a
    e2 = c - a
    p = np.cross(directions, e2)
    det = np.sum(e1 * p, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = np.where(det != 0.0, 1.0 / det, np.nan)
        s = origins - a
        u = np.sum(s * p, axis=1) * inv
        q = np.cross(s, e1)
        v = np.sum(directions * q, axis=1) * inv
        t = np.sum(e2 * q, axis=1) * inv
    return t, np.stack([1.0 - u - v, u, v], axis=1)


def primary_rays(camera, mesh, rows, cols, tri):
    """The eye rays through pixels (rows, cols), their hits on the pixels' visible triangles
    ``tri`` of ``mesh`` and their directions reflected about the interpolated normals there
    (:mod:`refsoft.raster._rays`).

    Returns
    -------
    hit, ray : ndarray (P, 3) float64
    ok : ndarray (P,) bool
        False where a ray is parallel to its triangle's plane.
    """
    from .._parallel import parallel_range
    from ._rays import primary_rays as kernel

    n = len(rows)
    hit, ray, ok = np.empty((n, 3)), np.empty((n, 3)), np.empty(n, dtype=bool)
    parallel_range(kernel, n, np.asarray(rows, np.int64), np.asarray(cols, np.int64), float(camera.width),
                   float(camera.height), np.ascontiguousarray(linalg.inv(camera.view_proj())),
                   np.asarray(camera.eye, np.float64), camera.projection == "perspective",
                   np.ascontiguousarray(mesh.vertices, np.float64), np.ascontiguousarray(mesh.normals, np.float64),
                   np.ascontiguousarray(mesh.faces, np.int64), np.asarray(tri, np.int64), hit, ray, ok)
    return hit, ray, ok


def box_rays(camera, mesh, triangle, stencil, box, out=None):
    """:func:`primary_rays` of every ``stencil`` pixel of ``box`` (r0, r1, c0, c1), written into
    box-shaped arrays (kernel ``_rays.box_rays``, the same arithmetic, each row's eye rays in one
    vectorized loop).

    Parameters
    ----------
    camera : Camera
    mesh : Mesh
        The reflector's world mesh.
    triangle : (H, W) int
        The visible triangle of ``mesh`` per view pixel.
    stencil : (H, W) bool
    box : (r0, r1, c0, c1)
    out : tuple, optional
        ``(valid, origin, direction)`` arrays of the shapes and dtypes below to write into (any
        contents), instead of new ones.

    Returns
    -------
    valid : (h, w) bool
        Stencil pixels whose ray is not parallel to its triangle's plane.
    origin, direction : (h, w, 3) float64
        Each stencil pixel's hit and reflected direction (zeros off the stencil).
    """
    from .._parallel import parallel_range
    from ._rays import box_rays as kernel

    r0, r1, c0, c1 = (int(x) for x in box)
    h, w = r1 - r0, c1 - c0
    if out is None:
        out = np.empty((h, w), bool), np.empty((h, w, 3)), np.empty((h, w, 3))
    valid, origin, direction = out
    parallel_range(kernel, h, r0, c0, np.ascontiguousarray(stencil[r0:r1, c0:c1], bool),
                   np.ascontiguousarray(triangle[r0:r1, c0:c1], np.int64), float(camera.width), float(camera.height),
                   np.ascontiguousarray(linalg.inv(camera.view_proj())), np.asarray(camera.eye, np.float64),
                   camera.projection == "perspective", np.ascontiguousarray(mesh.vertices, np.float64),
                   np.ascontiguousarray(mesh.normals, np.float64), np.ascontiguousarray(mesh.faces, np.int64), valid,
                   origin, direction, work=lambda: (np.empty((6, max(w, 1))),))
    return valid, origin, direction
