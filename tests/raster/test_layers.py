"""The two nearest fragments of each pixel (the G-buffer's depth margin) against the NumPy
reference in tests/naive.py, and the winner against the rasterizer itself."""

import numpy as np
import pytest

from naive import naive_depth_layers, naive_interpolate
from refsoft import Camera, raster
from refsoft.errors import RefsoftError
from refsoft.raster import _setup
from refsoft.scene.primitives import icosphere

CAMERAS = {
    "perspective": Camera(eye=(0, 0, 0), target=(0, 0, -1), width=64, height=48, fov_y=60, near=0.5, far=20),
    "orthographic": Camera(eye=(0, 0, 3), target=(0, 0, -1), width=56, height=56, projection="orthographic",
                           ortho_height=6.0, near=0.1, far=20),
}


def overlapping_soup(rng, n):
    """Random overlapping triangles around the view direction, some crossing the near plane,
    and every fifth one drawn twice (exact depth ties, which the first drawn wins)."""
    centres = np.c_[rng.uniform(-2.0, 2.0, (n, 2)), rng.uniform(-6.0, 0.5, n)]
    tris = centres[:, None, :] + rng.normal(0, 0.9, (n, 3, 3))
    tris = np.concatenate([tris, tris[::5]])
    return tris.reshape(-1, 3), np.arange(3 * len(tris)).reshape(-1, 3)


@pytest.mark.parametrize("kind", sorted(CAMERAS))
def test_two_nearest_fragments_match_the_reference(kind):
    cam = CAMERAS[kind]
    verts, faces = overlapping_soup(np.random.default_rng(3), 40)
    clip = _setup.transform_points(verts, cam.view_proj())
    lay = raster.depth_layers(clip, faces, cam.width, cam.height)
    depth, face, _, depth2, face2, _, _ = naive_depth_layers(clip, faces, cam.width, cam.height)
    np.testing.assert_array_equal(lay.depth, depth)
    np.testing.assert_array_equal(lay.triangle, face)
    np.testing.assert_array_equal(lay.second_depth, depth2)
    np.testing.assert_array_equal(lay.second_triangle, face2)
    # the winner is the rasterizer's, bit for bit
    frags = raster.rasterize(clip, faces, cam.width, cam.height)
    np.testing.assert_array_equal(lay.depth, frags.depth)
    np.testing.assert_array_equal(lay.index, frags.index)
    m = lay.margin
    assert (m == 0).sum() > 50 and (np.isfinite(m) & (m > 0)).sum() > 200  # exact ties and ordinary overlaps
    assert np.all(np.isinf(m[lay.index < 0])) and np.all(m[np.isfinite(m)] >= 0)


def test_gbuffer_second_fragment_matches_the_reference():
    cam = Camera(eye=(0.3, 0.2, 4.0), target=(0, 0, 0), width=64, height=48, fov_y=40, near=0.5, far=20)
    mesh = icosphere(2, 1.0)
    origin = np.asarray(cam.eye, dtype=np.float64)
    sec = raster.gbuffer_layers(mesh, cam.view_proj(), cam.width, cam.height, "float32", origin)
    gb = raster.gbuffer(mesh, cam, "float32", origin=origin)
    np.testing.assert_array_equal(sec.first_triangle, gb.triangle)
    clip = _setup.transform_points(mesh.vertices, cam.view_proj())
    depth, _, _, depth2, face2, which2, tris = naive_depth_layers(clip, mesh.faces, cam.width, cam.height)
    np.testing.assert_array_equal(sec.triangle, face2)
    np.testing.assert_array_equal(sec.margin, np.where(gb.mask, depth2 - depth, np.inf).astype(np.float32))
    # a closed sphere: behind every covered pixel lies its back face
    assert np.isfinite(sec.margin[gb.mask]).mean() > 0.95 and sec.margin[gb.mask].min() < 1e-3
    np.testing.assert_array_equal(sec.position, naive_interpolate(which2, tris, mesh.vertices - origin, mesh.faces,
                                                                  np.float32))
    np.testing.assert_array_equal(sec.normal, naive_interpolate(which2, tris, mesh.normals, mesh.faces, np.float32,
                                                                normalize=True))
    # the crop changes nothing
    lay = raster.depth_layers(clip, mesh.faces, cam.width, cam.height, region=(10, 40, 12, 50))
    np.testing.assert_array_equal(lay.second_depth, depth2[10:40, 12:50])
    assert lay.origin == (10, 12)


def test_bad_input_is_refused():
    cam = CAMERAS["perspective"]
    mesh = icosphere(1, 1.0)
    clip = _setup.transform_points(mesh.vertices, cam.view_proj())
    with pytest.raises(RefsoftError, match="region"):
        raster.depth_layers(clip, mesh.faces, 64, 48, region=(0, 49, 0, 10))
    with pytest.raises(RefsoftError, match="clip coordinates"):
        raster.depth_layers(clip[:, :3], mesh.faces, 64, 48)
    with pytest.raises(RefsoftError, match="view_proj"):
        raster.gbuffer_layers(mesh, np.eye(3), 64, 48)
    with pytest.raises(RefsoftError, match="origin"):
        raster.gbuffer_layers(mesh, cam.view_proj(), 64, 48, origin=(0, np.nan, 0))
