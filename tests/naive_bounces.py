"""Slow, plainly correct reference for the truth's mirror paths (spec section 5.1): a brute-force
ray tracer in NumPy (float64), every ray against every triangle of the scene, one ray at a time.

A path starts where the eye ray meets the reflector's visible triangle (as the truth does, the
triangle the main view rasterized there), reflects about the normal interpolated there, and goes
on: while fewer than ``bounces`` reflections were taken it may meet any reflector but the one it
leaves (that one too when it is in ``sees_itself``, but never the triangle it leaves, and only
beyond ``offset``), and reflects again about the interpolated normal at the hit; the ray leaving
the last reflection allowed meets non-reflectors only.
"""

from __future__ import annotations

import numpy as np

from naive_several import reflected_rays


def _unit(x):
    return x / np.linalg.norm(x)


def ray_all_triangles(o, d, tris):
    """Moller-Trumbore of one ray against every triangle (T, 3, 3): t and barycentrics (u, v),
    and whether the ray meets the triangle (inside, edges included, t > 0)."""
    a, b, c = tris[:, 0], tris[:, 1], tris[:, 2]
    e1, e2 = b - a, c - a
    p = np.cross(d, e2)
    det = np.sum(e1 * p, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = o - a
        u = np.sum(s * p, axis=1) / det
        q = np.cross(s, e1)
        v = (q @ d) / det
        t = np.sum(e2 * q, axis=1) / det
    inside = (det != 0) & (t > 0) & (u >= 0) & (v >= 0) & (u + v <= 1)
    return t, u, v, inside


def trace_paths(scene, meshes, camera, view, bounces, sees_itself=(), offset=0.0):
    """The truth's per-pixel answer, traced by brute force.

    Parameters
    ----------
    scene : Scene
    meshes : list of Mesh
        World meshes (object ``k`` is ``meshes[k - 1]``).
    camera : Camera
    view : ColorPass
        The main view (``object_id``, ``triangle``).
    bounces : int
    sees_itself : set of int
        Reflectors a ray leaving them may meet again.
    offset : float
        Hits on the reflector a ray leaves must lie further than this along the (unit) ray.

    Returns
    -------
    reflected_id : ndarray (H, W) int32
        The non-reflector each path ends on (0 none) at reflector pixels, -1 elsewhere.
    bounce_depth : ndarray (H, W) int8
        Reflections taken, 0 off the reflectors.
    reflected_hit : ndarray (H, W, 3) float64
        Where the path ends on a non-reflector (zero elsewhere).
    """
    tris = np.concatenate([m.vertices[m.faces] for m in meshes])
    normals = np.concatenate([m.normals[m.faces] for m in meshes])
    owner = np.concatenate([np.full(m.n_faces, k, np.int64) for k, m in enumerate(meshes, start=1)])
    first = np.cumsum([0] + [m.n_faces for m in meshes])
    mirror = np.array([False] + [o.reflector for o in scene.objects])
    H, W = view.object_id.shape
    rid = np.full((H, W), -1, np.int32)
    depth = np.zeros((H, W), np.int8)
    hits = np.zeros((H, W, 3))
    for k in scene.reflector_ids:
        stencil = view.object_id == k
        rid[stencil] = 0
        rows, cols, origins, dirs = reflected_rays(camera, stencil, meshes[k - 1], view.triangle)
        for r, c, o, d in zip(rows, cols, origins, dirs):
            src, src_tri, taken = k, first[k - 1] + view.triangle[r, c], 1
            while True:
                t, u, v, inside = ray_all_triangles(o, d, tris)
                allowed = ~mirror[owner]
                if taken < bounces:
                    allowed |= mirror[owner] & (owner != src)
                    if src in sees_itself:
                        own = (owner == src) & (np.arange(len(tris)) != src_tri) & (t * np.linalg.norm(d) > offset)
                        allowed |= own
                ok = np.flatnonzero(inside & allowed)
                if not len(ok):
                    break
                i = ok[np.argmin(t[ok])]
                p = o + t[i] * d
                if not mirror[owner[i]]:
                    rid[r, c], hits[r, c] = owner[i], p
                    break
                n = _unit((1 - u[i] - v[i]) * normals[i, 0] + u[i] * normals[i, 1] + v[i] * normals[i, 2])
                o, d = p, d - 2 * np.dot(d, n) * n
                src, src_tri, taken = owner[i], i, taken + 1
            depth[r, c] = taken
    return rid, depth, hits



def faces_met(verts, faces, edge, origin, direction, length=None):
    """(T,) bool: the faces each of whose corners lies within the face's longest edge (and 1e-9
    of it) of one of the rays (origin (P, 3), direction (P, 3), the part ahead of the origin, up
    to ``length`` (P,) when given): every face a ray meets (within its length) is among them. One
    ray and one corner at a time."""
    out = np.zeros(len(faces), bool)
    length = np.full(len(origin), np.inf) if length is None else length
    for i, (face, e) in enumerate(zip(faces, edge)):
        ok = True
        for c in face:
            best = np.inf
            for o, d, L in zip(origin, direction, length):
                u = _unit(d)
                t = min(max(float(np.dot(verts[c] - o, u)), 0.0), L)
                best = min(best, float(np.linalg.norm(verts[c] - o - t * u)))
            ok &= best <= e * (1.0 + 1e-9)
        out[i] = ok
    return out


def best_starts(samples, rel, own=None, has=None):
    """Per vertex (n, 3) the sample (K, 9: P, N, U) of highest float64 score, the first among
    equals: the halfway vector of the eye direction U and the normalized direction to the vertex,
    normalized, dotted with N. All vertices and samples at once in NumPy. With ``own`` (n, 9)
    and ``has`` (n,) bool: K where a vertex's own sample scores higher than every one. (n,) int64."""
    def scores(g, v):
        d = v[:, None, :] - g[..., 0:3]
        b = d / np.maximum(np.linalg.norm(d, axis=-1, keepdims=True), 1e-300)
        hv = g[..., 6:9] + b
        hv /= np.maximum(np.linalg.norm(hv, axis=-1, keepdims=True), 1e-300)
        return np.sum(hv * g[..., 3:6], axis=-1)

    v = rel.astype(np.float64)
    s = scores(samples.astype(np.float64)[None], v)
    best = np.argmax(s, axis=1)
    if own is not None:
        mine = scores(own.astype(np.float64)[:, None, :], v)[:, 0]
        best[has & (mine > s.max(axis=1))] = len(samples)
    return best
