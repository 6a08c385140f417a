"""The silhouette cut's bisection kernel (refsoft.search._silhouette) against the plain reference
in tests/naive_silhouette.py (one search per point), bit for bit: the same cut points, pixels and
flags, also from starts that are no longer covered or missing, in float64, with the box, on one
thread and on several; and the whole cut with the walk against the cut with one search call per
step."""

import numpy as np
import pytest
from naive_silhouette import naive_bisect

from refsoft import raster, search
from refsoft._parallel import one_thread
from refsoft.search import silhouette
from scene_data import sphere_searched


@pytest.fixture(scope="module")
def mixed_edges():
    """The sphere's cut edges (visible end, hidden end) at 160x120, with their search results."""
    scene, gb, verts, _, comb, res = sphere_searched("discard")
    clip = silhouette.clip_at_silhouette(gb, scene.camera.eye, verts, comb.normals, comb.faces, comb.face_object,
                                         res.pixel, res.flags)
    vis, hid = clip.ends[:, 0], clip.ends[:, 1]
    assert len(vis) > 20
    return scene, gb, verts, res, vis, hid, clip


def _both(gb, eye, pv, ph, pixel, flags, nb, iterations):
    got = silhouette._bisect(gb, eye, pv, ph, pixel, flags, nb, None, iterations)
    want = naive_bisect(gb, eye, pv, ph, pixel, flags, nb, iterations)
    return got, want


@pytest.mark.parametrize("nb", ["cross", "box"])
def test_kernel_matches_one_search_per_point(mixed_edges, nb):
    scene, gb, verts, res, vis, hid, _ = mixed_edges
    got, want = _both(gb, scene.camera.eye, verts[vis], verts[hid], res.pixel[vis], res.flags[vis], nb, 6)
    for a, b in zip(got, want):
        np.testing.assert_array_equal(a, b)
    assert np.all(got[0] > 0) and np.all(got[0] < 1)  # every edge was cut inside


def test_kernel_restarts_like_the_search(mixed_edges):
    """Starts no longer covered restart at the default start with flag RESTARTED, (-1, -1) starts
    there without it: as the search does."""
    scene, gb, verts, res, vis, hid, _ = mixed_edges
    pixel = res.pixel[vis].copy()
    pixel[::3] = (0, 0)  # a corner of the buffer: not covered
    pixel[1::3] = (-1, -1)
    assert not gb.mask[0, 0]
    got, want = _both(gb, scene.camera.eye, verts[vis], verts[hid], pixel, res.flags[vis], "cross", 4)
    for a, b in zip(got, want):
        np.testing.assert_array_equal(a, b)
    assert np.any(got[2] & search.RESTARTED)


def test_kernel_in_float64(mixed_edges):
    scene, _, verts, _, vis, hid, _ = mixed_edges
    gb = raster.gbuffer(scene.world_mesh(1, proxy=True), scene.camera, "float64", origin=scene.camera.eye)
    res = search.search(gb, scene.camera.eye, verts, "cross", "discard")
    ok = (res.flags[vis] & search.HIDDEN) == 0
    got, want = _both(gb, scene.camera.eye, verts[vis][ok], verts[hid][ok], res.pixel[vis][ok], res.flags[vis][ok],
                      "cross", 5)
    for a, b in zip(got, want):
        np.testing.assert_array_equal(a, b)


def test_cut_is_the_same_on_one_thread_and_with_searches_per_step(mixed_edges, monkeypatch):
    scene, gb, verts, res, vis, hid, clip = mixed_edges
    with one_thread():
        one = silhouette._bisect(gb, scene.camera.eye, verts[vis], verts[hid], res.pixel[vis], res.flags[vis],
                                 "cross", None, 10)
    steps = silhouette._bisect_searches(gb, scene.camera.eye, verts[vis], verts[hid], res.pixel[vis], res.flags[vis],
                                        "cross", None, "walk", 10)
    for a, b, c in zip(one, steps, (clip.t, clip.pixel, clip.flags)):
        np.testing.assert_array_equal(a, c)
        np.testing.assert_array_equal(b, c)
