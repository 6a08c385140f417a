"""Slow, plainly correct reference for drawing every image on mirrors that are not convex
(spec section 4.8): a per-pixel ray tracer of what a reflector shows, in NumPy (float64)."""

from __future__ import annotations

import numpy as np


def _unit(x):
    n = np.linalg.norm(x, axis=-1, keepdims=True)
    return np.divide(x, n, out=np.zeros_like(x), where=n > 0)


def reflected_rays(camera, stencil, reflector_mesh, triangle):
    """Per stencil pixel (row-major): the eye ray through the pixel centre meets the visible
    reflector triangle and is reflected about the interpolated normal there.

    Returns
    -------
    rows, cols : (P,) int
    origin, direction : (P, 3) float64
    """
    H, W = stencil.shape
    inv = np.linalg.inv(camera.view_proj())
    eye = np.asarray(camera.eye, np.float64)
    rows, cols, origin, direction = [], [], [], []
    for r, c in zip(*np.nonzero(stencil)):
        x = (c + 0.5) / W * 2 - 1
        y = (H - r - 0.5) / H * 2 - 1
        far = inv @ np.array([x, y, 1.0, 1.0])
        near = inv @ np.array([x, y, -1.0, 1.0])
        d = _unit(far[:3] / far[3] - near[:3] / near[3])
        f = reflector_mesh.faces[triangle[r, c]]
        a, b, cc = reflector_mesh.vertices[f]
        t, u, v = _moller(eye, d, a, b, cc)
        if not np.isfinite(t):
            continue
        n = _unit((1 - u - v) * reflector_mesh.normals[f[0]] + u * reflector_mesh.normals[f[1]]
                  + v * reflector_mesh.normals[f[2]])
        rows.append(r)
        cols.append(c)
        origin.append(eye + t * d)
        direction.append(d - 2 * np.dot(d, n) * n)
    return np.asarray(rows, int), np.asarray(cols, int), np.asarray(origin).reshape(-1, 3), \
        np.asarray(direction).reshape(-1, 3)


def first_hits(origin, direction, tris):
    """Per ray, the index of the nearest triangle of ``tris`` (T, 3, 3) hit with t > 0 (-1 none)."""
    A, B, C = tris[:, 0], tris[:, 1], tris[:, 2]
    e1, e2 = B - A, C - A
    out = np.full(len(origin), -1)
    for i, (p, rd) in enumerate(zip(origin, direction)):
        pv = np.cross(rd, e2)
        det = np.sum(e1 * pv, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            s = p - A
            uu = np.sum(s * pv, axis=1) / det
            q = np.cross(s, e1)
            vv = (q @ rd) / det
            tt = np.sum(e2 * q, axis=1) / det
        hit = (tt > 0) & (uu >= 0) & (vv >= 0) & (uu + vv <= 1)
        if hit.any():
            out[i] = np.flatnonzero(hit)[np.argmin(tt[hit])]
    return out


def trace_reflections(scene, meshes, camera, stencil, reflector_mesh, triangle):
    """What reflector pixels show: :func:`reflected_rays` intersected with every triangle of every
    non-reflector object (float64, nearest t > 0 inside the triangle).

    Returns
    -------
    reflected_id : ndarray (H, W) int32
        Object id seen, 0 none (also off the stencil).
    """
    tris, ids = [], []
    for k, obj in enumerate(scene.objects, start=1):
        if not obj.reflector:
            tris.append(meshes[k - 1].vertices[meshes[k - 1].faces])
            ids.append(np.full(meshes[k - 1].n_faces, k, np.int32))
    tris, ids = np.concatenate(tris), np.concatenate(ids)
    rows, cols, origin, direction = reflected_rays(camera, stencil, reflector_mesh, triangle)
    hit = first_hits(origin, direction, tris)
    out = np.zeros(stencil.shape, np.int32)
    out[rows, cols] = np.where(hit >= 0, ids[hit], 0)
    return out


def _moller(o, d, a, b, c):
    e1, e2 = b - a, c - a
    p = np.cross(d, e2)
    det = np.dot(e1, p)
    if det == 0:
        return np.nan, 0.0, 0.0
    s = o - a
    u = np.dot(s, p) / det
    q = np.cross(s, e1)
    return np.dot(e2, q) / det, u, np.dot(d, q) / det


def rays_near(real, origin, direction, first, last, ray, margin, parallel):
    """The rays of ``ray[first[f]:last[f]]`` not clearly off each triangle of ``real`` (F, 3, 3),
    as lists, in the arithmetic of ``refsoft.search._several.rays_near`` written out in NumPy: a
    ray is off when its Moller-Trumbore barycentrics leave [-margin, 1 + margin] or its t is below
    ``-margin * (|e1| + |e2|)``, unless it lies within ``parallel`` of the plane
    (``|det| <= parallel * (|e1| |e2|) * |d|``)."""
    out = []
    for f in range(len(real)):
        r = np.asarray(ray[first[f]:last[f]])
        p0 = real[f, 0]
        e1, e2 = real[f, 1] - p0, real[f, 2] - p0
        l1 = np.sqrt((e1[0] * e1[0] + e1[1] * e1[1]) + e1[2] * e1[2])
        l2 = np.sqrt((e2[0] * e2[0] + e2[1] * e2[1]) + e2[2] * e2[2])
        d = direction[r]
        dx, dy, dz = d[:, 0], d[:, 1], d[:, 2]
        with np.errstate(invalid="ignore", over="ignore"):  # a triangle that is not finite gives NaN
            px, py, pz = dy * e2[2] - dz * e2[1], dz * e2[0] - dx * e2[2], dx * e2[1] - dy * e2[0]
            det = (e1[0] * px + e1[1] * py) + e1[2] * pz
        ld = np.sqrt((dx * dx + dy * dy) + dz * dz)
        s = origin[r] - p0
        sx, sy, sz = s[:, 0], s[:, 1], s[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / det
            u = ((sx * px + sy * py) + sz * pz) * inv
            qx, qy, qz = sy * e1[2] - sz * e1[1], sz * e1[0] - sx * e1[2], sx * e1[1] - sy * e1[0]
            v = ((dx * qx + dy * qy) + dz * qz) * inv
            t = ((e2[0] * qx + e2[1] * qy) + e2[2] * qz) * inv
            off = (u < -margin) | (u > 1.0 + margin) | (v < -margin) | (u + v > 1.0 + margin)
            off |= t < -margin * (l1 + l2)
            off &= ~(np.abs(det) <= parallel * (l1 * l2) * ld)
        out.append(r[~off].tolist())
    return out


def screen(virtual, camera, box):
    """The candidates' screen positions (C, 3, 2), dilated bounds (C, 4) int64 and dilations (C,)
    of ``refsoft.search.acceptance._screen``, written out in NumPy over every candidate at once."""
    from refsoft import constants
    from refsoft.raster import _setup

    r0, r1, c0, c1 = box
    c = len(virtual)
    W, H = camera.width, camera.height
    clip = _setup.transform_points(virtual.reshape(-1, 3), camera.view_proj()).reshape(c, 3, 4)
    wv = clip[..., 3]
    good = np.all(wv > 0, axis=1)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        x = (clip[..., 0] / wv + 1.0) * 0.5 * W
        y = (1.0 - clip[..., 1] / wv) * 0.5 * H
        out = np.ascontiguousarray(np.stack([x, y], axis=2))
        out[~good] = 0.0
        edge = np.max(np.sqrt(np.sum((out - out[:, [1, 2, 0]]) ** 2, axis=2)), axis=1)
        dilate = constants.SEVERAL_DILATE_PIXELS + constants.SEVERAL_DILATE_FRACTION * edge
        bbox = np.empty((c, 4), np.int64)
        lo_x, hi_x = np.min(x, axis=1) - dilate, np.max(x, axis=1) + dilate
        lo_y, hi_y = np.min(y, axis=1) - dilate, np.max(y, axis=1) + dilate
        big = float(1 << 30)
        fine = good & np.isfinite(dilate) & np.all(np.isfinite(out), axis=(1, 2))
        bbox[:, 0] = np.floor(np.clip(np.where(fine, lo_y, 0) - 0.5, -big, big)).astype(np.int64) - r0
        bbox[:, 1] = np.ceil(np.clip(np.where(fine, hi_y, 0) - 0.5, -big, big)).astype(np.int64) + 1 - r0
        bbox[:, 2] = np.floor(np.clip(np.where(fine, lo_x, 0) - 0.5, -big, big)).astype(np.int64)
        bbox[:, 3] = np.ceil(np.clip(np.where(fine, hi_x, 0) - 0.5, -big, big)).astype(np.int64) + 1
    bbox[~good] = (0, r1 - r0, c0, c1)
    dilate = np.where(good & np.isfinite(dilate), dilate, -1.0)
    return out, bbox, dilate, fine | ~good
