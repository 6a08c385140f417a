"""The analytic sphere reflection point: Brent on the arc against Eberly's quartic."""

import numpy as np
import pytest

from refsoft import RefsoftError
from refsoft.truth.analytic import reflection_residual, sphere_reflection_points, sphere_reflection_points_quartic


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
