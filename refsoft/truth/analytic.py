"""Exact reflection points on a sphere (Alhazen's problem), float64 (spec section 6).

:func:`sphere_reflection_points` solves on the great-circle arc between the directions to the
eye and to the point: ``f(t) = (u + v) . T(t) = 0`` with ``u``, ``v`` the unit directions from
the arc point to the eye and to the point and ``T`` the arc's tangent. The arc is sampled to
bracket every sign change, each bracket is solved with Brent's method (the algorithm of
``scipy.optimize.brentq``, in a Numba kernel parallel over points: :mod:`._analytic`), and the
first root along the arc where both the eye and the point lie outside the tangent plane is kept.
:func:`sphere_reflection_points_quartic` is Eberly's closed form ("Computing a Point of
Reflection on a Sphere"), kept to cross-check the solver; it loses accuracy near grazing angles.

:func:`sphere_inside_reflection_points` is the concave case: the eye and the points inside the
sphere, reflected by its inner surface. The same equation is solved around the whole great circle
through the eye and the point (the roots need not lie on the short arc between their directions),
and every root is kept: up to four.
"""

from __future__ import annotations

import numpy as np

from .. import linalg
from ..errors import RefsoftError
from .._parallel import parallel_range
from ._analytic import inside_points_kernel, reflection_points_kernel
from ..constants import (ARC_SAMPLES, COLLINEAR_TOL, INSIDE_ARC_SAMPLES, MAX_SPHERE_IMAGES, MAXITER, RTOL,
                         XTOL)

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


def _circle_axes(e, d, rho):
    """Per point, orthonormal axes ``a``, ``b`` of a great circle through the directions of ``e``
    (the eye, from the centre) and of each row of ``d`` (the points), or an arbitrary one through
    ``a`` where they are collinear; and whether each row has a circle at all (not both at the
    centre, where every point of the sphere reflects)."""
    n = len(d)
    dist = np.sqrt(_dot3(d, d))
    ne = float(np.sqrt(_dot3(e, e)))
    if ne > COLLINEAR_TOL * rho:
        a = np.broadcast_to(e / ne, (n, 3)).copy()
        defined = np.ones(n, dtype=bool)
    else:  # the eye at the centre: start at the point's direction
        defined = dist > COLLINEAR_TOL * rho
        with np.errstate(divide="ignore", invalid="ignore"):
            a = np.where(defined[:, None], d / dist[:, None], 0.0)
    b = d - _dot3(d, a)[:, None] * a
    nb = np.sqrt(_dot3(b, b))
    flat = nb <= COLLINEAR_TOL * rho
    if flat.any():
        # eye, point and centre on one line: every plane through it holds reflection points;
        # the one through e_x (e_y when the line is along x) is searched
        ex = np.cross(a, [1.0, 0.0, 0.0])
        ey = np.cross(a, [0.0, 1.0, 0.0])
        alt = np.where((np.sqrt(_dot3(ex, ex)) < 1e-6)[:, None], ey, ex)
        b = np.where(flat[:, None], alt, b)
        nb = np.sqrt(_dot3(b, b))
    with np.errstate(divide="ignore", invalid="ignore"):
        b = np.where(defined[:, None], b / nb[:, None], 0.0)
    return a, b, defined, dist


def sphere_inside_reflection_points(centre, radius, eye, points, samples=INSIDE_ARC_SAMPLES):
    """Every reflection point of ``points`` seen from ``eye`` in the inside of a mirror sphere.

    The eye and the points lie inside the sphere; the mirror is its inner surface, whose normal
    points to the centre. A point has up to four reflection points (Alhazen's problem), all on the
    great circle through the eye and the point; the whole circle is sampled (``samples``
    intervals) to bracket the roots of ``(u + v) . T``, each bracket solved by Brent's method,
    and a root is kept when both the eye and the point lie in front of the inward tangent plane
    (for points strictly inside, every root). Where the eye, the point and the centre are
    collinear the reflection points form rings around that line: those in one plane through it
    (the one through ``e_x``, or ``e_y`` for a line along ``x``) are returned; with both at the
    centre every point of the sphere reflects, and none is returned.

    Parameters
    ----------
    centre : array_like, shape (3,)
    radius : float
    eye : array_like, shape (3,)
        Inside the sphere.
    points : array_like, shape (N, 3)
    samples : int
        Intervals around the circle; roots closer than ``2 pi / samples`` radians of arc can be
        missed (two images about to merge at a caustic).

    Returns
    -------
    points : ndarray, shape (N, 4, 3), float64
        The reflection points of each point in increasing angle around the circle from the eye's
        direction (from the point's direction when the eye is at the centre) towards the point's;
        NaN past ``count``.
    virtual : ndarray, shape (N, 4, 3), float64
        The virtual vertex of each: the point mirrored across the tangent plane there; NaN past
        ``count``.
    count : ndarray, shape (N,), int32
        Reflection points per point; 0 for points on or outside the sphere.
    """
    c = np.asarray(centre, dtype=np.float64).reshape(3)
    o = np.asarray(eye, dtype=np.float64).reshape(3)
    pts = np.ascontiguousarray(np.asarray(points, dtype=np.float64).reshape(-1, 3))
    if not (np.isfinite(radius) and radius > 0):
        raise RefsoftError(f"sphere radius must be positive, got {radius!r}")
    if not (np.all(np.isfinite(c)) and np.all(np.isfinite(o)) and np.all(np.isfinite(pts))):
        raise RefsoftError("sphere centre, eye and points must be finite")
    if not (isinstance(samples, (int, np.integer)) and samples >= 8):
        raise RefsoftError(f"samples must be an integer of at least 8, got {samples!r}")
    rho = float(radius)
    if np.sqrt(_dot3(o - c, o - c)) >= rho:
        raise RefsoftError("the eye must lie inside the sphere")
    n = len(pts)
    out = np.full((n, MAX_SPHERE_IMAGES, 3), np.nan)
    count = np.zeros(n, dtype=np.int32)
    a, b, defined, dist = _circle_axes(o - c, pts - c, rho)
    todo = np.flatnonzero(defined & (dist < rho)).astype(np.int64)
    if len(todo):
        parallel_range(inside_points_kernel, len(todo), np.ascontiguousarray(c), rho, np.ascontiguousarray(o), pts,
                       np.ascontiguousarray(a), np.ascontiguousarray(b), todo, int(samples), XTOL, RTOL, MAXITER,
                       out, count, work=lambda: (np.empty(samples + 1), np.empty(samples + 1)))
    nrm = (out - c) / rho
    virtual = pts[:, None, :] - 2.0 * _dot3(pts[:, None, :] - out, nrm)[..., None] * nrm
    return out, virtual, count


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
