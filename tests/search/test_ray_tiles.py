"""The ray tiles (refsoft/search/_raytiles.py) and the drawing of every image that meets each
candidate triangle with the rays that may hit it (reach.ray_lists, several.with_ray_lists)."""

import numpy as np
import pytest

from refsoft import constants
from refsoft._parallel import one_thread
from refsoft.errors import RefsoftError
from refsoft.search import reach, several

import naive_several as naive


def _rays(h=37, w=45):
    """Rays of an (h, w) box (sizes not multiples of the tiles) leaving a wavy surface below the
    triangles, a few pixels invalid and one ray that is not finite."""
    yy, xx = np.mgrid[0:h, 0:w]
    u, v = (xx - w / 2) / w * 2.4, (yy - h / 2) / h * 2.4
    origin = np.stack([u, v, 0.15 * np.sin(3 * u) * np.cos(2 * v)], axis=-1)
    # directions fan out from the surface, as off a curved mirror (not unit length)
    direction = np.stack([0.6 * np.sin(2 * u), 0.5 * np.cos(3 * v), 1.0 + 0.3 * u * u], axis=-1)
    valid = np.ones((h, w), bool)
    valid[::7, ::5] = False
    origin[~valid] = 0.0
    direction[~valid] = 0.0
    origin[20, 30, 0] = np.nan
    return valid, origin, direction


def _triangles(rng, n=60):
    real = rng.uniform(-2.0, 2.0, (n, 3, 3)) * [1.0, 1.0, 0.3] + [0.0, 0.0, 1.5]
    real[3] = [[0, 0, 1], [1, 0, 1], [2, 0, 1]]  # degenerate
    real[4, 2, 1] = np.inf  # not finite: every ray kept
    real[5] += [0.0, 0.0, -6.0]  # behind every ray
    real[6] = [[-0.5, -0.5, 1.2], [0.5, -0.5, 1.2], [0.0, 0.6, 1.2]]  # hit by many
    real[7] *= 0.05  # small, near the surface
    return real


def _hit(origin, direction, tri):
    """Exact Moller-Trumbore of rays (R, 3) with one triangle: t > 0, u, v, u + v in [0, 1]."""
    with np.errstate(invalid="ignore"):
        return naive.first_hits(origin, direction, tri[None]) == 0


def test_ray_lists_are_the_every_ray_lists_less_rays_that_cannot_hit(rng):
    valid, origin, direction = _rays()
    real = _triangles(rng)
    o, d = origin[valid], direction[valid]
    want = naive.rays_near(real, o, d, np.zeros(len(real), int), np.full(len(real), len(o)), np.arange(len(o)),
                           constants.SEVERAL_PRUNE_MARGIN, constants.SEVERAL_PRUNE_PARALLEL)
    first, last, ray = reach.ray_lists(real, (valid, origin, direction))
    dropped = 0
    for f in range(len(real)):
        got = ray[first[f]:last[f]].tolist()
        assert got == sorted(set(got)) and set(got) <= set(want[f]), f
        lost = np.setdiff1d(want[f], got)
        dropped += len(lost)
        assert not np.any(_hit(o[lost], d[lost], real[f])), f
    hits = [int(np.sum(_hit(o, d, real[f]))) for f in range(len(real))]
    assert hits[6] > 20 and sum(hits) > 300  # the lists hold rays that hit
    assert ray[first[4]:last[4]].tolist() == want[4]  # a corner not finite: nothing pruned
    odd = int(np.flatnonzero(~np.isfinite(o).all(axis=1))[0])  # kept by every triangle: nothing proves it off
    assert ray[first[5]:last[5]].tolist() == [odd] and all(odd in want[f] for f in range(len(real)))
    np.testing.assert_array_equal(first, np.cumsum(last - first) - (last - first))
    assert dropped > 0 or sum(map(len, want)) == len(ray)


def test_ray_lists_prune_tiles_far_from_the_triangle():
    """A small triangle above one corner of the box keeps no ray of the far tiles, and the lists
    hold only rays of pixels whose ray passes near it."""
    valid, origin, direction = _rays(64, 64)
    direction[:] = [0.0, 0.0, 1.0]
    origin[20, 30, 0] = 0.0
    tri = np.array([[[-1.1, -1.1, 1.0], [-1.0, -1.1, 1.0], [-1.1, -1.0, 1.0]]])
    first, last, ray = reach.ray_lists(tri, (valid, origin, direction))
    rows, cols = np.nonzero(valid)
    assert 0 < last[0] - first[0] < 40
    assert rows[ray].max() < 16 and cols[ray].max() < 16


def test_ray_lists_same_bits_on_one_thread_and_several(rng):
    rays = _rays()
    real = _triangles(rng, 90)
    with one_thread():
        a = reach.ray_lists(real, rays)
    b = reach.ray_lists(real, rays)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)


def test_ray_lists_refuses_rays_of_other_shapes():
    valid, origin, direction = _rays()
    with pytest.raises(RefsoftError, match="rays must be"):
        reach.ray_lists(np.zeros((1, 3, 3)), (valid, origin[:, :5], direction))


def test_no_candidate_triangle_leaves_a_pixel_it_reflects_empty():
    """On the tiny concave scene the image candidates alone leave pixels empty or wrong (their
    virtual triangles miss part of their images); met with their rays, every stencil pixel shows
    the naive ray tracer's nearest object among the candidates' triangles, and with every
    triangle a ray hits among them, the naive tracer's object."""
    from test_several import _render, _scene

    scene = _scene()
    frame, (view, k, stencil, out) = _render(scene)
    truth = naive.trace_reflections(scene, view.meshes, view.camera, stencil, view.meshes[k - 1],
                                    view.view.triangle)
    rid = frame.arrays["reflected_id"]
    assert np.array_equal(rid[stencil], truth[stencil])
    assert out.report["several"]["pixels_empty"] == int(np.sum(stencil & (truth == 0)))
