"""The cone test of reflection regions against the written-out reference and against sampled rays."""

import numpy as np
import pytest

from naive import naive_cone_cases
from refsoft.ldt.regions import cone_cases, cone_test

# the eye at the origin; the object at (0, 0, -3), radius 0.5, in front of the mirror plane
# z = -5, which mirrors it to (0, 0, -7): the cone's radius is about 0.358 at z = -5
EYE = np.zeros(3)
SPHERE = (np.array([[0.0, 0.0, -3.0]]), np.array([0.5]))


def tri(*xy, z=-5.0):
    return np.array([[x, y, z] for x, y in xy], dtype=np.float64)


CASES = {
    # name: corners, expected (corner, edge, axis)
    "corner": (tri((0.0, 0.0), (3.0, 0.0), (0.0, 3.0)), (True, True, True)),
    "edge only": (tri((-1.0, 0.1), (1.0, 0.1), (0.0, 2.0)), (False, True, False)),
    "ellipse inside": (tri((-10.0, -10.0), (10.0, -10.0), (0.0, 10.0)), (False, False, True)),
    "beside": (tri((2.0, 2.0), (3.0, 2.0), (2.0, 3.0)), (False, False, False)),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_the_three_cases(name):
    corners, expected = CASES[name]
    got = cone_cases(corners[None], EYE, *SPHERE)[0, 0]
    assert tuple(got[:3]) == expected and not got[3]
    assert cone_test(corners[None], EYE, *SPHERE)[0, 0] == any(expected)
    assert tuple(naive_cone_cases(*corners, EYE, SPHERE[0][0], SPHERE[1][0])[:3]) == expected


def test_a_triangle_facing_away_fails():
    """The same place on the axis, tilted by 45 degrees: its plane mirrors the sphere to
    (-2, 0, -5), about 22 degrees off, outside the cone (5.3 degrees)."""
    c = np.array([0.0, 0.0, -5.0])
    a, b = np.array([1.0, 0.0, -1.0]) / np.sqrt(2), np.array([0.0, 1.0, 0.0])
    corners = np.array([c - 0.2 * a - 0.2 * b, c + 0.2 * a - 0.2 * b, c + 0.2 * b])
    assert not cone_test(corners[None], EYE, *SPHERE)[0, 0]
    facing = tri((-0.2, -0.2), (0.2, -0.2), (0.0, 0.2))
    assert cone_test(facing[None], EYE, *SPHERE)[0, 0]


def test_eye_inside_the_virtual_sphere_and_degenerate_triangles_pass():
    corners = tri((10.0, 10.0), (11.0, 10.0), (10.0, 11.0), z=0.2)  # plane z = 0.2: O_v = (0, 0, 3.4)
    got = cone_cases(corners[None], EYE, np.array([[0.0, 0.0, -3.0]]), np.array([3.5]))[0, 0]
    assert got[3]
    flat = tri((0.0, 0.0), (1.0, 1.0), (2.0, 2.0))
    assert cone_cases(flat[None], EYE, *SPHERE)[0, 0, 3]


def test_random_triangles_match_the_reference_and_sampled_rays():
    rng = np.random.default_rng(8)
    T, K = 300, 3
    centres = rng.normal(0, 1.5, (K, 3)) + [0, 0, -4]
    radii = rng.uniform(0.5, 1.5, K)
    base = rng.normal(0, 2.0, (T, 1, 3)) + [0, 0, -5]
    corners = base + rng.normal(0, 1.5, (T, 3, 3))
    got = cone_cases(corners, EYE, centres, radii)
    for t in range(T):
        for k in range(K):
            assert tuple(got[t, k]) == naive_cone_cases(*corners[t], EYE, centres[k], radii[k])
    passed = got.any(axis=2)
    assert 0.1 < passed.mean() < 0.9
    # each case decides some pairs alone
    assert (got[..., 0].sum() > 20 and (got[..., 1] & ~got[..., 0]).sum() > 20
            and (got[..., 2] & ~got[..., 0] & ~got[..., 1]).sum() > 5)
    # sampled points of the triangle: where the eye's ray through one meets the virtual sphere
    # (the point lies in the cone), the triangle must pass: the three cases cover the overlap
    w = rng.dirichlet(np.ones(3), 400)
    seen = 0
    for t in range(T):
        p1, p2, p3 = corners[t]
        n = np.cross(p1 - p2, p3 - p2)
        n /= np.linalg.norm(n)
        d = w @ corners[t]
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        for k in range(K):
            Ov = centres[k] - 2 * (np.dot(n, centres[k]) - np.dot(n, p1)) * n
            s = d @ Ov
            hit = (s > 0) & (np.linalg.norm(Ov - s[:, None] * d, axis=1) <= radii[k])
            if hit.any():
                seen += 1
                assert passed[t, k]
    assert seen > 20
