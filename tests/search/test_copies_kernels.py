"""The kernels of the exact drawing's second candidates (refsoft/search/_exact.py ``mirror_marks``,
called by refsoft/search/virtual.py ``mirror_images``; ``far_apart``, ``touching`` and
``interleave``, called by ``with_mirror_copies``) against NumPy, on one thread and on several."""

import numpy as np

from refsoft._parallel import one_thread, parallel_range
from refsoft import constants
from refsoft.search import BORDER, CULLED, HIDDEN
from refsoft.search._exact import far_apart, interleave, mirror_marks, touching


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


def test_mirror_marks_are_the_rules_of_mirror_images(rng):
    """The vertices imaged again (visible, and on the outline or seen at a grazing angle) and those
    hidden at the silhouette (not CULLED, HIDDEN and BORDER, by less than the margin), as NumPy
    states them column by column, bit for bit: float32 reflection points and normals, vertices
    near the tangent plane, values that are not finite."""
    n = 3000
    vertices = rng.normal(size=(n, 3)) * 3.0
    origin = np.array([0.25, -1.5, 2.0])
    point = rng.normal(size=(n, 3)).astype(np.float32)
    normal = rng.normal(size=(n, 3))
    normal = (normal / np.linalg.norm(normal, axis=1)[:, None]).astype(np.float32)
    # a third of them close to the tangent plane, on either side
    near = rng.random(n) < 0.3
    d = vertices - origin - point
    vertices[near] -= (np.sum(d * normal, axis=1) * rng.uniform(0.8, 1.2, n))[near, None] * normal[near]
    vertices[:4, 1] = np.nan
    flags = rng.choice(np.array([0, BORDER, HIDDEN, HIDDEN | BORDER, CULLED | HIDDEN | BORDER], np.uint8), n)
    d = (vertices - origin) - point.astype(np.float64)
    nrm = normal.astype(np.float64)
    dn = (d[:, 0] * nrm[:, 0] + d[:, 1] * nrm[:, 1]) + d[:, 2] * nrm[:, 2]
    size = np.sqrt((d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1]) + d[:, 2] * d[:, 2])
    visible, border = flags & (HIDDEN | CULLED) == 0, flags & BORDER != 0
    want_twin = visible & (border | (dn < constants.EXACT_TWIN_GRAZING * size))
    want_edge = (flags & CULLED == 0) & (flags & HIDDEN != 0) & border & (-dn < constants.EXACT_TWIN_HIDDEN * size)
    grazing = visible & ~border & (dn < constants.EXACT_TWIN_GRAZING * size)
    assert grazing.sum() > 50 and 50 < want_edge.sum() < np.sum((flags & HIDDEN != 0) & border & (flags & CULLED == 0))
    for several in (True, False):
        twin, edge = np.ones(n, bool), np.ones(n, bool)
        with one_thread(not several):
            parallel_range(mirror_marks, n, vertices, origin, point, normal, flags, constants.EXACT_TWIN_GRAZING,
                           constants.EXACT_TWIN_HIDDEN, np.uint8(BORDER), np.uint8(HIDDEN), np.uint8(CULLED), twin,
                           edge)
        np.testing.assert_array_equal(twin, want_twin)
        np.testing.assert_array_equal(edge, want_edge)


def test_far_apart_is_the_screen_gap_rule(rng):
    """Two images far apart: both in front of the eye and more than the threshold apart in view
    pixels along x or y, as NumPy computes it; points at or behind the eye plane (w = 0 among
    them) never are."""
    k, width, height = 4000, 64, 48
    a = rng.normal(size=(k, 4))
    a[:, 3] = rng.uniform(-0.3, 2.0, k)
    a[:10, 3] = 0.0
    b = a + rng.normal(size=(k, 4)) * np.where(rng.random(k) < 0.5, 1e-3, 0.2)[:, None]
    scale = 0.5 * np.array([width, height], np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        gap = np.abs(a[:, :2] / a[:, 3:] - b[:, :2] / b[:, 3:]) * scale
    want = (a[:, 3] > 0) & (b[:, 3] > 0) & np.any(gap > constants.EXACT_TWIN_PIXELS, axis=1)
    assert 100 < want.sum() < k - 100
    for several in (True, False):
        far = np.zeros(k, bool)
        with one_thread(not several):
            parallel_range(far_apart, k, a, b, 0.5 * width, 0.5 * height, float(constants.EXACT_TWIN_PIXELS), far)
        np.testing.assert_array_equal(far, want)
