"""refsoft.search.skips.triangles_outside_box (the per-triangle box cull) and triangles_skipped (it
and the lost vertices) against plain per-triangle versions (tests/naive.py and below), including
points exactly on a side."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from naive import naive_outside_box, naive_triangles_outside_box

from refsoft.search import BORDER, CULLED, HIDDEN, skips

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


def naive_triangles_skipped(clip, faces, flags, lost, bounds):
    """A triangle with a vertex flagged in ``lost``, or (``bounds`` given) one outside the box."""
    return np.array([any(int(flags[int(i)]) & lost for i in f)
                     or (bounds is not None and naive_outside_box([clip[int(i)] for i in f], bounds))
                     for f in faces], dtype=bool)


@pytest.mark.parametrize("with_box", [True, False])
def test_triangles_skipped_equals_the_reference(rng, with_box):
    """The virtual pass's one per-triangle test: lost vertices and (with a box) the box cull."""
    clip = np.c_[rng.uniform(-3, 3, (200, 3)), rng.uniform(-1, 3, 200)]
    faces = rng.integers(0, 200, (500, 3)).astype(np.int64)
    flags = rng.choice(np.array([0, CULLED, HIDDEN, BORDER, HIDDEN | BORDER], np.uint8), 200, p=[0.8, .05, .05, .05, .05])
    lost = CULLED | HIDDEN
    bounds = skips.box_planes((10, 40, 20, 70), 96, 72) if with_box else None
    expected = naive_triangles_skipped(clip, faces, flags, lost, bounds)
    for serial in (True, False):
        np.testing.assert_array_equal(skips.triangles_skipped(clip, faces, flags, lost, bounds, serial=serial), expected)
    assert 0 < expected.sum() < len(faces)
    # no flag lost: the box test alone (or nothing)
    alone = skips.triangles_skipped(clip, faces, flags, 0, bounds)
    np.testing.assert_array_equal(alone, naive_triangles_skipped(clip, faces, flags, 0, bounds))
    assert alone.any() == with_box
