"""The candidates' own acceptance loop (``_several.accept_untracked``): the narrowing of a row's
columns to those an edge test admits, and the tests it leaves out where a pixel's best hit is
already nearer than a candidate can be, against plain references."""

import numpy as np
import pytest

from refsoft import constants
from refsoft._parallel import one_thread, parallel_range
from refsoft.search import acceptance
from refsoft.search._several import ALONG, LOOSE, _edge, _narrow_row, _nearest_reach, accept_untracked

import naive_several_pool


def _passing(col0, col1, y, ax, ay, bx, by, sign, limit):
    """The columns of col0 .. col1 - 1 passing the edge test, each tested (plain Python)."""
    return [col for col in range(col0, col1)
            if not sign * ((bx - ax) * (y - ay) - (by - ay) * ((col + 0.5) - ax)) < limit]


def _edges(rng, n):
    """Edges of every kind: ordinary, nearly along the row, along the column, far outside the
    range, with huge coordinates and with huge limits."""
    out = []
    for i in range(n):
        ax, ay, bx, by = rng.uniform(-50, 250, 4)
        kind = i % 6
        if kind == 1:
            by = ay + rng.choice([1e-9, -1e-9, 1e-300, 5e-324, 0.0])
        elif kind == 2:
            bx = ax
        elif kind == 3:
            ax, bx = ax + 1e6, bx - 1e6
        elif kind == 4:
            ax, ay, bx, by = rng.uniform(-1e90, 1e90, 4) * rng.choice([1.0, 1e20])
        limit = rng.choice([-rng.uniform(0, 50), 0.0, rng.uniform(0, 50), -1e120 if kind == 5 else -3.0])
        out.append((ax, ay, bx, by, rng.choice([-1.0, 1.0]), limit))
    return out


def test_narrowing_keeps_exactly_the_columns_an_edge_admits():
    """The estimated-then-corrected narrowing gives the prefix or suffix of columns that pass the
    edge's own test, checked column by column, on every kind of edge; an edge along the rows keeps
    all or none; one with values too large to narrow keeps every column (the caller then tests
    each)."""
    rng = np.random.default_rng(7)
    kinds = {LOOSE: 0, ALONG: 0, "narrowed": 0, "exact": 0}
    for ax, ay, bx, by, sign, limit in _edges(rng, 600):
        col0 = int(rng.integers(-20, 150))
        col1 = col0 + int(rng.integers(0, 120))
        y = float(rng.integers(-10, 200)) + 0.5
        kind, a, b = _edge(ax, ay, bx, by, sign, limit)
        lo, hi = _narrow_row(kind, a, b, col0, col1, y, ax, ay, bx, by, sign, limit)
        want = _passing(col0, col1, y, ax, ay, bx, by, sign, limit)
        if max(abs(ax), abs(ay), abs(bx), abs(by), abs(limit)) >= 1e100:
            assert kind == LOOSE and (lo, hi) == (col0, col1)
            kinds[LOOSE] += 1
            continue
        assert list(range(lo, hi)) == want, (ax, ay, bx, by, sign, limit, col0, col1, y)
        if by - ay == 0.0:
            assert kind == ALONG and want in ([], list(range(col0, col1)))
            kinds[ALONG] += 1
            continue
        kinds["exact"] += 1
        kinds["narrowed"] += len(want) < col1 - col0
    assert kinds["exact"] > 300 and kinds["narrowed"] > 150 and kinds[LOOSE] > 50 and kinds[ALONG] > 50


def test_nearest_reach_bounds_every_hit():
    """No ray from the origins' box meets a triangle at a ``t`` below its bound: random rays
    (directions of any length) against random triangles, every hit Moller-Trumbore finds."""
    from refsoft.raster.rays import ray_triangle

    rng = np.random.default_rng(11)
    origin = rng.uniform([-1, -1, 1], [1, 1, 2], (400, 3))
    direction = rng.normal(0, 1, (400, 3)) * rng.uniform(0.2, 3.0, (400, 1))
    bounds = np.concatenate([origin.min(0), origin.max(0), [np.sqrt((direction ** 2).sum(1)).max()]])
    real = rng.uniform(-4, 4, (60, 3, 3))
    hits = 0
    for c in range(len(real)):
        near = _nearest_reach(real, c, bounds)
        a, b, cc = (np.broadcast_to(real[c, k], origin.shape) for k in range(3))
        t, bary = ray_triangle(origin, direction, a, b, cc)
        inside = (bary >= 0).all(1) & (t > 0)
        hits += inside.sum()
        assert np.all(t[inside] >= near)
    assert hits > 100
    # a triangle whose box overlaps the origins' is never left out
    assert _nearest_reach(np.array([[[0.0, 0.0, 1.5], [1.0, 0.0, 1.5], [0.0, 1.0, 1.5]]]), 0, bounds) == 0.0
    # a value that is not finite leaves nothing out
    assert _nearest_reach(np.array([[[np.nan, 0.0, 9.0], [1.0, 0.0, 9.0], [0.0, 1.0, 9.0]]]), 0, bounds) == 0.0


def test_layers_far_behind_are_left_out_with_the_same_winners():
    """Layers of triangles one behind the other, the nearest first or last: the loop gives the
    plain pixel-by-candidate loop's winners bit for bit on one thread and several, and the layers
    behind are left untested (their bound exceeds the best hit at most of their pixels)."""
    rng = np.random.default_rng(5)
    h, w, r0, c0 = 12, 16, 3, 4
    valid = rng.random((h, w)) < 0.9
    origin = np.concatenate([rng.uniform(-1, 1, (h, w, 2)), np.full((h, w, 1), 2.0)], axis=2)
    direction = np.concatenate([rng.normal(0, 0.05, (h, w, 2)), np.full((h, w, 1), -1.0)], axis=2)
    layers = []
    for z in (1.0, -1.0, -3.0, -5.0):  # big triangles covering the rays, at four depths
        layers.append([[-9.0, -9.0, z], [9.0, -9.0, z], [0.0, 9.0, z]])
    real = np.array(layers + layers[::-1], dtype=np.float64)
    n = len(real)
    screen = np.tile(np.array([[c0 - 5.0, r0 - 5.0], [c0 + w + 5.0, r0 - 5.0], [c0 + w / 2, r0 + h + 5.0]]), (n, 1, 1))
    dilate = np.full(n, -1.0)  # each tested over its whole bounds
    bbox = np.tile(np.array([0, h, c0, c0 + w], np.int64), (n, 1))
    want = naive_several_pool.accept(r0, c0, valid, origin, direction, screen, bbox, dilate, real)
    assert (want[1] == 0).sum() == valid.sum()  # the nearest layer, first in order, wins everywhere
    bounds = acceptance._ray_bounds(valid, origin, direction)
    left_out = sum(_nearest_reach(real, c, bounds) > 1.0 + constants.EXACT_TRACE_MARGIN * 2.0 for c in range(n))
    assert left_out >= 4  # the layers at -3 and -5 (both copies) cannot beat t = 1 anywhere
    for threads in (True, False):
        got = (np.full((h, w), np.inf), np.full((h, w), -1, np.int64), np.zeros((h, w, 2)))
        args = (accept_untracked, h, r0, c0, valid, acceptance._spans(valid), origin, direction, screen, bbox, dilate,
                real, bounds, constants.EXACT_TRACE_MARGIN, *got)
        with one_thread(not threads):
            parallel_range(*args)
        for a, b in zip(got, want[:3]):
            assert np.array_equal(a, b)


@pytest.mark.parametrize("rows", [1, 5])
def test_ray_bounds_are_the_valid_rays_box(rows):
    """The per-row kernel's bounds, taken over the rows, are NumPy's over the valid rays."""
    rng = np.random.default_rng(rows)
    valid = rng.random((rows, 9)) < 0.6
    valid[0, 0] = True
    origin, direction = rng.normal(0, 3, (rows, 9, 3)), rng.normal(0, 2, (rows, 9, 3))
    got = acceptance._ray_bounds(valid, origin, direction)
    o, d = origin[valid], direction[valid]
    want = np.concatenate([o.min(0), o.max(0), [np.sqrt(((d * d).sum(1))).max()]])
    assert np.allclose(got, want, rtol=1e-15, atol=0) and np.array_equal(got[:6], want[:6])


def test_bounds_area_is_numpys_clipped_sum():
    """The pixels the candidates' bounds cover in the box, against NumPy's clipped products:
    bounds inside, across and outside the box, empty and reversed ones."""
    from refsoft.search._several import bounds_area

    rng = np.random.default_rng(9)
    h, c0, c1 = 40, 100, 180
    lo = rng.integers(-30, 70, (500, 2))
    bbox = np.stack([lo[:, 0], lo[:, 0] + rng.integers(-5, 60, 500), lo[:, 1] + 80,
                     lo[:, 1] + 80 + rng.integers(-5, 90, 500)], axis=1).astype(np.int64)
    rows = np.clip(bbox[:, 1], 0, h) - np.clip(bbox[:, 0], 0, h)
    cols = np.clip(bbox[:, 3], c0, c1) - np.clip(bbox[:, 2], c0, c1)
    want = float(np.sum(np.maximum(rows, 0) * np.maximum(cols, 0)))
    assert want > 0 and ((rows <= 0) | (cols <= 0)).any()
    assert bounds_area(bbox, h, c0, c1) == want
    assert bounds_area(bbox[:0], h, c0, c1) == 0.0
