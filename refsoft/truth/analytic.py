"""Exact reflection points on a sphere (Alhazen's problem), float64 (spec section 6).

:func:`sphere_reflection_points` solves on the great-circle arc between the directions to the
eye and to the point: ``f(t) = (u + v) . T(t) = 0`` with ``u``, ``v`` the unit directions from
the arc point to the eye and to the point and ``T`` the arc's tangent. The arc is sampled to
bracket every sign change, each bracket is solved with Brent's method (the algorithm of
``scipy.optimize.brentq``, in a Numba kernel parallel over points: :mod:`._analytic`), and the
first root along the arc where both the eye and the point lie outside the tangent plane is kept.
:func:`sphere_reflection_points_quartic` is Eberly's closed form ("Computing a Point of
Reflection on a Sphere"), kept to cross-check the solver; it loses accuracy near grazing angles.
"""

from __future__ import annotations

import numpy as np

from .. import linalg
from ..errors import RefsoftError
from .._parallel import parallel_range
from ._analytic import reflection_points_kernel
from ..constants import ARC_SAMPLES, MAXITER, RTOL, XTOL

#: Arc samples the kernel evaluates at a time (speed only).
SAMPLE_BLOCK = 8


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


def _dot3(x, y):
    """``(x0 y0 + x1 y1) + x2 y2`` over the last axis, in that order."""
    return (x[..., 0] * y[..., 0] + x[..., 1] * y[..., 1]) + x[..., 2] * y[..., 2]


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
    c, rho, o, pts = _inputs(centre, radius, eye, points)
    c, o, pts = np.ascontiguousarray(c), np.ascontiguousarray(o), np.ascontiguousarray(pts)
    out = np.full((len(pts), 3), np.nan)
    # per-point arc setup in NumPy, norms and dot products summed left to right like the kernel
    # (elementwise, not np.linalg.norm or @: those go through BLAS, whose ddot may fuse or
    # reorder the products)
    eye_dir = (o - c) / np.sqrt(_dot3(o - c, o - c))
    d = pts - c
    dist = np.sqrt(_dot3(d, d))
    todo = np.flatnonzero(dist > rho)
    if len(todo) == 0:
        return out
    with np.errstate(divide="ignore", invalid="ignore"):
        dirs = d / dist[:, None]
    cos_phi = _dot3(dirs, eye_dir)
    # NumPy's arccos, not the kernel's libm one: the two differ in the last bit for some inputs
    phi = np.arccos(np.clip(cos_phi, -1.0, 1.0))
    parallel_range(reflection_points_kernel, len(todo), c, rho, o, eye_dir, pts, dirs, cos_phi, phi,
                   todo.astype(np.int64), ARC_SAMPLES, SAMPLE_BLOCK, XTOL, RTOL, MAXITER, out)
    return out


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
    scale = float(np.sqrt(np.mean(_dot3(x - shift, x - shift))))
    if not (np.isfinite(scale) and scale > 0):
        return None
    y = (x - shift) / scale  # of size 1, so the normal equations below stay well conditioned
    # |y|^2 = 2 c.y + k  (k = r^2 - |c|^2): linear least squares in (c, k), by the normal
    # equations summed in NumPy and solved by refsoft.linalg.inv (no LAPACK: its bits depend on
    # the machine's CPU)
    lhs = np.c_[2.0 * y, np.ones(len(y))]
    rhs = _dot3(y, y)
    normal = np.array([[np.sum(lhs[:, i] * lhs[:, j]) for j in range(4)] for i in range(4)])
    try:
        sol = linalg.matvec(linalg.inv(normal), [np.sum(lhs[:, i] * rhs) for i in range(4)])
    except ValueError:  # singular: the points span no sphere
        return None
    centre = sol[:3] * scale
    r2 = (sol[3] + float(_dot3(sol[:3], sol[:3]))) * scale * scale
    if not np.isfinite(r2) or r2 <= 0:
        return None
    radius = float(np.sqrt(r2))
    dev = np.abs(np.sqrt(_dot3(x - shift - centre, x - shift - centre)) - radius)
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
