"""Numba kernel of :func:`refsoft.truth.analytic.sphere_reflection_points` (float64).

The points are split among threads (:func:`refsoft._parallel.parallel_range`), each writing only
its own output row: results do not depend on the thread count. The arithmetic follows the NumPy
formulation term by term (sums of three products left to right, no fused multiply-add; libm's
``cos``, ``sin`` and ``sqrt``, which give NumPy's float64 results, whereas its ``arccos`` may
not: the arc angle comes from NumPy), so the arc samples, their signs and the Brent iterates are the same doubles as the
SciPy-based reference solver's (``tests/naive.py``).
"""

from __future__ import annotations

import math

import numpy as np

from .._numba import kernel


@kernel
def _arc_f(t, a0, a1, a2, b0, b1, b2, c0, c1, c2, rho, o0, o1, o2, v0, v1, v2):
    """``(u + v) . T`` at arc angle ``t``: ``u``, ``v`` unit vectors from the arc point to the eye
    and to the point, ``T`` the arc's tangent."""
    ct = math.cos(t)
    st = math.sin(t)
    r0 = c0 + rho * (ct * a0 + st * b0)
    r1 = c1 + rho * (ct * a1 + st * b1)
    r2 = c2 + rho * (ct * a2 + st * b2)
    u0 = o0 - r0
    u1 = o1 - r1
    u2 = o2 - r2
    w0 = v0 - r0
    w1 = v1 - r1
    w2 = v2 - r2
    lu = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
    lw = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    s0 = u0 / lu + w0 / lw
    s1 = u1 / lu + w1 / lw
    s2 = u2 / lu + w2 / lw
    return s0 * (-st * a0 + ct * b0) + s1 * (-st * a1 + ct * b1) + s2 * (-st * a2 + ct * b2)


@kernel(inline=True)
def _circle_point(t, a0, a1, a2, b0, b1, b2, c0, c1, c2, rho):
    """The unit normal ``n = cos(t) a + sin(t) b`` on the great circle and the sphere's point
    ``c + rho n`` there."""
    ct = math.cos(t)
    st = math.sin(t)
    n0 = ct * a0 + st * b0
    n1 = ct * a1 + st * b1
    n2 = ct * a2 + st * b2
    return n0, n1, n2, c0 + rho * n0, c1 + rho * n1, c2 + rho * n2


@kernel
def _brent(lo, hi, f_lo, f_hi, xtol, rtol, maxiter, a0, a1, a2, b0, b1, b2, c0, c1, c2, rho, o0, o1, o2,
           v0, v1, v2):
    """Root of ``_arc_f`` in ``[lo, hi]`` (``f_lo``, ``f_hi`` of opposite signs, neither zero) by
    Brent's method in the form of SciPy's ``brentq``: inverse quadratic or secant steps while they
    shrink fast enough, bisection otherwise; stops when half the bracket is below
    ``(xtol + rtol |x|) / 2``."""
    prev, cur = lo, hi
    f_prev, f_cur = f_lo, f_hi
    blk = 0.0
    f_blk = 0.0
    step_prev = 0.0
    step = 0.0
    for _ in range(maxiter):
        # keep the root bracketed by [cur, blk]
        if f_prev != 0.0 and f_cur != 0.0 and (f_prev < 0.0) != (f_cur < 0.0):
            blk = prev
            f_blk = f_prev
            step = cur - prev
            step_prev = step
        # cur is the best estimate so far
        if abs(f_blk) < abs(f_cur):
            prev = cur
            cur = blk
            blk = prev
            f_prev = f_cur
            f_cur = f_blk
            f_blk = f_prev
        tol = (xtol + rtol * abs(cur)) / 2.0
        half = (blk - cur) / 2.0
        if f_cur == 0.0 or abs(half) < tol:
            return cur
        bisect = True
        if abs(step_prev) > tol and abs(f_cur) < abs(f_prev):
            if prev == blk:
                trial = -f_cur * (cur - prev) / (f_cur - f_prev)  # secant
            else:
                # inverse quadratic through (prev, cur, blk)
                d_prev = (f_prev - f_cur) / (prev - cur)
                d_blk = (f_blk - f_cur) / (blk - cur)
                trial = -f_cur * (f_blk * d_blk - f_prev * d_prev) / (d_blk * d_prev * (f_blk - f_prev))
            if 2.0 * abs(trial) < min(abs(step_prev), 3.0 * abs(half) - tol):
                step_prev = step
                step = trial
                bisect = False
        if bisect:
            step_prev = half
            step = half
        prev = cur
        f_prev = f_cur
        if abs(step) > tol:
            cur += step
        elif half > 0.0:
            cur += tol
        else:
            cur -= tol
        f_cur = _arc_f(cur, a0, a1, a2, b0, b1, b2, c0, c1, c2, rho, o0, o1, o2, v0, v1, v2)
    return cur


@kernel
def _solve_point(i, c0, c1, c2, rho, o0, o1, o2, a0, a1, a2, points, dirs, cos_phi, phi, samples, block, xtol,
                 rtol, maxiter, ts, fs, out):
    """Reflection point of ``points[i]`` into ``out[i]`` (untouched if none); ``ts``, ``fs``
    (``samples + 1``,) are scratch."""
    v0, v1, v2 = points[i, 0], points[i, 1], points[i, 2]
    # the arc's second axis: the point's direction less its component along the eye's
    cp = cos_phi[i]
    b0 = dirs[i, 0] - cp * a0
    b1 = dirs[i, 1] - cp * a1
    b2 = dirs[i, 2] - cp * a2
    nb = math.sqrt(b0 * b0 + b1 * b1 + b2 * b2)
    if nb < 1e-15:
        # the point is (anti)parallel to the eye: any great circle through the eye, a x e_x
        b0 = a1 * 0.0 - a2 * 0.0
        b1 = a2 * 1.0 - a0 * 0.0
        b2 = a0 * 0.0 - a1 * 1.0
        if math.sqrt(b0 * b0 + b1 * b1 + b2 * b2) < 1e-6:
            b0 = a1 * 0.0 - a2 * 1.0  # a x e_y
            b1 = a2 * 0.0 - a0 * 0.0
            b2 = a0 * 1.0 - a1 * 0.0
        nb = math.sqrt(b0 * b0 + b1 * b1 + b2 * b2)
    b0 /= nb
    b1 /= nb
    b2 /= nb
    ph = phi[i]
    # candidates in arc order (sampled zeros, roots of sign-change brackets), each solved as it
    # is met: the first accepted one is the answer, so samples past it are not needed. Samples
    # are evaluated ``block`` at a time, a branch-free loop the compiler vectorizes.
    done = -1  # last evaluated sample
    for k in range(samples + 1):
        if k + 1 > done and done < samples:
            hi = min(k + block, samples)
            for q in range(done + 1, hi + 1):
                ts[q] = ph * (q / samples)
                fs[q] = _arc_f(ts[q], a0, a1, a2, b0, b1, b2, c0, c1, c2, rho, o0, o1, o2, v0, v1, v2)
            done = hi
        if k < samples:
            if fs[k] == 0.0:
                t = ts[k]
            elif fs[k] * fs[k + 1] < 0.0:
                t = _brent(ts[k], ts[k + 1], fs[k], fs[k + 1], xtol, rtol, maxiter,
                           a0, a1, a2, b0, b1, b2, c0, c1, c2, rho, o0, o1, o2, v0, v1, v2)
            else:
                continue
        elif fs[k] == 0.0 and ph > 0.0:
            t = ts[k]  # a zero at the arc's end
        else:
            continue
        n0, n1, n2, r0, r1, r2 = _circle_point(t, a0, a1, a2, b0, b1, b2, c0, c1, c2, rho)
        # both the eye and the point outside the tangent plane
        if ((o0 - r0) * n0 + (o1 - r1) * n1 + (o2 - r2) * n2 > 0.0
                and (v0 - r0) * n0 + (v1 - r1) * n1 + (v2 - r2) * n2 > 0.0):
            out[i, 0] = r0
            out[i, 1] = r1
            out[i, 2] = r2
            return


@kernel
def reflection_points_kernel(lo, hi, centre, rho, eye, eye_dir, points, dirs, cos_phi, phi, todo, samples, block,
                             xtol, rtol, maxiter, out):
    """Solve Alhazen's problem for ``points[todo[lo:hi]]`` into ``out`` (rows left untouched: no
    root); run over all of ``todo`` by :func:`refsoft._parallel.parallel_range`.

    Parameters
    ----------
    lo, hi : int
        The entries of ``todo`` solved here.
    centre, eye, eye_dir : ndarray, shape (3,), float64
        Sphere centre, eye, unit direction from the centre to the eye (the arc's start).
    rho : float
        Sphere radius.
    points, dirs : ndarray, shape (N, 3), float64
        The points and their unit directions from the centre.
    cos_phi, phi : ndarray, shape (N,), float64
        ``dirs . eye_dir`` and the arc angle ``arccos(clip(cos_phi, -1, 1))``.
    todo : ndarray, shape (M,), int64
        Rows to solve (points outside the sphere).
    samples : int
        Arc intervals sampled to bracket the roots.
    block : int
        Samples evaluated at a time (speed only: the result does not depend on it).
    xtol, rtol, maxiter :
        Brent's stopping rule (``brentq``'s meaning).
    out : ndarray, shape (N, 3), float64
        Receives the reflection points.
    """
    c0, c1, c2 = centre[0], centre[1], centre[2]
    o0, o1, o2 = eye[0], eye[1], eye[2]
    a0, a1, a2 = eye_dir[0], eye_dir[1], eye_dir[2]
    ts = np.empty(samples + 1)  # work arrays, once per part
    fs = np.empty(samples + 1)
    for j in range(lo, hi):
        _solve_point(todo[j], c0, c1, c2, rho, o0, o1, o2, a0, a1, a2, points, dirs, cos_phi, phi, samples, block,
                     xtol, rtol, maxiter, ts, fs, out)


@kernel
def _inside_point(i, c0, c1, c2, rho, o0, o1, o2, points, axis_a, axis_b, samples, xtol, rtol, maxiter, ts, fs,
                  out, count):
    """Every reflection point of ``points[i]`` seen from inside into ``out[i]``, in arc order,
    their number into ``count[i]``; ``ts``, ``fs`` (``samples + 1``,) are scratch."""
    v0, v1, v2 = points[i, 0], points[i, 1], points[i, 2]
    a0, a1, a2 = axis_a[i, 0], axis_a[i, 1], axis_a[i, 2]
    b0, b1, b2 = axis_b[i, 0], axis_b[i, 1], axis_b[i, 2]
    two_pi = 2.0 * math.pi
    for q in range(samples):
        ts[q] = two_pi * (q / samples)
        fs[q] = _arc_f(ts[q], a0, a1, a2, b0, b1, b2, c0, c1, c2, rho, o0, o1, o2, v0, v1, v2)
    # the circle closes: the last interval ends where the first begins, with the same value
    ts[samples] = two_pi
    fs[samples] = fs[0]
    m = 0
    cap = out.shape[1]
    for k in range(samples):
        if fs[k] == 0.0:
            t = ts[k]
        elif fs[k] * fs[k + 1] < 0.0:
            t = _brent(ts[k], ts[k + 1], fs[k], fs[k + 1], xtol, rtol, maxiter,
                       a0, a1, a2, b0, b1, b2, c0, c1, c2, rho, o0, o1, o2, v0, v1, v2)
        else:
            continue
        n0, n1, n2, r0, r1, r2 = _circle_point(t, a0, a1, a2, b0, b1, b2, c0, c1, c2, rho)
        # both the eye and the point in front of the inward tangent plane (normal -n)
        if ((o0 - r0) * n0 + (o1 - r1) * n1 + (o2 - r2) * n2 < 0.0
                and (v0 - r0) * n0 + (v1 - r1) * n1 + (v2 - r2) * n2 < 0.0 and m < cap):
            out[i, m, 0] = r0
            out[i, m, 1] = r1
            out[i, m, 2] = r2
            m += 1
    count[i] = m


@kernel
def inside_points_kernel(lo, hi, centre, rho, eye, points, axis_a, axis_b, todo, samples, xtol, rtol, maxiter, out,
                         count, ts, fs):
    """Every reflection point of ``points[todo[lo:hi]]`` seen from inside the sphere; run over all
    of ``todo`` by :func:`refsoft._parallel.parallel_range`.

    Parameters
    ----------
    lo, hi : int
        The entries of ``todo`` solved here.
    centre, eye : ndarray, shape (3,), float64
        Sphere centre and the eye (inside the sphere).
    rho : float
        Sphere radius.
    points : ndarray, shape (N, 3), float64
        The points.
    axis_a, axis_b : ndarray, shape (N, 3), float64
        Per point, orthonormal axes of the great circle searched: ``n(t) = cos t a + sin t b``.
    todo : ndarray, shape (M,), int64
        Rows to solve (points inside the sphere with a well-defined circle).
    samples : int
        Intervals around the circle sampled to bracket the roots.
    xtol, rtol, maxiter :
        Brent's stopping rule (``brentq``'s meaning).
    out : ndarray, shape (N, K, 3), float64
        Receives the reflection points, in increasing ``t`` (rows past ``count`` untouched).
    count : ndarray, shape (N,), int32
        Receives the number of reflection points (at most K).
    ts, fs : ndarray, shape (samples + 1,), float64
        Scratch, one pair per part.
    """
    c0, c1, c2 = centre[0], centre[1], centre[2]
    o0, o1, o2 = eye[0], eye[1], eye[2]
    for j in range(lo, hi):
        _inside_point(todo[j], c0, c1, c2, rho, o0, o1, o2, points, axis_a, axis_b, samples, xtol, rtol, maxiter,
                      ts, fs, out, count)
