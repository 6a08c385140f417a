"""Public rasterizer API: input validation, colour pass, 8-bit conversion."""

import numpy as np
import pytest

import refsoft
from refsoft import Camera, CameraError, Mesh, RefsoftError, constants, load_scene, primitives, raster
from refsoft.raster import _setup

CLIP = np.array([[-0.5, -0.5, 0, 1], [0.5, -0.5, 0, 1], [0, 0.5, 0, 1]], dtype=float)


@pytest.mark.parametrize("call, message", [
    (lambda: raster.rasterize(CLIP * np.nan, [[0, 1, 2]], 8, 8), "not finite"),
    (lambda: raster.rasterize(CLIP, [[0, 1, 3]], 8, 8), r"face indices must be in \[0, 2\]"),
    (lambda: raster.rasterize(CLIP, [[0, 1]], 8, 8), r"shape \(F, 3\)"),
    (lambda: raster.rasterize(CLIP[:, :3], [[0, 1, 2]], 8, 8), r"shape \(V, 4\)"),
    (lambda: raster.rasterize(CLIP, [[0, 1, 2]], 0, 8), "width must be positive"),
    (lambda: raster.rasterize(CLIP, [[0, 1, 2]], 8, 8, peel_depth=np.zeros((4, 4))), "peel_depth"),
    (lambda: raster.gbuffer("mesh", Camera(eye=(0, 0, 1), target=(0, 0, 0))), "refsoft.Mesh"),
    (lambda: raster.gbuffer(primitives.icosphere(1), "camera"), "refsoft.Camera"),
    (lambda: raster.gbuffer(primitives.icosphere(1), Camera(eye=(0, 0, 3), target=(0, 0, 0)), "float16"), "precision"),
    (lambda: raster.gbuffer(primitives.icosphere(1), Camera(eye=(0, 0, 3), target=(0, 0, 0)), origin=(0, np.inf, 0)), "origin"),
    (lambda: raster.color_pass([], [], Camera(eye=(0, 0, 3), target=(0, 0, 0))), "at least one mesh"),
    (lambda: raster.color_pass([primitives.icosphere(1)], [[1, 0]], Camera(eye=(0, 0, 3), target=(0, 0, 0))), "colors"),
])
def test_bad_input_raises(call, message):
    with pytest.raises(RefsoftError, match=message):
        call()


def test_interpolate_checks_attributes_against_fragments():
    frags = raster.rasterize(CLIP, [[0, 1, 2]], 8, 8)
    with pytest.raises(RefsoftError, match="attributes"):
        raster.interpolate(frags, np.zeros(3), [[0, 1, 2]])
    with pytest.raises(RefsoftError, match="do not match"):
        raster.interpolate(frags, np.zeros((3, 2)), [[0, 1, 2], [0, 1, 2]])


def test_origin_relative_positions():
    mesh = primitives.icosphere(3).transformed(np.diag([1, 1, 1, 1.0]) + np.eye(4, k=3) * 0)
    cam = Camera(eye=(0, 0, 3), target=(0, 0, 0), width=48, height=48)
    world = raster.gbuffer(mesh, cam, "float64")
    rel = raster.gbuffer(mesh, cam, "float64", origin=cam.eye)
    np.testing.assert_array_equal(world.mask, rel.mask)
    np.testing.assert_allclose(rel.position[rel.mask] + cam.eye, world.position[world.mask], atol=1e-12)
    np.testing.assert_array_equal(rel.origin, cam.eye)


def test_to_uint8_rounds_half_to_even_and_clips():
    c = np.array([-0.5, 0.0, 0.5 / 255, 1.5 / 255, 2.5 / 255, 1.0, 7.0])
    np.testing.assert_array_equal(raster.to_uint8(c), [0, 0, 0, 2, 2, 255, 255])


def test_to_uint8_kernel_equals_the_numpy_formula_bit_for_bit(rng):
    for dtype in (np.float32, np.float64):
        c = rng.uniform(-0.2, 1.2, (37, 41, 3)).astype(dtype)
        c[0, :, 0] = (np.arange(41) + 0.5) / 255  # exact ties
        c[1, 0] = np.nan
        expected = np.rint(np.clip(c.astype(np.float64), 0.0, 1.0) * 255.0)
        got = raster.to_uint8(c)
        assert got.dtype == np.uint8 and got.shape == c.shape
        ok = np.isfinite(c)
        np.testing.assert_array_equal(got[ok], expected[ok].astype(np.uint8))
        assert np.all(got[~ok] == 0)


def test_color_pass_shading_kernel_equals_numpy_shade():
    s = load_scene("sphere", width=96, height=72)
    meshes = [s.world_mesh(i + 1) for i in range(len(s.objects))]
    colors = np.array([o.color for o in s.objects])
    cp = raster.color_pass(meshes, colors, s.camera)
    # the same normals, shaded by the NumPy formula
    verts = np.concatenate([m.vertices for m in meshes])
    norms = np.concatenate([m.normals for m in meshes])
    offs = np.cumsum([0] + [m.n_vertices for m in meshes])
    faces = np.concatenate([m.faces.astype(np.int64) + offs[i] for i, m in enumerate(meshes)])
    frags = raster.rasterize(_setup.transform_points(verts, s.camera.view_proj()), faces, 96, 72)
    nrm = raster.interpolate(frags, norms, faces, np.float32, normalize=True)
    table = np.vstack([constants.BACKGROUND_COLOR, colors]).astype(np.float32)
    expected = raster.shade(nrm, table[cp.object_id])
    expected[cp.object_id == 0] = table[0]
    np.testing.assert_array_equal(cp.color, expected)


def test_color_pass_ids_depth_order_and_shading():
    s = load_scene("sphere", width=160, height=120)
    meshes = [s.world_mesh(i + 1) for i in range(len(s.objects))]
    colors = np.array([o.color for o in s.objects])
    cp = raster.color_pass(meshes, colors, s.camera)
    assert cp.image.dtype == np.uint8 and cp.object_id.dtype == np.int32
    assert set(np.unique(cp.object_id)) == {1, 2, 3, 4, 5, 6}
    # object ids agree with per-object depth: the visible object is the nearest one
    depths = np.stack([raster.rasterize(_setup.transform_points(m.vertices, s.camera.view_proj()), m.faces,
                                        160, 120).depth for m in meshes])
    nearest = np.where(depths.min(axis=0) < 1.0, np.argmin(depths, axis=0) + 1, 0)
    agree = nearest == cp.object_id
    assert agree.mean() > 0.999  # ties between objects at equal depth go to the first drawn
    np.testing.assert_array_equal(cp.depth, depths.min(axis=0))
    # shading formula at the ball's pixels
    gb = raster.gbuffer(meshes[0], s.camera)
    ball = cp.object_id == 1
    lam = np.abs(gb.normal[ball] @ constants.LIGHT_DIRECTION.astype(np.float32))
    expected = colors[0] * (constants.AMBIENT + constants.DIFFUSE * lam[:, None])
    np.testing.assert_allclose(cp.color[ball], expected, atol=1e-6)
    np.testing.assert_array_equal(cp.image, raster.to_uint8(cp.color))
    assert np.all(cp.triangle[cp.object_id == 0] == -1)
    assert np.all(cp.triangle[ball] == gb.triangle[ball])


def test_degenerate_meshes_and_empty_views_do_not_crash():
    cam = Camera(eye=(0, 0, 3), target=(0, 0, 0), width=32, height=32)
    flat = Mesh([[0, 0, 0], [0, 0, 0], [0, 0, 0]], [[0, 1, 2]])
    gb = raster.gbuffer(flat, cam)
    assert not gb.mask.any() and np.all(np.isfinite(gb.position))
    behind = primitives.icosphere(2).transformed(np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 10], [0, 0, 0, 1.0]]))
    assert not raster.gbuffer(behind, cam).mask.any()
    with pytest.raises(CameraError):
        Camera(eye=(0, 0, 3), target=(0, 0, 3))


@pytest.mark.parametrize("name", ["sphere", "planar", "kitchen", "ants", "concave"])
@pytest.mark.parametrize("precision", ["float32", "float64"])
def test_cropped_gbuffer_equals_the_full_one(name, precision):
    """The G-buffer rasterized over the reflector's projected box equals the whole view's, bit
    for bit, for mirrors wholly in view, cut by the border, and tiny (the ants' eyes)."""
    scene = refsoft.load_scene(name, width=96, height=72)
    for frame in (0, scene.n_frames - 1):
        cam = scene.camera_at(frame)
        for k in scene.reflector_ids:
            mesh = scene.world_mesh(k, frame, proxy=True)
            a = raster.gbuffer(mesh, cam, precision, origin=cam.eye)
            b = raster.gbuffer(mesh, cam, precision, origin=cam.eye, crop=False)
            for field in ("position", "normal", "mask", "depth", "triangle"):
                np.testing.assert_array_equal(getattr(a, field), getattr(b, field), err_msg=f"{name} {k} {field}")


def test_coverage_region_cases():
    from refsoft.raster import coverage_region

    inside = np.array([[0.0, 0.0, 0.5, 1.0], [0.5, 0.5, 0.5, 1.0], [0.0, 0.5, 0.5, 1.0]])
    r = coverage_region(inside, 64, 48)
    assert r[0] <= 12 and r[1] >= 24 and r[2] <= 32 and r[3] >= 48  # contains x 32-48, rows 12-24
    assert coverage_region(inside + [3.0, 0, 0, 0], 64, 48) == ()  # wholly right of the view
    assert coverage_region(np.array([[0.0, 0.0, -2.0, 1.0]] * 3), 64, 48) is None  # before the near plane
    assert coverage_region(np.array([[0.0, 0.0, 0.5, -1.0]] * 3), 64, 48) is None  # behind the eye
