"""Exact reflection points on a sphere (Alhazen's problem), float64 (DESIGN section 6).

:func:`sphere_reflection_points` solves on the great-circle arc between the directions to the
eye and to the point: ``f(t) = (u + v) . T(t) = 0`` with ``u``, ``v`` the unit directions from
the arc point to the eye and to the point and ``T`` the arc's tangent. The arc is sampled to
bracket every sign change, each bracket is solved with Brent's method (``scipy.optimize.brentq``),
and the root where both the eye and the point lie outside the tangent plane is kept.
:func:`sphere_reflection_points_quartic` is Eberly's closed form ("Computing a Point of
Reflection on a Sphere"), kept to cross-check the solver; it loses accuracy near grazing angles.
"""

from __future__ import annotations

import numpy as np

from ..errors import RefsoftError

#: Samples along the arc used to bracket the roots.
ARC_SAMPLES = 64


def _inputs(centre, radius, eye, points):
    c = np.asarray(centre, dtype=np.float64).reshape(3)
    o = np.asarray(eye, dtype=np.float64).reshape(3)
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if not (np.isfinite(radius) and radius > 0):
        raise RefsoftError(f"sphere radius must be positive, got {radius!r}")
    if not (np.all(np.isfinite(c)) and np.all(np.isfinite(o)) and np.all(np.isfinite(p))):
        raise RefsoftError("sphere centre, eye and points must be finite")
    if np.linalg.norm(o - c) <= radius:
        raise RefsoftError("the eye must lie outside the sphere")
    return c, float(radius), o, p


def _arc(eye_dir, point_dir):
    """Orthonormal (a, b) spanning the arc from eye_dir towards point_dir, and its angle."""
    a = eye_dir
    b = point_dir - (point_dir @ a) * a
    nb = np.linalg.norm(b)
    phi = float(np.arccos(np.clip(point_dir @ a, -1.0, 1.0)))
    if nb < 1e-15:
        b = np.cross(a, [1.0, 0.0, 0.0])
        if np.linalg.norm(b) < 1e-6:
            b = np.cross(a, [0.0, 1.0, 0.0])
        b /= np.linalg.norm(b)
    else:
        b = b / nb
    return a, b, phi


def sphere_reflection_points(centre, radius, eye, points) -> np.ndarray:
    """Exact reflection points of ``points`` seen from ``eye`` in a mirror sphere.

    Parameters
    ----------
    centre : array_like, shape (3,)
    radius : float
    eye : array_like, shape (3,)
        Outside the sphere.
    points : array_like, shape (N, 3)

    Returns
    -------
    ndarray, shape (N, 3), float64
        The reflection point of each point; NaN where there is none (the point is inside the
        sphere or behind it, hidden from every visible point of the surface).
    """
    from scipy.optimize import brentq

    c, rho, o, pts = _inputs(centre, radius, eye, points)
    out = np.full((len(pts), 3), np.nan)
    eye_dir = (o - c) / np.linalg.norm(o - c)
    outside = np.flatnonzero(np.linalg.norm(pts - c, axis=1) > rho)
    if len(outside) == 0:
        return out
    arcs = [_arc(eye_dir, (pts[i] - c) / np.linalg.norm(pts[i] - c)) for i in outside]
    A = np.array([a for a, _, _ in arcs])
    B = np.array([b for _, b, _ in arcs])
    phi = np.array([p for _, _, p in arcs])
    # bracket the roots of every point at once: f on ARC_SAMPLES + 1 samples of each arc
    ts = phi[:, None] * np.linspace(0.0, 1.0, ARC_SAMPLES + 1)[None, :]
    fs = _arc_function(ts[..., None], A[:, None], B[:, None], c, rho, o, pts[outside][:, None])
    for j, i in enumerate(outside):
        a, b, v = A[j], B[j], pts[i]

        def f(t):
            return float(_arc_function(t, a, b, c, rho, o, v))

        candidates = [ts[j, k] if fs[j, k] == 0.0 else (ts[j, k], ts[j, k + 1])
                      for k in range(ARC_SAMPLES) if fs[j, k] == 0.0 or fs[j, k] * fs[j, k + 1] < 0.0]
        if fs[j, -1] == 0.0 and phi[j] > 0:
            candidates.append(ts[j, -1])
        for cand in candidates:
            t = cand if np.isscalar(cand) else brentq(f, cand[0], cand[1], xtol=1e-15,
                                                       rtol=4 * np.finfo(float).eps, maxiter=200)
            n = np.cos(t) * a + np.sin(t) * b
            r = c + rho * n
            if (o - r) @ n > 0.0 and (v - r) @ n > 0.0:
                out[i] = r
                break
    return out


def _arc_function(t, a, b, c, rho, o, v):
    """``(u + v) . T`` at arc angle ``t`` (broadcasting over leading axes; last axis xyz)."""
    n = np.cos(t) * a + np.sin(t) * b
    r = c + rho * n
    u = o - r
    w = v - r
    s = u / np.linalg.norm(u, axis=-1, keepdims=True) + w / np.linalg.norm(w, axis=-1, keepdims=True)
    return np.sum(s * (-np.sin(t) * a + np.cos(t) * b), axis=-1)


def fit_sphere(vertices, rtol=1e-9):
    """The sphere all ``vertices`` lie on, if there is one (icosphere and uv-sphere meshes).

    Parameters
    ----------
    vertices : array_like, shape (N, 3)
    rtol : float
        Largest accepted ``| |x - c| - r |`` relative to ``r``.

    Returns
    -------
    (centre (3,) float64, radius float) or None
    """
    x = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    if len(x) < 4:
        return None
    shift = x.mean(axis=0)
    y = x - shift
    # |y|^2 = 2 c.y + k  (k = r^2 - |c|^2): linear least squares in (c, k)
    lhs = np.c_[2.0 * y, np.ones(len(y))]
    sol, *_ = np.linalg.lstsq(lhs, np.sum(y * y, axis=1), rcond=None)
    centre = sol[:3]
    r2 = sol[3] + centre @ centre
    if not np.isfinite(r2) or r2 <= 0:
        return None
    radius = float(np.sqrt(r2))
    dev = np.abs(np.linalg.norm(y - centre, axis=1) - radius)
    if dev.max() > rtol * radius:
        return None
    return centre + shift, radius


def sphere_reflection_points_quartic(centre, radius, eye, points) -> np.ndarray:
    """Eberly's quartic: with the sphere scaled to the unit sphere at the origin, ``Y = x E + y P``
    where ``y`` solves ``4c(ac-b^2) y^4 - 4(ac-b^2) y^3 + (a+2b+c-4ac) y^2 + 2(a-b) y + a - 1 = 0``
    (``a = E.E, b = E.P, c = P.P``) and ``x = (-2c y^2 + y + 1) / (2b y + 1)``. The valid root has
    both E and P outside the tangent plane and a unit Y. NaN where none is found."""
    c0, rho, o, pts = _inputs(centre, radius, eye, points)
    E = (o - c0) / rho
    out = np.full((len(pts), 3), np.nan)
    for i, v in enumerate(pts):
        P = (v - c0) / rho
        a, b, c = E @ E, E @ P, P @ P
        if c <= 1.0:
            continue
        d = a * c - b * b
        best, best_err = None, np.inf
        for y in np.roots([4 * c * d, -4 * d, a + 2 * b + c - 4 * a * c, 2 * (a - b), a - 1]):
            if abs(y.imag) > 1e-9:
                continue
            y = y.real
            den = 2 * b * y + 1
            if den == 0:
                continue
            x = (-2 * c * y * y + y + 1) / den
            Y = x * E + y * P
            err = abs(Y @ Y - 1.0)
            if (E - Y) @ Y > 0 and (P - Y) @ Y > 0 and err < 1e-6 and err < best_err:
                best, best_err = Y / np.linalg.norm(Y), err
        if best is not None:
            out[i] = c0 + rho * best
    return out


def reflection_residual(centre, eye, points, reflection_points) -> np.ndarray:
    """Angle (radians) between the sphere normal at each reflection point and the bisector of
    the directions to the eye and to the point: zero for an exact reflection point."""
    c = np.asarray(centre, dtype=np.float64)
    r = np.asarray(reflection_points, dtype=np.float64)
    n = r - c
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    u = np.asarray(eye, dtype=np.float64) - r
    w = np.asarray(points, dtype=np.float64) - r
    h = u / np.linalg.norm(u, axis=1, keepdims=True) + w / np.linalg.norm(w, axis=1, keepdims=True)
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    # atan2(|h x n|, h . n): accurate for tiny angles, where arccos(h . n) is not
    return np.arctan2(np.linalg.norm(np.cross(h, n), axis=1), np.sum(h * n, axis=1))
