"""Reflection points seen from inside a sphere (the concave case): the kernel against a plain
NumPy reference written here (the whole great circle sampled densely, each sign change bisected),
against the closed-form cases, and across thread counts."""

import numba
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from refsoft import RefsoftError
from refsoft.constants import INSIDE_ARC_SAMPLES
from refsoft.truth.analytic import reflection_residual, sphere_inside_reflection_points

DENSE = 16384


def reference_inside(centre, radius, eye, point, dense=DENSE):
    """Every reflection point of ``point`` seen from ``eye`` inside the sphere, and their angles
    around the circle: ``f(t) = (u + w) . T`` sampled at ``dense`` angles, bisected 80 times in
    each interval where it changes sign, kept where both lie in front of the inward tangent plane."""
    c, o, v = (np.asarray(x, dtype=np.float64) for x in (centre, eye, point))
    a = o - c
    a = a / np.linalg.norm(a)
    b = (v - c) - np.dot(v - c, a) * a
    b = b / np.linalg.norm(b)

    def f(t):
        t = np.asarray(t, dtype=np.float64)[..., None]
        n = np.cos(t) * a + np.sin(t) * b
        r = c + radius * n
        u = (o - r) / np.linalg.norm(o - r, axis=-1, keepdims=True)
        w = (v - r) / np.linalg.norm(v - r, axis=-1, keepdims=True)
        return np.sum((u + w) * (-np.sin(t) * a + np.cos(t) * b), axis=-1)

    t = np.linspace(0.0, 2 * np.pi, dense + 1)
    ft = f(t)
    roots = []
    for k in np.flatnonzero(np.sign(ft[:-1]) * np.sign(ft[1:]) < 0):
        lo, hi, flo = t[k], t[k + 1], ft[k]
        for _ in range(80):
            mid = 0.5 * (lo + hi)
            fm = f(mid)
            if np.sign(fm) == np.sign(flo):
                lo, flo = mid, fm
            else:
                hi = mid
        roots.append(0.5 * (lo + hi))
    roots = np.array(roots)
    n = np.cos(roots)[:, None] * a + np.sin(roots)[:, None] * b
    r = c + radius * n
    front = (np.sum((o - r) * -n, axis=1) > 0) & (np.sum((v - r) * -n, axis=1) > 0)
    return r[front], roots[front]


def min_gap(angles):
    """Smallest circular distance between two angles (inf for fewer than two)."""
    if len(angles) < 2:
        return np.inf
    s = np.sort(np.mod(angles, 2 * np.pi))
    return float(np.min(np.diff(np.r_[s, s[0] + 2 * np.pi])))


def inside_residual(centre, eye, points, found):
    """Angle between the bisector and the inward normal (the outward one's residual is pi less it)."""
    return np.pi - reflection_residual(centre, eye, points, found)


def inside_point(rng, centre, radius, scale):
    d = rng.normal(size=3)
    return centre + d / np.linalg.norm(d) * radius * scale


def check_against_reference(centre, radius, eye, pts):
    found, virtual, count = sphere_inside_reflection_points(centre, radius, eye, pts)
    compared = 0
    for i, v in enumerate(pts):
        ref, angles = reference_inside(centre, radius, eye, v)
        if min_gap(angles) < 1.5 * 2 * np.pi / INSIDE_ARC_SAMPLES:
            continue  # two images about to merge: the kernel's samples need not separate them
        compared += 1
        assert count[i] == len(ref)
        got = found[i, :count[i]]
        assert np.isnan(found[i, count[i]:]).all() and np.isnan(virtual[i, count[i]:]).all()
        # each reference root matched by one found root
        dist = np.linalg.norm(ref[:, None, :] - got[None, :, :], axis=2)
        assert np.array_equal(np.sort(dist.argmin(axis=1)), np.arange(len(ref)))
        assert dist.min(axis=1).max() < 1e-9 * radius
        # the virtual vertex: the point mirrored across the tangent plane
        n = (got - centre) / radius
        mirrored = v - 2 * np.sum((v - got) * n, axis=1)[:, None] * n
        np.testing.assert_allclose(virtual[i, :count[i]], mirrored, rtol=0, atol=1e-12 * radius)
    return compared, count


def test_matches_the_dense_reference_and_finds_four_images():
    rng = np.random.default_rng(0)
    centre, radius = np.array([0.2, -0.4, 1.0]), 1.5
    eye = centre + np.array([0.0, 0.3, 0.9])
    pts = np.array([inside_point(rng, centre, radius, s) for s in rng.uniform(0.05, 0.99, 60)])
    compared, count = check_against_reference(centre, radius, eye, pts)
    assert compared >= 50
    assert set(count.tolist()) >= {2, 4}  # both kinds occur


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), radius=st.floats(1e-2, 1e2), eye_frac=st.floats(0.0, 0.98),
       pt_frac=st.floats(0.01, 0.995))
def test_hypothesis_matches_the_dense_reference(seed, radius, eye_frac, pt_frac):
    rng = np.random.default_rng(seed)
    centre = rng.uniform(-3, 3, 3) * radius
    eye = inside_point(rng, centre, radius, eye_frac) if eye_frac > 1e-3 else centre + [radius * 1e-3, 0, 0]
    pts = np.array([inside_point(rng, centre, radius, pt_frac), inside_point(rng, centre, radius, 0.5)])
    check_against_reference(centre, radius, eye, pts)
    found, _, count = sphere_inside_reflection_points(centre, radius, eye, pts)
    ok = np.arange(found.shape[1])[None, :] < count[:, None]
    rows = np.repeat(np.arange(len(pts)), count)
    if ok.any():
        assert inside_residual(centre, eye, pts[rows], found[ok]).max() < 1e-9


def test_eye_at_the_centre_sees_the_point_along_its_direction():
    rng = np.random.default_rng(1)
    centre, radius = np.array([1.0, 2.0, -1.0]), 2.5
    pts = np.array([inside_point(rng, centre, radius, s) for s in rng.uniform(0.05, 0.95, 30)])
    found, virtual, count = sphere_inside_reflection_points(centre, radius, centre, pts)
    assert np.all(count == 2)
    d = (pts - centre) / np.linalg.norm(pts - centre, axis=1, keepdims=True)
    # the point's direction and its opposite (in either order: the first may be met at 2 pi - 0)
    near = np.sum((found[:, :2] - centre) * d[:, None, :], axis=2) > 0
    assert np.all(near.sum(axis=1) == 1)
    along = np.where(near[:, :1], found[:, 0], found[:, 1])
    away = np.where(near[:, :1], found[:, 1], found[:, 0])
    np.testing.assert_allclose(along, centre + radius * d, rtol=0, atol=1e-12)
    np.testing.assert_allclose(away, centre - radius * d, rtol=0, atol=1e-12)
    # mirrored across the tangent plane at distance radius - |p - c| (and radius + |p - c|)
    dist = np.linalg.norm(pts - centre, axis=1)
    v_along = np.where(near[:, :1], virtual[:, 0], virtual[:, 1])
    v_away = np.where(near[:, :1], virtual[:, 1], virtual[:, 0])
    np.testing.assert_allclose(v_along, centre + (2 * radius - dist)[:, None] * d, atol=1e-12)
    np.testing.assert_allclose(v_away, centre - (2 * radius + dist)[:, None] * d, atol=1e-12)


@pytest.mark.parametrize("x, y", [(0.3, 0.2), (0.6, -0.5), (0.1, 0.7), (0.8, 0.1)])
def test_eye_and_point_symmetric_about_an_axis_reflect_on_the_axis(x, y):
    centre, radius = np.array([0.0, 0.0, 0.0]), 1.0
    eye, pt = np.array([x, y, 0.0]), np.array([-x, y, 0.0])
    found, _, count = sphere_inside_reflection_points(centre, radius, eye, [pt])
    got = found[0, :count[0]]
    for axis_point in ([0.0, 1.0, 0.0], [0.0, -1.0, 0.0]):
        assert np.linalg.norm(got - axis_point, axis=1).min() < 1e-12
    ref, _ = reference_inside(centre, radius, eye, pt)
    assert count[0] == len(ref)


def test_collinear_points_give_the_axis_points():
    # the eye and the point on one line through the centre: the two ends of the line reflect
    eye = np.array([0.0, 0.0, 0.4])
    pts = np.array([[0.0, 0.0, 0.7], [0.0, 0.0, -0.2], [0.0, 0.0, 0.4]])
    found, _, count = sphere_inside_reflection_points([0, 0, 0], 1.0, eye, pts)
    for i in range(len(pts)):
        got = found[i, :count[i]]
        for end in ([0, 0, 1.0], [0, 0, -1.0]):
            assert np.linalg.norm(got - end, axis=1).min() < 1e-12
        assert inside_residual([0, 0, 0], eye, np.repeat(pts[i:i + 1], count[i], 0), got).max() < 1e-9


def test_points_outside_or_both_at_the_centre_have_none():
    found, virtual, count = sphere_inside_reflection_points([0, 0, 0], 1.0, [0.2, 0, 0], [[0, 2.0, 0], [0, 1.0, 0]])
    assert np.all(count == 0) and np.isnan(found).all() and np.isnan(virtual).all()
    _, _, count = sphere_inside_reflection_points([0, 0, 0], 1.0, [0, 0, 0], [[0, 0, 0], [0.5, 0, 0]])
    assert count.tolist() == [0, 2]


def test_bit_identical_across_thread_counts():
    rng = np.random.default_rng(3)
    centre, radius, eye = np.array([1.0, -2.0, 0.5]), 1.7, np.array([1.5, -1.4, 0.2])
    pts = np.array([inside_point(rng, centre, radius, s) for s in rng.uniform(0.0, 0.99, 400)])
    a = sphere_inside_reflection_points(centre, radius, eye, pts)
    numba.set_num_threads(1)
    try:
        b = sphere_inside_reflection_points(centre, radius, eye, pts)
    finally:
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    assert numba.config.NUMBA_NUM_THREADS > 1
    assert (a[2] == 4).sum() > 10
    for x, y in zip(a, b):
        assert np.array_equal(x, y, equal_nan=True)


def test_bad_inputs():
    with pytest.raises(RefsoftError, match="inside the sphere"):
        sphere_inside_reflection_points([0, 0, 0], 1.0, [0, 0, 1.5], [[0, 0, 0.5]])
    with pytest.raises(RefsoftError, match="radius"):
        sphere_inside_reflection_points([0, 0, 0], 0.0, [0, 0, 0], [[0, 0, 0.5]])
    with pytest.raises(RefsoftError, match="finite"):
        sphere_inside_reflection_points([0, 0, 0], 1.0, [0, 0, 0], [[0, np.nan, 0.5]])
    with pytest.raises(RefsoftError, match="samples"):
        sphere_inside_reflection_points([0, 0, 0], 1.0, [0, 0, 0], [[0, 0, 0.5]], samples=2)
