"""The traced acceptance (``_traced.accept_traced`` through ``acceptance._accept_traced``): each
pixel's ray walked through a hierarchy of the candidates' real triangles gives the plain
pixel-by-candidate loop's winners bit for bit (``tests/naive_several_pool.py``)."""

import numpy as np
import pytest

import naive_several_pool
from refsoft import constants
from refsoft._parallel import one_thread
from refsoft.search import _traced, acceptance


def _configuration(seed, n_faces=120, h=16, w=20, r0=4, c0=9):
    """Candidates over a box: overlapping real triangles at several heights, repeated ones (equal
    real triangles with other screen triangles: ties), slivers, unusable projections; rays with
    components that are exactly 0 and origins inside the triangles' boxes."""
    rng = np.random.default_rng(seed)
    valid = rng.random((h, w)) < 0.8
    valid[2] = False
    origin = np.concatenate([rng.uniform(-1, 1, (h, w, 2)), np.full((h, w, 1), 2.0)], axis=2)
    direction = np.concatenate([rng.normal(0, 0.2, (h, w, 2)), np.full((h, w, 1), -1.0)], axis=2)
    direction[::3, ::4, 0] = 0.0  # parallel to an axis
    direction[1::5, ::3, 1] = 0.0
    origin[5, :, 2] = 0.1  # inside the stack of triangles
    real = np.concatenate([rng.uniform(-1.5, 1.5, (n_faces, 3, 2)),
                           rng.uniform(-0.5, 0.5, (n_faces, 1, 1)).repeat(3, 1)], axis=2)
    real[::4] += rng.normal(0, 0.1, (len(real[::4]), 3, 3))  # tilted
    real = np.repeat(real, rng.integers(1, 4, n_faces), axis=0)  # equal real triangles: ties
    n = len(real)
    screen = rng.uniform([c0 - 3, r0 - 3], [c0 + w + 3, r0 + h + 3], (n, 3, 2))
    screen[::7, 2] = screen[::7, 0]  # slivers
    dilate = rng.uniform(0.5, 3.0, n)
    dilate[::11] = -1.0  # unusable projections: the whole bbox
    lo, hi = np.floor(screen.min(axis=1) - dilate[:, None]), np.ceil(screen.max(axis=1) + dilate[:, None])
    bbox = np.stack([lo[:, 1] - r0, hi[:, 1] - r0, lo[:, 0], hi[:, 0]], axis=1).astype(np.int64)
    return r0, c0, valid, origin, direction, screen, bbox, dilate, real


def _traced_outputs(r0, c0, valid, origin, direction, screen, bbox, dilate, real):
    h, w = valid.shape
    out = (np.full((h, w), np.inf), np.full((h, w), -1, np.int64), np.zeros((h, w, 2)))
    acceptance._accept_traced(r0, c0, valid, origin, direction, screen, bbox, dilate, real, *out)
    return out


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_traced_acceptance_matches_the_plain_loop(seed):
    """Same best_t, best_c and best_uv as the plain loop, on one thread and on several; the
    configuration has winners, ties between equal real triangles and empty pixels."""
    args = _configuration(seed)
    want = naive_several_pool.accept(*args)
    covered = want[1] >= 0
    assert covered.sum() > 50 and (~covered & args[2]).any()
    real = args[-1]
    _, first = np.unique(real.reshape(len(real), -1), axis=0, return_index=True)
    assert len(first) < len(real)  # repeated real triangles: ties decided by the lower index
    for several in (True, False):
        if several:
            got = _traced_outputs(*args)
        else:
            with one_thread():
                got = _traced_outputs(*args)
        for a, b in zip(got, want[:3]):
            assert np.array_equal(a, b)


def test_traced_acceptance_with_a_triangle_that_is_not_finite():
    """A candidate with a NaN corner has no box that bounds it: the candidates' own loop is used,
    with the same winners."""
    args = list(_configuration(4))
    real = args[-1].copy()
    real[7, 1, 0] = np.nan
    args[-1] = real
    want = naive_several_pool.accept(*args)
    got = _traced_outputs(*args)
    for a, b in zip(got, want[:3]):
        assert np.array_equal(a, b)
    assert (want[1] >= 0).sum() > 50


def test_nearest_traced_equals_the_loop_and_picks_by_cover():
    """``nearest`` with ``traced`` True or False gives the same bits; by default it traces only
    where the candidates' bounds cover more than EXACT_TRACE_COVER candidates per valid pixel."""
    r0, c0, valid, origin, direction, screen, bbox, dilate, real = _configuration(5)
    h, w = valid.shape
    box = (r0, r0 + h, c0, c0 + w)
    cand = acceptance.Candidates(None, real, None, None, np.arange(len(real)), 0)
    rays = (valid, origin, direction)
    runs = [acceptance.nearest(cand, None, None, box, rays=rays, screen=(screen, bbox, dilate), runs=False,
                               traced=traced) for traced in (True, False)]
    assert np.array_equal(runs[0][0], runs[1][0]) and np.array_equal(runs[0][1], runs[1][1])
    assert (runs[0][0] >= 0).sum() > 50
    rows = np.clip(bbox[:, 1], 0, h) - np.clip(bbox[:, 0], 0, h)
    cols = np.clip(bbox[:, 3], c0, c0 + w) - np.clip(bbox[:, 2], c0, c0 + w)
    per_pixel = np.sum(np.maximum(rows, 0) * np.maximum(cols, 0)) / valid.sum()
    assert acceptance._trace_pays(valid, bbox, h, c0, c0 + w, real, None) == (per_pixel > constants.EXACT_TRACE_COVER)
    crowded = np.repeat(bbox, int(constants.EXACT_TRACE_COVER / per_pixel) + 1, axis=0)
    assert acceptance._trace_pays(valid, crowded, h, c0, c0 + w, real, None)
    assert not acceptance._trace_pays(valid, bbox[:1], h, c0, c0 + w, real, None)


def test_leaf_boxes_widened_by_the_largest_coordinate():
    """``leaf_boxes`` then ``widen``: each leaf's box is its triangles' coordinates' bounds widened
    by the margin of the largest |coordinate| (NumPy's), and ``widen`` returns that coordinate;
    a value that is not finite (inf or NaN, in any leaf) gives NaN."""
    from refsoft._parallel import parallel_range

    rng = np.random.default_rng(7)
    real = rng.uniform(-3, 5, (501, 3, 3))
    bbox = rng.integers(0, 50, (501, 4)).astype(np.int64)
    n = -(-len(real) // _traced.LEAF)
    boxes, rects = np.empty((n, 6)), np.empty((n, 4), np.int64)
    parallel_range(_traced.leaf_boxes, n, real, bbox, boxes, rects)
    fraction = 1e-9
    assert _traced.widen(n, boxes, fraction) == np.abs(real).max()
    margin = fraction * (np.abs(real).max() + 1.0)
    padded = np.concatenate([real, np.full((n * _traced.LEAF - len(real), 3, 3), np.nan)]).reshape(n, -1, 3)
    assert np.array_equal(boxes[:, :3], np.nanmin(padded, axis=1) - margin)
    assert np.array_equal(boxes[:, 3:], np.nanmax(padded, axis=1) + margin)
    for bad in (np.inf, -np.inf, np.nan):
        real[3, 2, 1] = bad
        parallel_range(_traced.leaf_boxes, n, real, bbox, boxes, rects)
        assert np.isnan(_traced.widen(n, boxes, fraction))
