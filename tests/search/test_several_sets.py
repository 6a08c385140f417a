"""The sets of pair keys of the drawing of every image (refsoft/search/several.py): distinct values
by a sort, unions by a merge, edges by their keys; the same arrays as NumPy's set functions."""

import numpy as np

from refsoft.search import several


def test_sorted_unique_and_union_are_numpys(rng):
    for n in (0, 1, 2, 7, 5000):
        a = rng.integers(0, 50 if n < 100 else 1 << 40, n).astype(np.int64)
        a = np.concatenate([a, a[: n // 3]])
        got = several._sorted_unique(a)
        assert got.dtype == np.int64 and np.array_equal(got, np.unique(a))
        assert np.array_equal(several._sorted_unique(a.reshape(-1, 1)), np.unique(a))
        for m in (0, 1, 300):
            b = rng.integers(0, 1 << 40, m).astype(np.int64)
            b = np.concatenate([b, a[:5], b[:2]])
            u = several._union(np.unique(a), b)
            assert u.dtype == np.int64 and np.array_equal(u, np.union1d(a, b))


def test_edges_are_the_sorted_distinct_edges(rng):
    faces = rng.integers(0, 40, (200, 3)).astype(np.int64)
    faces[5] = [3, 3, 7]  # a degenerate face: edge (3, 3)
    e = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    got = several._edges(faces)
    assert got.dtype == np.int64 and np.array_equal(got, np.unique(e, axis=0))
    assert several._edges(np.zeros((0, 3), np.int64)).shape == (0, 2)
