"""Reflection regions (docs/ldt.md, "Reflection regions"): which reflector triangles can show an
object, by the paper's cone test, in float64 world space.

A triangle's plane (unit normal ``n = normalize((P1 - P2) x (P3 - P2))``, ``e = -n . P1``)
mirrors the object's bounding sphere (centre O, radius rho) to ``O_v = O - 2 (n . O + e) n``.
The cone is the infinite single nappe with apex the eye C, axis ``g = (O_v - C) / |O_v - C|`` and
``cos^2(theta) = 1 - rho^2 / |O_v - C|^2``; a point X is inside when, with ``v = X - C``,
``g . v > 0`` and ``(g . v)^2 >= cos^2(theta) |v|^2``. The triangle passes when (1) a corner is
inside, (2) an edge ``v(w) = v0 + w d``, w in [0, 1], meets the cone's surface with
``g . v(w) >= 0``, or (3) the axis ray from C along g hits the triangle (the ellipse inside it).
It also passes when C lies inside the virtual sphere (``|O_v - C| <= rho``), and a degenerate
triangle (no plane) always passes.
"""

from __future__ import annotations

import numpy as np

from ..scene.mesh import Mesh
from . import constants as C


def bounding_sphere(world_mesh: Mesh, centre) -> float:
    """Radius of the sphere around ``centre`` (3,) holding every vertex of ``world_mesh``: the
    farthest vertex's distance times :data:`~refsoft.ldt.constants.SPHERE_GROWTH`."""
    d = np.linalg.norm(world_mesh.vertices - np.asarray(centre, np.float64), axis=1)
    return float(d.max()) * C.SPHERE_GROWTH


def _dot(a, b):
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def cone_cases(corners, eye, centres, radii) -> np.ndarray:
    """The cone test's three cases for every (triangle, object).

    Parameters
    ----------
    corners : ndarray (T, 3, 3) float64
        World corners P1, P2, P3 of each triangle.
    eye : ndarray (3,)
    centres : ndarray (K, 3), radii : ndarray (K,)
        The objects' bounding spheres (world).

    Returns
    -------
    ndarray (T, K, 4) bool
        (1) a corner inside, (2) an edge meets the cone, (3) the axis hits the triangle, and
        (0 of the paper's) the trivial passes: no plane, or the eye inside the virtual sphere.
    """
    P = np.asarray(corners, np.float64)[:, None]          # (T, 1, 3, 3)
    Cv = np.asarray(eye, np.float64)
    O = np.asarray(centres, np.float64)[None]              # (1, K, 3)
    rho = np.asarray(radii, np.float64)[None]              # (1, K)
    T, K = len(corners), O.shape[1]
    p1, p2, p3 = P[..., 0, :], P[..., 1, :], P[..., 2, :]
    n = np.cross(p1 - p2, p3 - p2)
    length = np.sqrt(_dot(n, n))
    flat = length == 0.0
    n = n / np.where(flat, 1.0, length)[..., None]
    e = -_dot(n, p1)
    Ov = O - 2.0 * (_dot(n, O) + e)[..., None] * n         # (T, K, 3)
    w = Ov - Cv
    dist = np.sqrt(_dot(w, w))
    near = dist <= rho
    g = w / np.where(dist > 0, dist, 1.0)[..., None]
    cos2 = 1.0 - rho ** 2 / np.where(dist > 0, dist, 1.0) ** 2
    out = np.zeros((T, K, 4), dtype=bool)
    out[..., 3] = flat | near
    vs = [np.broadcast_to(p - Cv, Ov.shape) for p in (p1, p2, p3)]
    for v in vs:                                            # (1) corners
        gv = _dot(g, v)
        out[..., 0] |= (gv > 0) & (gv * gv >= cos2 * _dot(v, v))
    for a, b in ((0, 1), (1, 2), (2, 0)):                   # (2) edges
        v0, d = vs[a], vs[b] - vs[a]
        gd, g0 = _dot(g, d), _dot(g, v0)
        qa = gd * gd - cos2 * _dot(d, d)
        qb = 2.0 * (g0 * gd - cos2 * _dot(v0, d))
        qc = g0 * g0 - cos2 * _dot(v0, v0)
        disc = qb * qb - 4.0 * qa * qc
        with np.errstate(divide="ignore", invalid="ignore"):
            sq = np.sqrt(np.where(disc >= 0, disc, 0.0))
            quad = qa != 0
            roots = [np.where(quad, (-qb - sq) / (2.0 * qa), np.where(qb != 0, -qc / qb, np.nan)),
                     np.where(quad, (-qb + sq) / (2.0 * qa), np.nan)]
        real = ~quad | (disc >= 0)
        for r in roots:
            ok = real & (r >= 0.0) & (r <= 1.0)
            out[..., 1] |= ok & (g0 + np.where(ok, r, 0.0) * gd >= 0.0)
    # (3) the axis ray C + s g, s >= 0, against the triangle (Moller-Trumbore, inclusive)
    e1, e2 = vs[1] - vs[0], vs[2] - vs[0]
    pv = np.cross(g, e2)
    det = _dot(e1, pv)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        s0 = -vs[0]
        u = _dot(s0, pv) * inv
        qv = np.cross(s0, e1)
        vv = _dot(g, qv) * inv
        t = _dot(e2, qv) * inv
    out[..., 2] = (det != 0) & (u >= 0) & (vv >= 0) & (u + vv <= 1) & (t >= 0)
    return out


def cone_test(corners, eye, centres, radii) -> np.ndarray:
    """(T, K) bool: triangle t can show object k (any case of :func:`cone_cases`)."""
    return cone_cases(corners, eye, centres, radii).any(axis=2)


def visible_triangles(view_triangle, stencil) -> np.ndarray:
    """The reflector triangles visible at the stencil's pixels, sorted: (n,) int64."""
    return np.unique(np.asarray(view_triangle)[stencil]).astype(np.int64)


def regions(world_mesh: Mesh, visible, eye, centres, radii) -> np.ndarray:
    """The region table of one reflector: (T, K) bool, the cone test for its ``visible``
    triangles, False for the others (they cover no pixel)."""
    table = np.zeros((world_mesh.n_faces, len(radii)), dtype=bool)
    if len(visible) and len(radii):
        corners = world_mesh.vertices[world_mesh.faces[visible]]
        table[visible] = cone_test(corners, eye, centres, radii)
    return table
