"""The truth's primary rays as one kernel (float64, parallel over pixels): per reflector pixel the
eye ray through the pixel centre (:meth:`refsoft.scene.camera.Camera.rays`), its hit on the
pixel's visible triangle (Moller-Trumbore, :func:`refsoft.raster.rays.ray_triangle`), the
normal interpolated there and renormalised, and the reflected direction. The NumPy versions are
the references it is tested against (``tests/truth/test_truth.py``)."""

import numpy as np

from .._numba import kernel


@kernel(inline=True)
def _unproject(inv, x, y, z):
    """``inv @ (x, y, z, 1)`` divided by its w."""
    w = ((inv[3, 0] * x + inv[3, 1] * y) + inv[3, 2] * z) + inv[3, 3]
    px = (((inv[0, 0] * x + inv[0, 1] * y) + inv[0, 2] * z) + inv[0, 3]) / w
    py = (((inv[1, 0] * x + inv[1, 1] * y) + inv[1, 2] * z) + inv[1, 3]) / w
    pz = (((inv[2, 0] * x + inv[2, 1] * y) + inv[2, 2] * z) + inv[2, 3]) / w
    return px, py, pz


@kernel
def primary_rays(lo, hi, rows, cols, width, height, inv, eye, perspective, vertices, normals, faces, tri, hit, ray,
                 ok):
    """For pixel ``i`` in ``lo .. hi - 1`` at (rows[i], cols[i]) with visible triangle ``tri[i]``
    (run over every pixel by :func:`refsoft._parallel.parallel_range`): ``hit[i]`` the ray's
    point on that triangle's plane, ``ray[i]`` the direction reflected about the interpolated
    normal, ``ok[i]`` False where the ray is parallel to the plane (then hit is the ray's origin
    and ray its direction)."""
    for i in range(lo, hi):
        hx, hy, hz, rx, ry, rz, good = _pixel_ray(rows[i], cols[i], tri[i], width, height, inv, eye, perspective,
                                                  vertices, normals, faces)
        hit[i, 0], hit[i, 1], hit[i, 2] = hx, hy, hz
        ray[i, 0], ray[i, 1], ray[i, 2] = rx, ry, rz
        ok[i] = good


@kernel
def box_rays(lo, hi, r0, c0, stencil, triangle, width, height, inv, eye, perspective, vertices, normals, faces,
             valid, origin, direction, camera):
    """:func:`primary_rays` of every ``stencil`` (h, w) pixel of box rows ``lo .. hi - 1`` (view
    rows ``r0 + r``, columns ``c0 + c``; ``triangle`` (h, w) their visible triangles), written in
    place: ``origin``, ``direction`` (h, w, 3) float64 and ``valid`` (h, w) bool (``ok``); zeros
    and False at the other pixels. The same arithmetic: each row's eye rays first
    (:func:`camera_rays`, a loop that vectorizes), into ``camera`` (6, w) float64 (work)."""
    w = stencil.shape[1]
    for r in range(lo, hi):
        for c in range(w):
            valid[r, c] = False
            for k in range(3):
                origin[r, c, k] = 0.0
                direction[r, c, k] = 0.0
        first, last = w, 0
        for c in range(w):
            if stencil[r, c]:
                first = min(first, c)
                last = c + 1
        if first >= last:
            continue
        camera_rays(r + r0, first, last, c0, width, height, inv[0, 0], inv[0, 1], inv[0, 2], inv[0, 3], inv[1, 0],
                    inv[1, 1], inv[1, 2], inv[1, 3], inv[2, 0], inv[2, 1], inv[2, 2], inv[2, 3], inv[3, 0], inv[3, 1],
                    inv[3, 2], inv[3, 3], camera[0], camera[1], camera[2], camera[3], camera[4], camera[5])
        for c in range(first, last):
            if not stencil[r, c]:
                continue
            k = c - first
            if perspective:
                ox, oy, oz = eye[0], eye[1], eye[2]
            else:
                ox, oy, oz = camera[0, k], camera[1, k], camera[2, k]
            hx, hy, hz, rx, ry, rz, good = _reflect_at(ox, oy, oz, camera[3, k], camera[4, k], camera[5, k],
                                                       triangle[r, c], vertices, normals, faces)
            origin[r, c, 0], origin[r, c, 1], origin[r, c, 2] = hx, hy, hz
            direction[r, c, 0], direction[r, c, 1], direction[r, c, 2] = rx, ry, rz
            valid[r, c] = good


@kernel
def camera_rays(row, c_lo, c_hi, col_offset, width, height, i00, i01, i02, i03, i10, i11, i12, i13, i20, i21, i22,
                i23, i30, i31, i32, i33, NX, NY, NZ, DX, DY, DZ):
    """The eye rays through view pixels (row, c + col_offset), c in ``c_lo .. c_hi - 1``, with
    :func:`_pixel_ray`'s arithmetic (``i``: the inverse view-projection's entries): ``NX, NY, NZ``
    their near points, ``DX, DY, DZ`` their unit directions, at ``c - c_lo``. Separate arrays
    and no branch, so that the loop vectorizes (its divisions are most of a ray's work)."""
    y = (height - row - 0.5) / height * 2.0 - 1.0
    for c in range(c_lo, c_hi):
        x = (c + col_offset + 0.5) / width * 2.0 - 1.0
        wn = ((i30 * x + i31 * y) + i32 * -1.0) + i33
        nx = (((i00 * x + i01 * y) + i02 * -1.0) + i03) / wn
        ny = (((i10 * x + i11 * y) + i12 * -1.0) + i13) / wn
        nz = (((i20 * x + i21 * y) + i22 * -1.0) + i23) / wn
        wf = ((i30 * x + i31 * y) + i32 * 1.0) + i33
        dx = (((i00 * x + i01 * y) + i02 * 1.0) + i03) / wf - nx
        dy = (((i10 * x + i11 * y) + i12 * 1.0) + i13) / wf - ny
        dz = (((i20 * x + i21 * y) + i22 * 1.0) + i23) / wf - nz
        length = np.sqrt((dx * dx + dy * dy) + dz * dz)
        k = c - c_lo
        NX[k] = nx
        NY[k] = ny
        NZ[k] = nz
        DX[k] = dx / length
        DY[k] = dy / length
        DZ[k] = dz / length


@kernel(inline=True)
def _pixel_ray(row, col, t_index, width, height, inv, eye, perspective, vertices, normals, faces):
    """The eye ray through pixel (row, col), its hit on triangle ``t_index``'s plane and its
    direction reflected about the normal interpolated there: ``(hit x, y, z, ray x, y, z, ok)``
    (ok False where the ray is parallel to the plane: then hit is the ray's origin and ray its
    direction)."""
    x = (col + 0.5) / width * 2.0 - 1.0
    y = (height - row - 0.5) / height * 2.0 - 1.0
    nx_, ny_, nz_ = _unproject(inv, x, y, -1.0)
    fx, fy, fz = _unproject(inv, x, y, 1.0)
    dx, dy, dz = fx - nx_, fy - ny_, fz - nz_
    length = np.sqrt((dx * dx + dy * dy) + dz * dz)
    dx, dy, dz = dx / length, dy / length, dz / length
    if perspective:
        ox, oy, oz = eye[0], eye[1], eye[2]
    else:
        ox, oy, oz = nx_, ny_, nz_
    return _reflect_at(ox, oy, oz, dx, dy, dz, t_index, vertices, normals, faces)


@kernel(inline=True)
def _reflect_at(ox, oy, oz, dx, dy, dz, t_index, vertices, normals, faces):
    """The ray ``o + t d``'s hit on triangle ``t_index``'s plane (Moller-Trumbore) and ``d``
    reflected about the normal interpolated there: ``(hit x, y, z, ray x, y, z, ok)`` (ok False
    where the ray is parallel to the plane: then hit is ``o`` and ray ``d``)."""
    ia, ib, ic = faces[t_index, 0], faces[t_index, 1], faces[t_index, 2]
    ax, ay, az = vertices[ia, 0], vertices[ia, 1], vertices[ia, 2]
    e1x, e1y, e1z = vertices[ib, 0] - ax, vertices[ib, 1] - ay, vertices[ib, 2] - az
    e2x, e2y, e2z = vertices[ic, 0] - ax, vertices[ic, 1] - ay, vertices[ic, 2] - az
    px, py, pz = dy * e2z - dz * e2y, dz * e2x - dx * e2z, dx * e2y - dy * e2x
    det = (e1x * px + e1y * py) + e1z * pz
    if det == 0.0:
        return ox, oy, oz, dx, dy, dz, False
    inv_det = 1.0 / det
    sx, sy, sz = ox - ax, oy - ay, oz - az
    u = ((sx * px + sy * py) + sz * pz) * inv_det
    qx, qy, qz = sy * e1z - sz * e1y, sz * e1x - sx * e1z, sx * e1y - sy * e1x
    v = ((dx * qx + dy * qy) + dz * qz) * inv_det
    t = ((e2x * qx + e2y * qy) + e2z * qz) * inv_det
    good = np.isfinite(t)
    if not good:
        t = 0.0
        u = 0.0
        v = 0.0
    mx, my, mz = unit_normal(normals, ia, ib, ic, 1.0 - u - v if good else 0.0, u, v)
    k = 2.0 * ((dx * mx + dy * my) + dz * mz)
    return ox + t * dx, oy + t * dy, oz + t * dz, dx - k * mx, dy - k * my, dz - k * mz, good


@kernel(inline=True)
def unit_normal(normals, ia, ib, ic, w, u, v):
    """``w n[ia] + u n[ib] + v n[ic]`` of the vertex normals (n, 3) float64, summed left to right,
    renormalised (zero stays zero): ``(x, y, z)``."""
    x = (w * normals[ia, 0] + u * normals[ib, 0]) + v * normals[ic, 0]
    y = (w * normals[ia, 1] + u * normals[ib, 1]) + v * normals[ic, 1]
    z = (w * normals[ia, 2] + u * normals[ib, 2]) + v * normals[ic, 2]
    m = np.sqrt((x * x + y * y) + z * z)
    if m > 0.0:
        return x / m, y / m, z / m
    return 0.0, 0.0, 0.0
