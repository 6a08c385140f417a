"""The frame driver and `refsoft render`: outputs, stencils, coherence, planar truth, atomicity."""

import json
import os
import signal
import subprocess
import sys
import time
from dataclasses import replace

import numpy as np
import pytest

import refsoft
from refsoft import Camera, Scene, SceneObject, Transform, primitives, raster
from refsoft.raster import _setup
from refsoft.frame import FrameDriver, RenderOptions, render
from scene_data import ANIMATED

W, H = 160, 120



@pytest.fixture
def animated(tmp_path):
    p = tmp_path / "anim.toml"
    p.write_text(ANIMATED)
    return refsoft.load_scene(p)


def test_output_keys_shapes_and_dtypes(tmp_path, animated):
    frames, stats = render(animated, frames=2, out=tmp_path)
    for f in range(2):
        with np.load(tmp_path / f"frame_{f:04d}.npz") as z:
            n = len(z["vertex_object_1"])
            expect = {"image": ((H, W, 3), np.uint8), "object_id": ((H, W), np.int32),
                      "reflected_id": ((H, W), np.int32), "gbuffer_position_1": ((H, W, 3), np.float32),
                      "gbuffer_normal_1": ((H, W, 3), np.float32), "gbuffer_mask_1": ((H, W), np.bool_),
                      "gbuffer_view_proj_1": ((4, 4), np.float64), "reflection_pixel_1": ((n, 2), np.int32),
                      "virtual_vertex_1": ((n, 3), np.float32), "iterations_1": ((n,), np.int32),
                      "flags_1": ((n,), np.uint8), "vertex_object_1": ((n,), np.int32)}
            for key, (shape, dtype) in expect.items():
                assert z[key].shape == shape and z[key].dtype == dtype, key
            assert n == sum(o.mesh.n_vertices for o in animated.objects if not o.reflector)
            assert set(np.unique(z["vertex_object_1"])) == {2, 3}
        assert (tmp_path / f"frame_{f:04d}.png").exists()
    st = json.loads((tmp_path / "stats.json").read_text())
    assert [fr["frame"] for fr in st["frames"]] == [0, 1]
    assert set(st["frames"][0]["time_ms"]) >= {"gbuffer", "search", "virtual", "main", "composite", "total"}
    assert set(st["frames"][0]["iterations"]["1"]) == {"mean", "max"}
    assert st["summary"]["max_frame_mean_iterations"] >= st["summary"]["total_mean_iterations"] > 0
    # world-space G-buffer positions (the driver interpolates them relative to the eye)
    gb = raster.gbuffer(animated.world_mesh(1, 1), animated.camera_at(1))
    with np.load(tmp_path / "frame_0001.npz") as z:
        np.testing.assert_array_equal(z["gbuffer_mask_1"], gb.mask)
        np.testing.assert_allclose(z["gbuffer_position_1"][gb.mask], gb.position[gb.mask], atol=2e-6)
        assert np.all(z["gbuffer_position_1"][~gb.mask] == 0) and np.all(z["gbuffer_normal_1"][~gb.mask] == 0)


def test_reflected_id_is_minus_one_exactly_off_reflectors(animated):
    frames, _ = render(animated, frames=1)
    a = frames[0].arrays
    on = a["object_id"] == 1
    assert np.all(a["reflected_id"][~on] == -1)
    assert np.all(a["reflected_id"][on] >= 0)
    assert set(np.unique(a["reflected_id"][on])) >= {0, 2, 3}  # sky, box and floor are reflected


def test_reruns_are_bit_identical(animated):
    a, _ = render(animated, frames=3)
    b, _ = render(animated, frames=3)
    for fa, fb in zip(a, b):
        assert fa.arrays.keys() == fb.arrays.keys()
        for k in fa.arrays:
            np.testing.assert_array_equal(fa.arrays[k], fb.arrays[k], err_msg=k)


def test_coherent_and_cold_agree_where_the_optimum_is_unique(animated):
    warm, _ = render(animated, frames=4)
    cold, _ = render(animated, frames=4, coherence=False)
    assert warm[3].arrays["iterations_1"].mean() < cold[3].arrays["iterations_1"].mean()
    for w, c in zip(warm, cold):
        pw, pc = w.arrays["reflection_pixel_1"], c.arrays["reflection_pixel_1"]
        same_score = w.arrays["score_1"] == c.arrays["score_1"]
        unique = same_score & (c.arrays["margin_1"] > 0)
        np.testing.assert_array_equal(pw[unique], pc[unique])
        # elsewhere the two searches stopped on different local maxima (different scores)
        differ = ~np.all(pw == pc, axis=1)
        assert np.all(~same_score[differ] | (c.arrays["margin_1"][differ] == 0))
        print(f"frame {w.index}: {differ.mean():.3f} of vertices end elsewhere when coherent")


def test_several_reflectors_keep_to_their_stencils():
    base = refsoft.load_scene("sphere", width=W, height=H)
    second = SceneObject("ball2", primitives.icosphere(4, 0.5), (0.7, 0.7, 0.9), Transform((-1.2, 0.7, 0.8)),
                         reflector=True)
    scene = Scene(base.objects + (second,), base.camera, None, "two balls")
    both = FrameDriver(scene).render_frame(0).arrays
    for k in (1, 7):
        dull = Scene(tuple(replace(o, reflectivity=0.0) if i + 1 == k else o for i, o in enumerate(scene.objects)),
                     scene.camera, None, "dull")
        other = FrameDriver(dull).render_frame(0).arrays
        stencil = both["object_id"] == k
        assert stencil.sum() > 50
        differ = np.any(both["image"] != other["image"], axis=-1)
        assert differ.any() and not differ[~stencil].any()  # reflector k only changes its own pixels
        np.testing.assert_array_equal(both["reflected_id"], other["reflected_id"])
        for j in (1, 7):
            np.testing.assert_array_equal(both[f"reflection_pixel_{j}"], other[f"reflection_pixel_{j}"])


def test_planar_mirror_equals_the_classic_planar_reflection():
    cam = Camera(eye=(0.4, 1.0, 4.0), target=(0, 0.2, -2), width=W, height=H, fov_y=55)
    mirror = SceneObject("mirror", primitives.plane_grid((8.0, 6.0), (2, 2)), (0.9, 0.9, 0.9),
                         Transform((0, 0.5, -2.0), (90.0, 0, 0)), reflector=True, open=True)  # the plane z = -2
    ball = SceneObject("ball", primitives.icosphere(3, 0.5), (1, 0, 0), Transform((0.6, -0.2, 0.5)))
    box = SceneObject("box", primitives.box((0.6, 0.6, 0.6), 4), (0, 0, 1), Transform((-0.8, 0.3, 0.2)))
    torus = SceneObject("torus", primitives.torus(0.5, 0.15, 48, 16), (1, 0.8, 0), Transform((0.2, 0.9, 1.5)))
    scene = Scene((mirror, ball, box, torus), cam, None, "planar")
    a = FrameDriver(scene, RenderOptions(inverse="discard")).render_frame(0).arrays
    # classic: the objects mirrored through z = -2, drawn with the same camera
    flip = np.diag([1.0, 1.0, -1.0, 1.0])
    flip[2, 3] = -4.0
    meshes = [scene.world_mesh(k).transformed(flip) for k in (2, 3, 4)]
    clip = [_setup.transform_points(m.vertices, cam.view_proj()) for m in meshes]
    depth = np.stack([raster.rasterize(c, m.faces, W, H).depth for c, m in zip(clip, meshes)])
    classic = np.where(depth.min(axis=0) < 1.0, np.argmin(depth, axis=0) + 2, 0)
    on = a["object_id"] == 1
    assert on.sum() > 0.3 * on.size
    agree = np.mean(a["reflected_id"][on] == classic[on])
    assert agree >= 0.995, agree


def test_interrupted_render_leaves_no_torn_file(tmp_path):
    out = tmp_path / "o"
    script = ("import refsoft.cli, sys; sys.exit(refsoft.cli.main(['render', 'sphere', '--frames', '40', '--preset', "
              f"'paper', '--width', '160', '--height', '120', '--out', r'{out}']))")
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 600  # a first run compiles the kernels
    while time.time() < deadline and not list(out.glob("frame_*.npz")):
        time.sleep(0.05)
    time.sleep(0.2)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    files = sorted(out.glob("frame_*.npz"))
    assert files, "the render wrote nothing before it was killed"
    for f in files:
        with np.load(f) as z:
            assert z["image"].shape == (120, 160, 3)
    import imageio.v3 as iio
    for f in out.glob("frame_*.png"):
        assert iio.imread(f).shape == (120, 160, 3)


@pytest.mark.parametrize("kwargs, message", [
    (dict(neighbourhood="hex"), "neighbourhood must be one of"),
    (dict(neighbourhood="hierarchy"), "method='hierarchy'"),
    (dict(method="ldt2"), "method must be one of"),
    (dict(inverse="x"), "inverse must be one of"),
    (dict(widen=0.5), "widen"),
    (dict(precision="float16"), "precision"),
    (dict(frames=0), "frames must be positive"),
    (dict(frames=[9]), "outside"),
])
def test_render_options_validated(animated, kwargs, message):
    with pytest.raises(refsoft.RefsoftError, match=message):
        render(animated, **kwargs)
