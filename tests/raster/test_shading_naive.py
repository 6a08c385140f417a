"""The shading kernels (refsoft.raster._shading) and refsoft.raster.shade against the plain
per-pixel references in tests/naive.py, bit for bit."""

import numpy as np
from naive import naive_object_ids, naive_shade, naive_to_uint8

from refsoft import constants, raster
from refsoft.raster import _shading


def _normals(rng, h, w):
    n = rng.normal(size=(h, w, 3)).astype(np.float32)
    n /= np.linalg.norm(n, axis=2, keepdims=True)
    n[0, :3] = 0.0  # zero normals: ambient only
    n[1, 0] = [1.0, 0.0, 0.0]
    n[1, 1] = -constants.LIGHT_DIRECTION.astype(np.float32)  # facing away: two-sided
    return n


def test_shade_ids_equals_the_per_pixel_reference(rng):
    h, w = 11, 13
    nrm = _normals(rng, h, w)
    ids = rng.integers(0, 4, (h, w)).astype(np.int32)
    ids[0, 0] = 0
    table = rng.uniform(0.0, 1.0, (4, 3)).astype(np.float32)
    light = constants.LIGHT_DIRECTION.astype(np.float32)
    ambient, diffuse = np.float32(constants.AMBIENT), np.float32(constants.DIFFUSE)
    out = np.empty((h, w, 3), dtype=np.float32)
    _shading.shade_ids(nrm, ids, table, light, ambient, diffuse, table[0], out)
    expected = naive_shade(nrm, ids, table, light, ambient, diffuse)
    assert expected[0, 0].tolist() == table[0].tolist()
    np.testing.assert_array_equal(out, expected)


def test_raster_shade_equals_the_per_pixel_reference(rng):
    h, w = 9, 7
    nrm = _normals(rng, h, w)
    colors = rng.uniform(0.0, 1.0, (h, w, 3)).astype(np.float32)
    # one object per pixel: the reference's table row k + 1 is pixel k's colour
    ids = np.arange(1, h * w + 1, dtype=np.int32).reshape(h, w)
    table = np.vstack([np.zeros((1, 3), np.float32), colors.reshape(-1, 3)])
    expected = naive_shade(nrm, ids, table, constants.LIGHT_DIRECTION, constants.AMBIENT, constants.DIFFUSE)
    got = raster.shade(nrm, colors)
    assert got.dtype == np.float32
    np.testing.assert_array_equal(got, expected)


def test_object_ids_equal_the_reference(rng):
    sizes = [3, 1, 5, 2]
    face_offset = np.cumsum([0] + sizes).astype(np.int64)
    face_object = np.repeat(np.arange(1, len(sizes) + 1, dtype=np.int32), sizes)
    triangle = rng.integers(-1, face_offset[-1], (6, 8)).astype(np.int32)
    triangle[0, :2] = [-1, face_offset[-1] - 1]
    ids = np.empty(triangle.shape, np.int32)
    local = np.empty(triangle.shape, np.int32)
    _shading.object_ids(triangle, face_object, face_offset, ids, local)
    exp_ids, exp_local = naive_object_ids(triangle, face_offset)
    assert exp_ids[0, 1] == len(sizes) and exp_local[0, 1] == sizes[-1] - 1
    np.testing.assert_array_equal(ids, exp_ids)
    np.testing.assert_array_equal(local, exp_local)


def test_to_uint8_equals_the_reference(rng):
    for dtype in (np.float32, np.float64):
        c = rng.uniform(-0.1, 1.1, (5, 7, 3)).astype(dtype)
        c[0, :, 0] = (np.arange(7) + 0.5) / 255  # ties: half to even
        c[1, 0] = [np.nan, np.inf, -np.inf]
        np.testing.assert_array_equal(raster.to_uint8(c), naive_to_uint8(c))
