"""The shading passes (refsoft.raster.shade_fragments, refsoft.raster.shade) and the 8-bit
conversion against the plain per-pixel references in tests/naive.py, bit for bit."""

import numpy as np
from naive import naive_object_ids, naive_shade, naive_to_uint8

from refsoft import constants, raster


def _normals(rng, h, w):
    n = rng.normal(size=(h, w, 3)).astype(np.float32)
    n /= np.linalg.norm(n, axis=2, keepdims=True)
    n[0, :3] = 0.0  # zero normals: ambient only
    n[1, 0] = [1.0, 0.0, 0.0]
    n[1, 1] = -constants.LIGHT_DIRECTION.astype(np.float32)  # facing away: two-sided
    return n


def _scene(rng, n_objects=4, per_object=6, size=(40, 48)):
    """Random overlapping triangles of a few objects in front of a camera (clip coordinates with
    w in [1, 3]) with unit normals, and a nearest triangle 0 over the middle whose vertex
    normals are zero (ambient only)."""
    h, w = size
    n = n_objects * per_object * 3
    ndc = rng.uniform(-1.2, 1.2, (n, 2))
    wv = rng.uniform(1.0, 3.0, n)
    clip = np.c_[ndc * wv[:, None], rng.uniform(-0.9, 0.9, n) * wv, wv]
    faces = np.arange(n, dtype=np.int64).reshape(-1, 3)
    normals = rng.normal(size=(n, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    clip[:3] = [[-0.5, -0.5, -0.99, 1.0], [0.5, -0.5, -0.99, 1.0], [0.0, 0.5, -0.99, 1.0]]
    normals[:3] = 0.0
    sizes = [per_object] * n_objects
    face_offset = np.cumsum([0] + sizes).astype(np.int64)
    face_object = np.repeat(np.arange(1, n_objects + 1, dtype=np.int32), sizes)
    table = rng.uniform(0.0, 1.0, (n_objects + 1, 3)).astype(np.float32)
    return clip, faces, normals, face_object, face_offset, table, w, h


def test_shade_fragments_equals_interpolate_then_the_per_pixel_reference(rng):
    clip, faces, normals, face_object, face_offset, table, w, h = _scene(rng)
    light = constants.LIGHT_DIRECTION.astype(np.float32)
    ambient, diffuse = np.float32(constants.AMBIENT), np.float32(constants.DIFFUSE)
    for region in (None, (5, 33, 7, 41)):
        frags = raster.rasterize(clip, faces, w, h, region=region)
        nrm = raster.interpolate(frags, normals, faces, np.float32, normalize=True)
        exp_ids, exp_local = naive_object_ids(frags.triangle, face_offset)
        expected = naive_shade(nrm, exp_ids, table, light, ambient, diffuse)
        color, ids, local = raster.shade_fragments(frags, normals, faces, face_object, face_offset, table)
        assert 0 < (ids > 0).sum() < ids.size and len(np.unique(ids)) == len(table)
        assert (frags.triangle == 0).sum() > 20  # zero normals: ambient only
        assert np.all(expected[frags.triangle == 0] == table[1] * ambient)
        np.testing.assert_array_equal(color, expected)
        np.testing.assert_array_equal(ids, exp_ids)
        np.testing.assert_array_equal(local, exp_local)
        # a stencil: its pixels as above, the others as if nothing were drawn
        stencil = rng.uniform(size=ids.shape) < 0.5
        color_s, ids_s, local_s = raster.shade_fragments(frags, normals, faces, face_object, face_offset, table,
                                                         stencil)
        np.testing.assert_array_equal(color_s, np.where(stencil[..., None], expected, table[0]))
        np.testing.assert_array_equal(ids_s, np.where(stencil, exp_ids, 0))
        np.testing.assert_array_equal(local_s, np.where(stencil, exp_local, -1))


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


def test_to_uint8_equals_the_reference(rng):
    for dtype in (np.float32, np.float64):
        c = rng.uniform(-0.1, 1.1, (5, 7, 3)).astype(dtype)
        c[0, :, 0] = (np.arange(7) + 0.5) / 255  # ties: half to even
        c[1, 0] = [np.nan, np.inf, -np.inf]
        np.testing.assert_array_equal(raster.to_uint8(c), naive_to_uint8(c))
