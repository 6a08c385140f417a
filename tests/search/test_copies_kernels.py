"""The kernels of the exact drawing's second candidates (refsoft/search/_exact.py ``touching`` and
``interleave``, called by refsoft/search/virtual.py ``with_mirror_copies``) against NumPy's
indexing, on one thread and on several."""

import numpy as np

from refsoft._parallel import one_thread, parallel_range
from refsoft.search._exact import interleave, touching


def test_touching_marks_the_faces_with_a_twin_or_an_edge_corner(rng):
    n, m = 400, 3000
    faces = rng.integers(0, n, (m, 3)).astype(np.int64)
    twin = np.arange(n, dtype=np.int64)
    rows = np.sort(rng.choice(n, 25, replace=False))
    twin[rows] = n + np.arange(25)
    edge = rng.random(n) < 0.02
    want_copied = np.any((twin >= n)[faces], axis=1)
    want_near = np.any(edge[faces], axis=1)
    assert 0 < want_copied.sum() < m and 0 < want_near.sum() < m
    for several in (True, False):
        copied, near = np.ones(m, bool), np.ones(m, bool)
        with one_thread(not several):
            parallel_range(touching, m, faces, twin, n, edge, copied, near)
        np.testing.assert_array_equal(copied, want_copied)
        np.testing.assert_array_equal(near, want_near)


def test_interleave_puts_each_copy_right_after_its_face(rng):
    n, m = 200, 1000
    faces = rng.integers(0, n, (m, 3)).astype(np.int64)
    face_obj = rng.integers(1, 7, m).astype(np.int32)
    twin = np.arange(n, dtype=np.int64)
    twin[::9] = n + np.arange(len(twin[::9]))
    copied = rng.random(m) < 0.3
    # NumPy: every face repeated where copied, the repeat's corners by twin
    which = np.flatnonzero(copied)
    order = np.repeat(np.arange(m), 1 + copied)
    want_faces = faces[order]
    want_faces[which + np.arange(1, len(which) + 1)] = twin[faces[which]]
    k = len(which)
    out_faces, out_obj = np.full((m + k + 5, 3), -7, np.int64), np.full(m + k + 5, -7, np.int32)
    interleave(faces, face_obj, copied, twin, out_faces, out_obj)
    np.testing.assert_array_equal(out_faces[:m + k], want_faces)
    np.testing.assert_array_equal(out_obj[:m + k], face_obj[order])
    assert np.all(out_faces[m + k:] == -7) and np.all(out_obj[m + k:] == -7)  # the rows after untouched
