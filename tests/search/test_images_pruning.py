"""The enumeration's cheap cell test (refsoft/search/_images.py, ``_may_contain``): it keeps every
cell the cone-sphere test keeps, so the texels judged, and the images, are the same."""

import numpy as np

from refsoft.search._hierarchy import _contains
from refsoft.search._images import _may_contain, cone_trig


def _cells(rng, n):
    """Float32 spheres and cones as the pyramid holds them: unit axes, half-angles from 0 to
    past pi, radii from 0 up, a few empty cells (-1)."""
    sph = np.empty((n, 4), np.float32)
    cone = np.empty((n, 4), np.float32)
    sph[:, :3] = rng.normal(size=(n, 3))
    sph[:, 3] = rng.choice([0.0, 1e-3, 0.05, 0.3, 2.0], n) * rng.uniform(0, 1, n)
    axis = rng.normal(size=(n, 3))
    cone[:, :3] = axis / np.linalg.norm(axis, axis=1, keepdims=True)
    cone[:, 3] = rng.choice([0.0, 1e-4, 0.02, 0.3, 1.5, 2.5, 3.5], n) * rng.uniform(0.5, 1.0, n)
    cone[::37, 3] = -1.0
    sph[::37, 3] = -1.0
    return sph, cone


def test_cheap_test_keeps_every_cell_the_cone_sphere_test_keeps(rng):
    sph, cone = _cells(rng, 3000)
    trig = np.empty((len(cone), 2))
    cone_trig(len(cone), cone, trig)
    one = np.float32(1.0)
    kept = exact = 0
    for q in range(len(sph)):
        # vertices near the axis's boundary, where the two tests are closest
        for _ in range(4):
            d = cone[q, :3] + rng.normal(scale=rng.choice([0.01, 0.3, 1.0]), size=3)
            v = (sph[q, :3] + d * rng.uniform(0.01, 3.0)).astype(np.float32)
            a = _contains(sph[q], cone[q], v, one, one, np.float32(0.0))
            b = _may_contain(sph[q], cone[q], trig[q], v)
            assert b or not a, (q, v)
            exact += a
            kept += b
    # it prunes: few cells kept that the exact test does not keep
    assert 0 < exact <= kept < exact + 0.05 * len(sph) * 4


def test_cheap_test_on_the_boundary_of_the_cone(rng):
    """Vertices placed at the cone's edge angle (the half-angle plus the apex's asin) within a
    few float32 roundings: whatever the exact test says there, the cheap test keeps it."""
    one = np.float32(1.0)
    for _ in range(2000):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        half = rng.uniform(0.0, 1.5)
        r = rng.uniform(0.0, 0.2)
        dist = rng.uniform(0.3, 5.0)
        edge = half + np.arcsin(min(r / dist, 1.0)) + rng.normal(scale=1e-6)
        perp = np.cross(axis, rng.normal(size=3))
        perp /= np.linalg.norm(perp)
        c = rng.normal(size=3)
        v = (c + dist * (np.cos(edge) * axis + np.sin(edge) * perp)).astype(np.float32)
        s = np.array([*c, r], np.float32)
        cn = np.array([*axis, half], np.float32)
        trig = np.empty((1, 2))
        cone_trig(1, cn[None], trig)
        if _contains(s, cn, v, one, one, np.float32(0.0)):
            assert _may_contain(s, cn, trig[0], v)
