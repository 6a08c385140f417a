"""Every skip leaves the frame's outputs bit for bit unchanged; the approximation
(adaptive widen) changes them only as documented."""

from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import refsoft
from refsoft import Camera, Scene, SceneObject, Transform, primitives
from refsoft.search import skips
from refsoft.raster import _setup, rasterize
from refsoft.frame import SKIPS, FrameDriver, RenderOptions
from refsoft.scene.model import Animation

W, H = 96, 72


def _assert_same_frames(scene, on, frames, off=None):
    """Render ``frames`` with options ``on`` and with every skip off; every array equal, bit
    for bit. Returns the frames rendered with ``on``."""
    off = off or on.without_skips()
    d_on, d_off = FrameDriver(scene, on), FrameDriver(scene, off)
    out = []
    for f in frames:
        a, b = d_on.render_frame(f), d_off.render_frame(f)
        assert a.arrays.keys() == b.arrays.keys()
        for key in a.arrays:
            x, y = a.arrays[key], b.arrays[key]
            assert x.dtype == y.dtype and x.shape == y.shape, key
            assert np.array_equal(x, y, equal_nan=True), f"frame {f}: {key} differs with skips {on}"
        assert a.iterations == b.iterations
        out.append(a)
    return out


def _stage_scene():
    """A static camera and mirror ball; a box slides past (frames 0-1 still, then moving), a
    second ball sits behind the camera (outside every G-buffer), and a screen hides the ball's
    left half, where a far-left pillar is reflected (outside the stencil's box)."""
    objects = (
        SceneObject("ball", primitives.icosphere(3, 1.0), (0.9, 0.9, 0.9), reflector=True),
        SceneObject("floor", primitives.plane_grid((10.0, 10.0), (10, 10)), (0.3, 0.6, 0.3),
                    Transform((0.0, -1.0, 0.0))),
        SceneObject("box", primitives.box((0.6, 0.6, 0.6), 2), (0.9, 0.2, 0.1), Transform((1.6, -0.5, 0.8))),
        SceneObject("behind", primitives.icosphere(2, 0.5), (0.8, 0.8, 0.8), Transform((0.0, 1.0, 9.0)),
                    reflector=True),
        SceneObject("pillar", primitives.box((0.3, 2.0, 0.3), 1), (0.2, 0.3, 0.9), Transform((-3.6, 0.0, 2.4))),
        SceneObject("screen", primitives.box((1.2, 3.0, 0.1), 1), (0.5, 0.5, 0.5), Transform((-0.75, 0.0, 2.5))),
    )
    anim = Animation(frames=5, object_keys={"box": ((1, Transform((1.6, -0.5, 0.8))),
                                                    (4, Transform((0.4, -0.5, 1.6))))})
    cam = Camera(eye=(0.0, 0.8, 5.0), target=(0.0, 0.0, 0.0), width=W, height=H)
    return Scene(objects, cam, anim, "stage")


@pytest.mark.parametrize("extra", [{}, {"inverse": "search"}, {"inverse": "discard"}, {"coherence": False},
                                   {"neighbourhood": "box", "precision": "float64"}, {"widen": 1.3},
                                   {"refine": True, "tessellate": 1e-5, "inverse": "discard"},
                                   {"preset": "accurate"}])
def test_all_skips_leave_outputs_unchanged(extra):
    scene = _stage_scene()
    extra = {"preset": "paper", **extra}
    frames = _assert_same_frames(scene, RenderOptions(**extra), range(5))
    s0, s1, s3 = frames[0].skipped, frames[1].skipped, frames[3].skipped
    # the ball behind the camera: no G-buffer, no search (frame 0); later its empty G-buffer is reused
    assert s0["reflectors_outside_view"] == [4]
    assert s1["gbuffers_reused"] == [1, 4]
    # frame 1: nothing moved; frame 3: the box moved, so its vertices were searched again
    n = len(frames[1].arrays["vertex_object_1"])
    owner = frames[1].arrays["vertex_object_1"]
    opt = RenderOptions(**extra)
    reusable0 = skips.reusable(SimpleNamespace(flags=frames[0].arrays["flags_1"]), opt.coherence, opt.inverse,
                                opt.border_restart)
    assert s1["searches_reused"]["1"] == int(reusable0.sum()) >= 0.8 * n
    reusable2 = skips.reusable(SimpleNamespace(flags=frames[2].arrays["flags_1"]), opt.coherence, opt.inverse,
                                opt.border_restart)
    assert s3["searches_reused"]["1"] == int(np.sum(reusable2 & (owner != 3))) > 0
    # the pillar's virtual vertices lie beyond the ball's stencil box (tessellated geometry is
    # one part, culled per triangle only)
    one_part = "tessellate" in extra or extra["preset"] == "accurate"  # tessellated or cut: one part
    if opt.draw == "raster":  # the exact drawing culls per triangle (search/exact.py)
        assert s0["virtual_objects_culled"]["1"] >= (0 if one_part else 1)
    else:
        assert "1" not in s0["virtual_objects_culled"]


@pytest.mark.parametrize("name", SKIPS)
def test_each_skip_alone_leaves_outputs_unchanged(name):
    scene = _stage_scene()
    only = RenderOptions(**{k: (k == name) for k in SKIPS})
    _assert_same_frames(scene, only, range(4))


@pytest.mark.parametrize("name", ["sphere", "ellipsoid", "planar", "concave", "torus", "quad", "kitchen", "ufo",
                                  "ants"])
def test_builtin_animations_unchanged_by_skips(name):
    scene = refsoft.load_scene(name, width=W, height=H)
    _assert_same_frames(scene, RenderOptions(), range(min(3, scene.n_frames)))


def test_reused_search_equals_search_from_the_last_pixel():
    """The reuse rule (1 iteration; HIDDEN and BORDER kept; CAPPED and inverse searches redone)
    checked on its own against the search kernel."""
    from refsoft.search.reflect import reflect
    from refsoft.scene import scene_vertices

    scene = _stage_scene()
    for inverse in ("plane", "search", "discard"):
        verts, _, out = reflect(scene, 0, [1], inverse=inverse, cap=6)
        res = out[1].result
        ok = skips.reusable(res, True, inverse)
        assert 0 < ok.sum() < len(ok)  # some capped (cap 6) or inverse searches are redone
        again = refsoft.search.search(out[1].gbuffer, scene.camera_at(0).eye, verts, inverse=inverse,
                                      previous=res.pixel, cap=6)
        it, fl = skips.reused_result(res, True)
        for a, b in ((res.pixel, again.pixel), (res.score, again.score), (res.margin, again.margin),
                     (it, again.iterations), (fl, again.flags)):
            np.testing.assert_array_equal(a[ok], b[ok])


def test_outside_frustum_hand_cases():
    inside = np.array([[0.0, 0.0, 0.5, 1.0], [0.5, 0.5, 0.5, 1.0]])
    assert not skips.outside_frustum(inside)
    assert skips.outside_frustum(inside + [2.0, 0, 0, 0])  # all right of x = w
    assert skips.outside_frustum(np.array([[0.0, 0.0, -3.0, 1.0], [0.0, 0.0, -2.0, 1.5]]))  # before near
    # one vertex each side of x = w: not culled (the triangle may cross the view)
    assert not skips.outside_frustum(np.array([[2.0, 0.0, 0.5, 1.0], [0.0, 0.0, 0.5, 1.0]]))
    # exactly on x = w is not strictly outside
    assert not skips.outside_frustum(np.array([[1.0, 0.0, 0.5, 1.0], [3.0, 0.0, 0.5, 1.0]]))


@settings(max_examples=150, deadline=None)
@given(st.lists(st.floats(-1.6, 1.6), min_size=9, max_size=9), st.lists(st.floats(0.3, 3.0), min_size=3, max_size=3),
       st.integers(0, 40), st.integers(1, 30), st.integers(0, 56), st.integers(1, 40))
def test_outside_box_triangles_cover_nothing_in_the_box(xyz, ws, r0, dh, c0, dw):
    """Whenever a triangle's clip vertices are 'outside' a box, the rasterizer covers no pixel
    of that box (the converse is not claimed: the test is conservative)."""
    width, height = 64, 48
    r1, c1 = min(r0 + dh, height), min(c0 + dw, width)
    r0, c0 = min(r0, r1 - 1), min(c0, c1 - 1)
    w = np.array(ws)
    clip = np.c_[np.reshape(xyz, (3, 3)) * w[:, None], w]
    clip[:, 2] = np.clip(clip[:, 2], -0.9 * w, 0.9 * w)
    box = (r0, r1, c0, c1)
    if skips.outside_box(clip, skips.box_planes(box, width, height)):
        frags = rasterize(clip, np.array([[0, 1, 2]]), width, height, region=box)
        assert not frags.mask.any()


def test_outside_box_margin():
    """A triangle 0.2 px beyond the box's last pixel centre is culled with no margin and kept with
    the default one (which allows for snapping); the rasterizer draws none of it in the box."""
    width, height = 64, 48
    box = (10, 20, 10, 20)  # last column centre at x = 19.5
    x = 2 * 19.7 / width - 1.0
    clip = np.array([[x, -0.9, 0.0, 1.0], [x + 0.5, -0.9, 0.0, 1.0], [x, 0.9, 0.0, 1.0]])
    assert skips.outside_box(clip, skips.box_planes(box, width, height, margin=0.0))
    assert not skips.outside_box(clip, skips.box_planes(box, width, height))
    assert not rasterize(clip, np.array([[0, 1, 2]]), width, height, region=box).mask.any()
    # moved 0.4 px left it covers the last column of the box, and neither test culls it
    clip[:, 0] -= 2 * 0.4 / width
    assert rasterize(clip, np.array([[0, 1, 2]]), width, height, region=box).mask[:, -1].any()
    assert not skips.outside_box(clip, skips.box_planes(box, width, height, margin=0.0))


def test_adaptive_widen_uses_the_wider_frustum_only_when_clipped():
    scene = _stage_scene()  # the ball is wholly in view
    d_adapt = FrameDriver(scene, RenderOptions(widen=1.5, adaptive_widen=True))
    d_plain = FrameDriver(scene, RenderOptions(widen=1.0))
    a, b = d_adapt.render_frame(0), d_plain.render_frame(0)
    assert a.skipped["widen_off"] == [1]
    for key in ("image", "reflected_id", "reflection_pixel_1", "gbuffer_mask_1"):
        np.testing.assert_array_equal(a.arrays[key], b.arrays[key])
    # a ball cut by the image border keeps the wider frustum
    clipped = Scene(scene.objects[:3], Camera(eye=(2.2, 0.8, 3.0), target=(4.0, 0.0, -2.0), width=W, height=H),
                    None, "clipped")
    c = FrameDriver(clipped, RenderOptions(widen=1.5, adaptive_widen=True)).render_frame(0)
    d = FrameDriver(clipped, RenderOptions(widen=1.5)).render_frame(0)
    assert c.skipped["widen_off"] == []
    assert np.array_equal(c.arrays["reflection_pixel_1"], d.arrays["reflection_pixel_1"])
    assert skips.projection_clipped(_setup.transform_points(clipped.world_mesh(1, 0).vertices,
                                                            clipped.camera.view_proj()))


def test_skip_options_are_checked():
    with pytest.raises(refsoft.RefsoftError, match="reuse must be True or False"):
        RenderOptions(reuse="yes")


def test_cli_skip_switches_give_identical_files_and_report_skips(tmp_path):
    import json

    from refsoft import cli

    size = ["--width", "48", "--height", "36", "--frames", "2"]
    assert cli.main(["render", "sphere", "--out", str(tmp_path / "on"), *size]) == 0
    assert cli.main(["render", "sphere", "--out", str(tmp_path / "off"), "--no-skips", *size]) == 0
    assert cli.main(["render", "sphere", "--out", str(tmp_path / "one"), "--no-skip", "reuse", "--no-skip",
                     "crop-virtual", *size]) == 0
    for f in ("frame_0000.npz", "frame_0001.npz", "frame_0001.png"):
        ref = (tmp_path / "off" / f).read_bytes()
        assert (tmp_path / "on" / f).read_bytes() == ref and (tmp_path / "one" / f).read_bytes() == ref
    st = json.loads((tmp_path / "on" / "stats.json").read_text())
    assert st["frames"][1]["skipped"]["gbuffers_reused"] == [1]  # the sphere scene is static
    assert json.loads((tmp_path / "off" / "stats.json").read_text())["frames"][1]["skipped"]["gbuffers_reused"] == []
    with pytest.raises(SystemExit):
        cli.main(["render", "sphere", "--no-skip", "everything"])


def test_triangle_kernel_agrees_with_outside_box():
    rng = np.random.default_rng(3)
    w = rng.uniform(0.2, 3.0, 600)
    clip = np.c_[rng.uniform(-2, 2, (600, 3)) * w[:, None], w]
    clip[::7, 3] *= -1  # some behind the eye
    faces = rng.integers(0, 600, (400, 3))
    bounds = skips.box_planes((10, 30, 20, 50), 64, 48)
    got = skips.triangles_outside_box(clip, faces, *bounds)
    expect = [skips.outside_box(clip[f], bounds) for f in faces]
    np.testing.assert_array_equal(got, expect)
    assert 0 < got.sum() < len(got)
