import math
from dataclasses import replace

import numpy as np
import pytest

from refsoft import Camera, CameraError, LimitError


def test_view_matrix_maps_eye_to_origin_and_target_down_minus_z():
    cam = Camera(eye=(1.0, 2.0, 5.0), target=(0.0, 0.5, -1.0))
    v = cam.view_matrix()
    np.testing.assert_allclose(v @ np.r_[cam.eye, 1], [0, 0, 0, 1], atol=1e-12)
    t = v @ np.r_[cam.target, 1]
    np.testing.assert_allclose(t[:2], 0, atol=1e-12)
    assert t[2] == pytest.approx(-np.linalg.norm(cam.target - cam.eye))
    np.testing.assert_allclose(v[:3, :3] @ v[:3, :3].T, np.eye(3), atol=1e-12)  # rigid
    assert np.linalg.det(v[:3, :3]) == pytest.approx(1.0)  # right-handed


def test_perspective_matrix_is_gluPerspective():
    cam = Camera(eye=(0, 0, 0), target=(0, 0, -1), fov_y=60, width=200, height=100, near=0.5, far=10)
    p = cam.projection_matrix()
    f = 1 / math.tan(math.radians(30))
    expected = np.array([[f / 2, 0, 0, 0], [0, f, 0, 0], [0, 0, -10.5 / 9.5, -10 / 9.5], [0, 0, -1, 0]])
    np.testing.assert_allclose(p, expected, rtol=1e-14)
    # near plane maps to NDC z = -1, far to +1 (window depth 0 and 1)
    for z, ndc in ((-0.5, -1.0), (-10.0, 1.0)):
        c = p @ [0, 0, z, 1]
        assert c[2] / c[3] == pytest.approx(ndc)


def test_orthographic_matrix_is_glOrtho():
    cam = Camera(eye=(0, 0, 0), target=(0, 0, -1), width=100, height=50, projection="orthographic",
                 ortho_height=4.0, near=1.0, far=3.0)
    p = cam.projection_matrix()
    np.testing.assert_allclose(p @ [4.0, 2.0, -1.0, 1.0], [1, 1, -1, 1])
    np.testing.assert_allclose(p @ [-4.0, -2.0, -3.0, 1.0], [-1, -1, 1, 1])


def test_pixel_rays_pass_through_pixel_centres():
    cam = Camera(eye=(0.5, 1.0, 4.0), target=(0, 0, 0), width=40, height=30)
    origins, dirs = cam.pixel_rays()
    pts = origins + 3.0 * dirs
    win = cam.project(pts.reshape(-1, 3))[:, :2].reshape(30, 40, 2)
    rows, cols = np.mgrid[0:30, 0:40]
    np.testing.assert_allclose(win[..., 0], cols + 0.5, atol=1e-9)
    np.testing.assert_allclose(win[..., 1], 30 - rows - 0.5, atol=1e-9)


def test_widened_camera_same_eye_wider_fov_same_density():
    cam = Camera(eye=(0, 1, 5), target=(0, 0, 0), fov_y=40, width=320, height=240)
    wide = cam.widened(1.5)
    np.testing.assert_array_equal(wide.eye, cam.eye)
    np.testing.assert_array_equal(wide.target, cam.target)
    assert (wide.width, wide.height) == (480, 360)
    assert math.tan(math.radians(wide.fov_y / 2)) == pytest.approx(1.5 * math.tan(math.radians(20)))
    # the view's top-right pixel centre: NDC shrinks by the factor in the wide buffer
    origins, dirs = cam.pixel_rays()
    corner = origins[0, -1] + 5 * dirs[0, -1]
    x, y, _ = wide.project(corner[None])[0]
    x_ndc, y_ndc = 319.5 / 160 - 1, 239.5 / 120 - 1
    assert x == pytest.approx((x_ndc / 1.5 + 1) * 240, abs=1e-9)
    assert y == pytest.approx((y_ndc / 1.5 + 1) * 180, abs=1e-9)
    assert cam.widened(1.0) == cam.widened(1.0)
    assert cam.widened(2.0, 100, 50).width == 100


@pytest.mark.parametrize("kwargs, message", [
    (dict(eye=(0, 0, 1), target=(0, 0, 1)), "eye equals target"),
    (dict(eye=(0, 0, 0), target=(0, 5, 0)), "parallel"),
    (dict(eye=(0, 0, 0), target=(0, 0, -1), up=(0, 0, 0)), "zero vector"),
    (dict(eye=(0, 0, 0), target=(0, 0, -1), fov_y=0.0), "fov_y"),
    (dict(eye=(0, 0, 0), target=(0, 0, -1), fov_y=180.0), "fov_y"),
    (dict(eye=(0, 0, 0), target=(0, 0, -1), fov_y=-10.0), "fov_y"),
    (dict(eye=(0, 0, 0), target=(0, 0, -1), width=0), "width"),
    (dict(eye=(0, 0, 0), target=(0, 0, -1), height=-3), "height"),
    (dict(eye=(0, 0, 0), target=(0, 0, -1), width=2.5), "integer"),
    (dict(eye=(0, 0, 0), target=(0, 0, -1), near=0.0), "near"),
    (dict(eye=(0, 0, 0), target=(0, 0, -1), near=2.0, far=1.0), "near"),
    (dict(eye=(np.nan, 0, 0), target=(0, 0, -1)), "not finite"),
    (dict(eye=(0, 0, 0), target=(0, 0, -1), projection="fisheye"), "projection"),
    (dict(eye=(0, 0), target=(0, 0, -1)), "3 numbers"),
])
def test_bad_cameras_raise_clear_errors(kwargs, message):
    with pytest.raises(CameraError, match=message):
        Camera(**kwargs)


def test_absurd_resolution_is_refused_by_the_limit():
    with pytest.raises(LimitError, match="exceeds the limit"):
        Camera(eye=(0, 0, 0), target=(0, 0, -1), width=16000, height=16000)
    with pytest.raises(LimitError):
        Camera(eye=(0, 0, 0), target=(0, 0, -1), width=100000, height=1)


def test_widen_factor_validated():
    cam = Camera(eye=(0, 0, 0), target=(0, 0, -1))
    for bad in (0.5, float("nan"), float("inf"), "2"):
        with pytest.raises(CameraError, match="widen"):
            cam.widened(bad)


def test_camera_keeps_its_own_frozen_vectors_and_computes_its_matrix_once():
    eye = np.array([0.0, 1.0, 5.0])
    cam = Camera(eye=eye, target=(0, 0, 0))
    assert eye.flags.writeable and cam.eye is not eye  # the caller's array is copied, not frozen
    with pytest.raises(ValueError):
        cam.eye[0] = 3.0
    m = cam.view_proj()
    np.testing.assert_array_equal(m, cam.projection_matrix() @ cam.view_matrix())
    m[0, 0] = 99.0  # each call returns a new array
    assert cam.view_proj()[0, 0] != 99.0
    moved = replace(cam, eye=(0.0, 2.0, 5.0))  # another camera, its own matrix
    np.testing.assert_array_equal(moved.view_proj(), moved.projection_matrix() @ moved.view_matrix())
    assert not np.array_equal(moved.view_proj(), cam.view_proj())
