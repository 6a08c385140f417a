"""The analytic sphere reflection point: the Numba kernel against the plain NumPy solver of
``tests/naive.py`` (bit for bit, any thread count), against SciPy's ``brentq`` (to SciPy's
documented tolerance: SciPy does not promise its iterates' bits), and Brent on the arc against
Eberly's quartic."""

import numba
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import refsoft
from naive import naive_sphere_reflection_points, scipy_brent
from refsoft import RefsoftError
from refsoft.constants import RTOL, XTOL
from refsoft.scene import scene_vertices
from refsoft.truth.analytic import (fit_sphere, reflection_residual, sphere_reflection_points,
                                    sphere_reflection_points_quartic)


def random_pairs(rng, n, grazing=False):
    centre = np.array([0.3, -0.2, 0.5])
    eye = centre + np.array([0.0, 0.0, 4.0])
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    if grazing:
        # points just inside the visible region's horizon: the reflection point is near the rim
        # points almost behind the sphere: the reflection point is close to the rim
        z = -rng.uniform(0.6, 0.95, n)
        xy = d[:, :2] / np.linalg.norm(d[:, :2], axis=1, keepdims=True) * np.sqrt(1 - z * z)[:, None]
        d = np.c_[xy, z]
    pts = centre + d * rng.uniform(1.2, 6.0, (n, 1)) * (2.0 if grazing else 1.0)
    return centre, eye, pts


@pytest.mark.parametrize("grazing", [False, True])
def test_brent_satisfies_the_reflection_law(grazing):
    rng = np.random.default_rng(1 + grazing)
    centre, eye, pts = random_pairs(rng, 600, grazing)
    r = sphere_reflection_points(centre, 1.0, eye, pts)
    ok = np.all(np.isfinite(r), axis=1)
    assert ok.sum() > 150
    np.testing.assert_allclose(np.linalg.norm(r[ok] - centre, axis=1), 1.0, atol=1e-14)
    assert reflection_residual(centre, eye, pts[ok], r[ok]).max() < 1e-10
    # both the eye and the point lie outside the tangent plane
    n = r[ok] - centre
    assert np.all(np.sum((eye - r[ok]) * n, axis=1) > 0) and np.all(np.sum((pts[ok] - r[ok]) * n, axis=1) > 0)


@pytest.mark.parametrize("grazing", [False, True])
def test_brent_agrees_with_eberly_and_is_the_more_accurate(grazing):
    rng = np.random.default_rng(10 + grazing)
    centre, eye, pts = random_pairs(rng, 600, grazing)
    brent = sphere_reflection_points(centre, 1.0, eye, pts)
    quartic = sphere_reflection_points_quartic(centre, 1.0, eye, pts)
    both = np.all(np.isfinite(brent), axis=1) & np.all(np.isfinite(quartic), axis=1)
    assert both.sum() > 150
    n = brent[both] - centre
    u = eye - brent[both]
    cos_in = np.sum(n * u, axis=1) / np.linalg.norm(u, axis=1)
    if grazing:
        assert np.median(cos_in) < 0.3  # these really are near-grazing reflections
    diff = np.linalg.norm(brent[both] - quartic[both], axis=1)
    assert np.median(diff) < 1e-9
    res_b = reflection_residual(centre, eye, pts[both], brent[both])
    res_q = reflection_residual(centre, eye, pts[both], quartic[both])
    worse = diff > 1e-12
    assert np.all(res_b[worse] <= res_q[worse] + 1e-15)
    print(f"grazing={grazing}: min cos incidence {cos_in.min():.3f}, max |brent - quartic| {diff.max():.2e}, "
          f"residual brent {res_b.max():.1e}, quartic {res_q.max():.1e}")


def test_points_inside_or_hidden_have_no_reflection_point():
    r = sphere_reflection_points([0, 0, 0], 1.0, [0, 0, 3.0], [[0, 0, 0.5], [0, 0, -5.0], [0, 0.1, -5.0]])
    assert np.all(np.isnan(r[0]))
    # exactly behind the centre: any point of the rim? no point of the visible surface reflects it
    assert np.all(np.isnan(r[1]))


def test_bad_inputs():
    with pytest.raises(RefsoftError, match="outside the sphere"):
        sphere_reflection_points([0, 0, 0], 1.0, [0, 0, 0.5], [[0, 0, 3.0]])
    with pytest.raises(RefsoftError, match="radius"):
        sphere_reflection_points([0, 0, 0], -1.0, [0, 0, 5], [[0, 0, 3.0]])


def mixed_points(rng, centre, radius, eye, n):
    """Points of every kind around a sphere: far and near, inside, behind it, near the horizon
    of the visible cap, on the eye's ray (in front and behind), on the surface's doorstep."""
    e = (eye - centre) / np.linalg.norm(eye - centre)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    dist = radius * rng.uniform(1.001, 8.0, n)
    kind = rng.integers(0, 6, n)
    # horizon of the cap seen from the point's side: directions almost opposite the eye
    back = -e + 0.35 * d
    d = np.where((kind == 1)[:, None], back / np.linalg.norm(back, axis=1, keepdims=True), d)
    d = np.where((kind == 2)[:, None], np.where(rng.random((n, 1)) < 0.5, e, -e), d)
    dist = np.where(kind == 3, radius * rng.uniform(0.0, 0.999, n), dist)  # inside
    dist = np.where(kind == 4, radius * (1.0 + rng.uniform(1e-12, 1e-6, n)), dist)  # just outside
    return centre + d * dist[:, None]


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), radius=st.floats(1e-3, 1e3), eye_dist=st.floats(1.0001, 50.0))
def test_kernel_matches_the_reference_solver_bit_for_bit(seed, radius, eye_dist):
    rng = np.random.default_rng(seed)
    centre = rng.uniform(-5, 5, 3) * radius
    e = rng.normal(size=3)
    eye = centre + e / np.linalg.norm(e) * eye_dist * radius
    pts = mixed_points(rng, centre, radius, eye, 40)
    new = sphere_reflection_points(centre, radius, eye, pts)
    old = naive_sphere_reflection_points(centre, radius, eye, pts)
    assert np.array_equal(new, old, equal_nan=True)


def test_kernel_matches_the_reference_solver_at_grazing_angles():
    rng = np.random.default_rng(7)
    centre, eye, pts = random_pairs(rng, 300, grazing=True)
    new = sphere_reflection_points(centre, 1.0, eye, pts)
    assert np.isfinite(new).all(axis=1).sum() > 100
    assert np.array_equal(new, naive_sphere_reflection_points(centre, 1.0, eye, pts), equal_nan=True)


def test_degenerate_arcs_match_the_reference_solver():
    # points on the eye's ray (the arc's plane is arbitrary) and none outside the sphere at all
    for eye in ([0.0, 0.0, 3.0], [2.5, 0.0, 0.0], [0.0, 4.0, 0.0]):
        e = np.array(eye) / np.linalg.norm(eye)
        pts = np.array([2.0 * e, -2.0 * e, 7.0 * e, -1.5 * e, 0.5 * e])
        new = sphere_reflection_points([0, 0, 0], 1.0, eye, pts)
        assert np.array_equal(new, naive_sphere_reflection_points([0, 0, 0], 1.0, eye, pts), equal_nan=True)
        assert np.isfinite(new[0]).all() and np.isnan(new[1]).all() and np.isnan(new[4]).all()
    assert np.isnan(sphere_reflection_points([0, 0, 0], 2.0, [0, 0, 5.0], [[0, 0, 1.0], [1, 0, 0]])).all()


def test_kernel_is_bit_identical_across_thread_counts():
    rng = np.random.default_rng(3)
    centre, radius, eye = np.array([1.0, -2.0, 0.5]), 1.7, np.array([4.0, 3.0, -6.0])
    pts = mixed_points(rng, centre, radius, eye, 3000)
    a = sphere_reflection_points(centre, radius, eye, pts)
    numba.set_num_threads(1)
    try:
        b = sphere_reflection_points(centre, radius, eye, pts)
    finally:
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    assert numba.config.NUMBA_NUM_THREADS > 1
    assert np.isfinite(a).all(axis=1).sum() > 1000
    assert np.array_equal(a, b, equal_nan=True)


def test_kernel_matches_the_reference_solver_on_a_scene_reflector():
    scene = refsoft.load_scene("sphere")
    verts, _ = scene_vertices(scene, 0)
    k = scene.reflector_ids[0]
    centre, radius = fit_sphere(scene.world_mesh(k, 0, proxy=True).vertices)
    eye = scene.camera_at(0).eye
    new = sphere_reflection_points(centre, radius, eye, verts)
    assert np.isfinite(new).all(axis=1).sum() > 100
    assert np.array_equal(new, naive_sphere_reflection_points(centre, radius, eye, verts), equal_nan=True)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_kernel_agrees_with_scipy_brentq_within_its_documented_tolerance(seed):
    """SciPy documents ``|x0 - x| <= xtol + rtol |x|`` for the root ``x0`` brentq returns, ``x``
    the exact root: two solvers that both meet it lie within twice that of each other. A point on
    a sphere of radius rho moves by rho |dt| for an arc angle dt, plus the rounding of
    ``c + rho n`` (a few ULP of |c| + rho)."""
    rng = np.random.default_rng(100 + seed)
    centre, radius = rng.uniform(-3, 3, 3), rng.uniform(0.2, 4.0)
    e = rng.normal(size=3)
    eye = centre + e / np.linalg.norm(e) * rng.uniform(1.5, 20.0) * radius
    pts = mixed_points(rng, centre, radius, eye, 400)
    new = sphere_reflection_points(centre, radius, eye, pts)
    ref, t, _ = naive_sphere_reflection_points(centre, radius, eye, pts, solver=scipy_brent, angles=True)
    found = np.isfinite(ref).all(axis=1)
    assert found.sum() > 100
    assert np.array_equal(np.isfinite(new).all(axis=1), found)
    bound = radius * 2.0 * (XTOL + RTOL * np.abs(t[found])) + 8 * np.finfo(float).eps * (np.abs(centre).max() + radius)
    err = np.linalg.norm(new[found] - ref[found], axis=1)
    assert np.all(err <= bound), (err / bound).max()


def test_sample_block_is_speed_only():
    from refsoft.truth import analytic

    rng = np.random.default_rng(5)
    centre, radius, eye = np.array([0.0, 0.5, -1.0]), 0.8, np.array([-3.0, 1.0, 2.0])
    pts = mixed_points(rng, centre, radius, eye, 500)
    ref = naive_sphere_reflection_points(centre, radius, eye, pts)
    block = analytic.SAMPLE_BLOCK
    try:
        for analytic.SAMPLE_BLOCK in (1, 3, analytic.ARC_SAMPLES, 2 * analytic.ARC_SAMPLES):
            assert np.array_equal(sphere_reflection_points(centre, radius, eye, pts), ref, equal_nan=True)
    finally:
        analytic.SAMPLE_BLOCK = block
