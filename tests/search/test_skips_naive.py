"""refsoft.search.skips.triangles_outside_box (the per-triangle box cull) against a plain
per-triangle version of outside_box (tests/naive.py), including points exactly on a side."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from naive import naive_outside_box, naive_triangles_outside_box

from refsoft.search import skips

# dyadic values: products are exact, so points land exactly on the sides (strict tests)
_COORD = st.sampled_from([-2.0, -1.0, -0.5, -0.25, 0.0, 0.25, 0.5, 1.0, 2.0])
_BOUNDS = (-0.5, 0.25, -0.25, 0.5)


def _check(clip, faces, bounds):
    expected = naive_triangles_outside_box(clip, faces, bounds)
    for serial in (True, False):  # on the calling thread alone, and split among threads
        np.testing.assert_array_equal(skips.triangles_outside_box(clip, faces, *bounds, serial=serial), expected)
    # and the mesh-level test on each triangle alone
    assert [skips.outside_box(clip[f], bounds) for f in faces] == expected.tolist()
    assert skips.outside_box(clip, bounds) == naive_outside_box(clip, bounds)  # every point at once
    return expected


@settings(max_examples=150, deadline=None)
@given(st.lists(st.tuples(_COORD, _COORD, _COORD, st.sampled_from([-1.0, 0.5, 1.0, 2.0])), min_size=3, max_size=7),
       st.data())
def test_box_cull_equals_the_reference_on_exact_sides(points, data):
    clip = np.array(points, dtype=np.float64)
    n = len(clip)
    faces = np.array(data.draw(st.lists(st.tuples(*[st.integers(0, n - 1)] * 3), min_size=1, max_size=8)),
                     dtype=np.int64)
    _check(clip, faces, _BOUNDS)


def test_box_cull_equals_the_reference_on_random_triangles(rng):
    clip = np.c_[rng.uniform(-3, 3, (200, 3)), rng.uniform(-1, 3, 200)]
    faces = rng.integers(0, 200, (500, 3)).astype(np.int64)
    bounds = skips.box_planes((10, 40, 20, 70), 96, 72)
    expected = _check(clip, faces, bounds)
    assert 0 < expected.sum() < len(faces)  # both outcomes occur
