"""The fast rasterizer against the slow NumPy reference in tests/naive.py."""

import numpy as np
import pytest

from naive import naive_interpolate, naive_rasterize
import refsoft
from refsoft import Camera, raster
from refsoft.raster import _setup


def random_soup(rng, n_tris, spread=2.5, depth_range=(-6.0, 1.0)):
    """Random triangles in front of, around and behind a camera at the origin looking down -z."""
    centres = np.c_[rng.uniform(-spread, spread, (n_tris, 2)), rng.uniform(*depth_range, n_tris)]
    verts = (centres[:, None, :] + rng.normal(0, 0.8, (n_tris, 3, 3))).reshape(-1, 3)
    faces = np.arange(3 * n_tris).reshape(-1, 3)
    return verts, faces


CAMERAS = {
    "perspective": Camera(eye=(0, 0, 0), target=(0, 0, -1), width=96, height=64, fov_y=60, near=0.5, far=20),
    "orthographic": Camera(eye=(0, 0, 3), target=(0, 0, -1), width=80, height=80, projection="orthographic",
                           ortho_height=6.0, near=0.1, far=20),
}


@pytest.mark.parametrize("kind", sorted(CAMERAS))
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_coverage_depth_and_ids_bit_identical(kind, seed):
    rng = np.random.default_rng(seed)
    cam = CAMERAS[kind]
    verts, faces = random_soup(rng, 60)
    clip = _setup.transform_points(verts, cam.view_proj())
    frags = raster.rasterize(clip, faces, cam.width, cam.height)
    depth, face, which, tris = naive_rasterize(clip, faces, cam.width, cam.height)
    assert frags.mask.sum() > 0.2 * frags.mask.size  # the case is not trivial
    np.testing.assert_array_equal(frags.triangle, face)
    np.testing.assert_array_equal(frags.depth, depth)
    # clipping happened in the perspective case (triangles cross the near plane)
    if kind == "perspective":
        assert len(tris) > len(faces) * 0.7 and any(not np.allclose(t["B"], np.eye(3)) for t in tris)


@pytest.mark.parametrize("precision", [np.float32, np.float64])
def test_interpolation_matches_reference_exactly(precision):
    rng = np.random.default_rng(7)
    cam = CAMERAS["perspective"]
    verts, faces = random_soup(rng, 40)
    attrs = np.c_[verts, rng.normal(size=(len(verts), 2))]
    clip = _setup.transform_points(verts, cam.view_proj())
    frags = raster.rasterize(clip, faces, cam.width, cam.height)
    _, _, which, tris = naive_rasterize(clip, faces, cam.width, cam.height)
    for normalize in (False, True):
        fast = raster.interpolate(frags, attrs, faces, precision, normalize=normalize)
        slow = naive_interpolate(which, tris, attrs, faces, precision, normalize=normalize)
        assert fast.dtype == precision
        # Same formula, same order, same precision: the results are bit-identical.
        np.testing.assert_array_equal(fast, slow)


def test_float32_path_computes_in_float32():
    """The float32 interpolation differs from a float64 computation rounded to float32."""
    rng = np.random.default_rng(11)
    cam = CAMERAS["perspective"]
    verts, faces = random_soup(rng, 40)
    attrs = verts * 1000.0 + 0.123456789
    clip = _setup.transform_points(verts, cam.view_proj())
    frags = raster.rasterize(clip, faces, cam.width, cam.height)
    f32 = raster.interpolate(frags, attrs, faces, np.float32)
    f64 = raster.interpolate(frags, attrs, faces, np.float64).astype(np.float32)
    m = frags.mask
    assert np.mean(f32[m] != f64[m]) > 0.05


def test_depth_peeling_matches_reference():
    rng = np.random.default_rng(5)
    cam = CAMERAS["perspective"]
    verts, faces = random_soup(rng, 60, depth_range=(-8, -2))
    clip = _setup.transform_points(verts, cam.view_proj())
    first = raster.rasterize(clip, faces, cam.width, cam.height)
    second = raster.rasterize(clip, faces, cam.width, cam.height, peel_depth=first.depth)
    d2, f2, _, _ = naive_rasterize(clip, faces, cam.width, cam.height, peel=first.depth)
    np.testing.assert_array_equal(second.triangle, f2)
    np.testing.assert_array_equal(second.depth, d2)
    both = first.mask & second.mask
    assert both.sum() > 100
    assert np.all(second.depth[both] > first.depth[both])


@pytest.mark.parametrize("precision", ["float32", "float64"])
def test_gbuffer_fused_pass_equals_separate_interpolation(precision):
    from refsoft import Mesh

    rng = np.random.default_rng(9)
    cam = CAMERAS["perspective"]
    verts, faces = random_soup(rng, 50)
    normals = rng.normal(size=verts.shape)
    mesh = Mesh(verts, faces, normals)
    gb = raster.gbuffer(mesh, cam, precision)
    clip = _setup.transform_points(verts, cam.view_proj())
    _, face, which, tris = naive_rasterize(clip, faces, cam.width, cam.height)
    dt = np.dtype(precision).type
    np.testing.assert_array_equal(gb.triangle, face)
    np.testing.assert_array_equal(gb.position, naive_interpolate(which, tris, mesh.vertices, faces, dt))
    np.testing.assert_array_equal(gb.normal, naive_interpolate(which, tris, mesh.normals, faces, dt, True))


@pytest.mark.parametrize("region", [(10, 50, 20, 90), (0, 64, 0, 96), (33, 34, 7, 8), (0, 17, 80, 96)])
def test_region_equals_the_cropped_full_raster(region):
    rng = np.random.default_rng(21)
    cam = CAMERAS["perspective"]
    verts, faces = random_soup(rng, 60)
    clip = _setup.transform_points(verts, cam.view_proj())
    full = raster.rasterize(clip, faces, cam.width, cam.height)
    part = raster.rasterize(clip, faces, cam.width, cam.height, region=region)
    r0, r1, c0, c1 = region
    np.testing.assert_array_equal(part.triangle, full.triangle[r0:r1, c0:c1])
    np.testing.assert_array_equal(part.depth, full.depth[r0:r1, c0:c1])
    attrs = np.c_[verts, rng.normal(size=(len(verts), 2))]
    for normalize in (False, True):
        np.testing.assert_array_equal(raster.interpolate(part, attrs, faces, normalize=normalize),
                                      raster.interpolate(full, attrs, faces, normalize=normalize)[r0:r1, c0:c1])
    with pytest.raises(refsoft.RefsoftError, match="region"):
        raster.rasterize(clip, faces, cam.width, cam.height, region=(5, 5, 0, 10))
