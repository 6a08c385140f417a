"""Slow, plainly correct references for drawing every image on mirrors that are not convex
(spec section 4.8): every reflection point of a vertex by brute force over the G-buffer, and a
per-pixel ray tracer of what a reflector shows, in NumPy.

``enumerate_images`` takes every covered texel where the score of spec section 4.1 is a local
maximum (>= its covered neighbours among the 8), the vertex lies in front of the tangent plane and
a Newton step on the misalignment ``bisector - normal`` (central differences, one-sided at the
rim) is at most 1.5 texels long: a point where the bisector equals the normal lies within it.
"""

from __future__ import annotations

import numpy as np

from refsoft.search.images import Images

NEWTON_TEXELS = 1.5


def _unit(x):
    n = np.linalg.norm(x, axis=-1, keepdims=True)
    return np.divide(x, n, out=np.zeros_like(x), where=n > 0)


def enumerate_images(gb, eye, verts) -> Images:
    """Every image of every vertex in G-buffer ``gb`` (float64 arithmetic), sheet -1."""
    P = np.asarray(gb.position, np.float64)
    N = np.asarray(gb.normal, np.float64)
    m = np.asarray(gb.mask, bool)
    # pad by one texel: neighbours outside the buffer are uncovered
    P = np.pad(P, ((1, 1), (1, 1), (0, 0)))
    N = np.pad(N, ((1, 1), (1, 1), (0, 0)))
    mp = np.pad(m, 1)
    rr, cc = np.nonzero(mp)
    eye_rel = np.asarray(eye, np.float64) - gb.origin
    to_eye = _unit(eye_rel - P)
    offset, pixel, virtual = [0], [], []
    for v in np.asarray(verts, np.float64):
        v_rel = v - gb.origin
        bis = _unit(to_eye + _unit(v_rel - P))
        s = np.where(mp, np.sum(bis * N, axis=-1), -np.inf)  # uncovered: never above a covered texel
        g = bis - N  # zero at a reflection point
        sc = s[rr, cc]
        ok = np.sum((v_rel - P[rr, cc]) * N[rr, cc], axis=1) > 0
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                ok &= sc >= s[rr + dr, cc + dc]
        r, c = rr[ok], cc[ok]
        gx = _difference(g, mp, r, c, 0, 1)
        gy = _difference(g, mp, r, c, 1, 0)
        J = np.stack([gx, gy], axis=2)  # (K, 3, 2)
        step = np.array([np.linalg.lstsq(Jk, -gk, rcond=None)[0] for Jk, gk in zip(J, g[r, c])]).reshape(-1, 2)
        good = np.all(np.abs(step) <= NEWTON_TEXELS, axis=1)
        r, c = r[good], c[good]
        for ri, ci in zip(r, c):
            p, n = P[ri, ci], N[ri, ci]
            pixel.append((ri - 1, ci - 1))
            virtual.append(v - 2.0 * np.dot(v_rel - p, n) * n)
        offset.append(offset[-1] + len(r))
    M = len(pixel)
    return Images(np.asarray(offset, np.int64), np.asarray(pixel, np.int32).reshape(M, 2),
                  np.asarray(virtual, np.float64).reshape(M, 3), np.full(M, -1, np.int32))


def _difference(g, m, r, c, dr, dc):
    """Derivative of ``g`` per texel at (r, c) along (dr, dc): central where both neighbours are
    covered, one-sided where one is, zero where neither."""
    fwd, back = m[r + dr, c + dc], m[r - dr, c - dc]
    d = np.zeros((len(r), 3))
    both = fwd & back
    d[both] = (g[r + dr, c + dc][both] - g[r - dr, c - dc][both]) / 2
    f = fwd & ~back
    d[f] = g[r + dr, c + dc][f] - g[r, c][f]
    b = back & ~fwd
    d[b] = g[r, c][b] - g[r - dr, c - dc][b]
    return d


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
