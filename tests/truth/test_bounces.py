"""The truth's mirror paths (``bounces = N``, spec section 5.1): against a brute-force NumPy ray
tracer (tests/naive_bounces.py), a corner reflector's analytic double image, the first-order
truth, and bad values."""

import numpy as np
import pytest

import naive_bounces
from mirror_scenes import corner_scene
from refsoft import Camera, Scene, SceneObject, Transform, cli, constants
from refsoft.errors import RefsoftError
from refsoft.raster import color_pass
from refsoft.scene.builtin.shapes import bowl
from refsoft.scene.primitives import box, icosphere, plane_grid
from refsoft.truth.raytrace import RayTracedTruth, TruthRenderer, render_truth


def two_balls_and_a_box(width=48, height=36):
    """Two small mirror balls side by side (each sees the other) and a box, on a floor."""
    objects = (
        SceneObject("left_ball", icosphere(3, 0.6), (0.9, 0.9, 0.9), Transform((-0.65, 0.0, 0.0)), reflector=True),
        SceneObject("right_ball", icosphere(3, 0.55), (0.9, 0.9, 0.9), Transform((0.6, 0.05, -0.1)),
                    reflector=True),
        SceneObject("box", box((0.5, 0.5, 0.5), 2), (0.85, 0.2, 0.15), Transform((0.1, -0.35, 1.1), (0, 25, 0))),
        SceneObject("floor", plane_grid((8.0, 8.0), (4, 4)), (0.35, 0.55, 0.35), Transform((0.0, -0.6, 0.0))),
    )
    cam = Camera(eye=(0.0, 0.3, 2.6), target=(0.0, 0.0, 0.0), fov_y=40.0, width=width, height=height)
    return Scene(objects, cam, None, "two_balls")


def bowl_scene(width=48, height=36):
    """The inside of an open mirror bowl (it sees itself) with a ball over it."""
    inner, _ = bowl(1.0, 8, 24, inside=True)
    objects = (
        SceneObject("bowl", inner, (0.85, 0.85, 0.85), Transform((0.0, 0.0, 0.0)), reflector=True, open=True),
        SceneObject("ball", icosphere(2, 0.25), (0.9, 0.2, 0.15), Transform((0.2, 0.4, 0.1))),
        SceneObject("floor", plane_grid((8.0, 8.0), (2, 2)), (0.35, 0.55, 0.35), Transform((0.0, -1.2, 0.0))),
    )
    cam = Camera(eye=(0.0, 2.2, 1.6), target=(0.0, -0.4, 0.0), fov_y=45.0, width=width, height=height)
    return Scene(objects, cam, None, "bowl")


def _brute_force(scene, bounces, sees_itself=(), offset=0.0):
    meshes = [scene.world_mesh(k) for k in range(1, len(scene.objects) + 1)]
    view = color_pass(meshes, [o.color for o in scene.objects], scene.camera)
    return naive_bounces.trace_paths(scene, meshes, scene.camera, view, bounces, sees_itself, offset)


def _agreement(scene, bounces, sees_itself=(), offset=0.0):
    fr = TruthRenderer(scene, exact=False, bounces=bounces).render_frame(0)
    rid, depth, hits = _brute_force(scene, bounces, sees_itself, offset)
    a = fr.arrays
    on = np.isin(a["object_id"], scene.reflector_ids)
    assert np.array_equal(rid >= 0, on)  # the same reflector pixels (the same main view)
    same_id = a["reflected_id"][on] == rid[on]
    same_depth = a["bounce_depth"][on] == depth[on]
    both = on & (a["reflected_id"] == rid) & (rid > 0)
    hit_err = np.abs(a["reflected_hit"][both] - hits[both]).max(initial=0.0)
    return a, on, same_id.mean(), same_depth.mean(), hit_err, depth


@pytest.mark.parametrize("bounces", [1, 2, 3])
def test_paths_agree_with_a_brute_force_tracer(bounces):
    scene = two_balls_and_a_box()
    a, on, ids, depths, hit_err, depth = _agreement(scene, bounces)
    print(f"bounces={bounces}: {on.sum()} reflector pixels, reflected_id agrees on {100 * ids:.3f}%, bounce_depth "
          f"on {100 * depths:.3f}%, max reflected_hit difference {hit_err:.1e}; depths "
          f"{np.bincount(depth[on], minlength=bounces + 1).tolist()}")
    assert on.sum() > 400
    assert ids >= 0.999 and depths >= 0.999
    assert hit_err < 1e-9
    assert a["bounce_depth"][on].max() == bounces  # the balls do see each other, to the last reflection
    assert np.all(a["bounce_depth"][~on] == 0)


def test_a_mirror_that_sees_itself_agrees_with_the_brute_force_tracer():
    scene = bowl_scene()
    v = scene.world_mesh(1).vertices
    offset = constants.TRUTH_SELF_OFFSET * np.linalg.norm(v.max(axis=0) - v.min(axis=0))
    a, on, ids, depths, hit_err, depth = _agreement(scene, 3, {1}, offset)
    print(f"bowl, bounces=3: {on.sum()} px, reflected_id {100 * ids:.3f}%, bounce_depth {100 * depths:.3f}%, "
          f"depths {np.bincount(depth[on], minlength=4).tolist()}")
    assert ids >= 0.999 and depths >= 0.999 and hit_err < 1e-9
    assert (a["bounce_depth"][on] == 3).sum() > 20  # rays reflect inside the bowl, again and again


def test_which_reflectors_see_themselves():
    from refsoft.truth.paths import sees_itself

    assert not sees_itself(two_balls_and_a_box(), 1)  # a convex ball
    assert sees_itself(bowl_scene(), 1)  # the inside of an open bowl
    assert not sees_itself(corner_scene(), 1)  # a plane mirror
    outside, proxy = bowl(1.0, 8, 24)  # an open shell seen from outside, with a closed proxy: its rim sees itself
    scene = Scene((SceneObject("shell", outside, reflector=True, closed_proxy=proxy),) + bowl_scene().objects[1:],
                  bowl_scene().camera)
    assert sees_itself(scene, 1)


# --- the corner reflector: two flat mirrors at a right angle ---------------------------------

def _first_hit(o, d, tris):
    t, _, _, inside = naive_bounces.ray_all_triangles(o, d, tris)
    return t[inside].min() if inside.any() else np.inf


def test_corner_reflector_shows_the_double_image():
    scene = corner_scene()
    mesh_a, mesh_b = scene.world_mesh(1), scene.world_mesh(2)
    # the mirrors are where the docstring says
    assert np.allclose(mesh_a.vertices[:, 0], 0) and np.allclose(mesh_a.normals, [1, 0, 0])
    assert np.allclose(mesh_b.vertices[:, 2], 0) and np.allclose(mesh_b.normals, [0, 0, 1])
    fr = TruthRenderer(scene, exact=False, bounces=2).render_frame(0)
    a = fr.arrays
    tris = scene.world_mesh(3).vertices[scene.world_mesh(3).faces]
    turn = np.array([-1.0, 1.0, -1.0])  # both reflections: 180 degrees about the corner line (the y axis)
    flip = {1: np.array([-1.0, 1.0, 1.0]), 2: np.array([1.0, 1.0, -1.0])}  # across A, across B
    cam = scene.camera
    rows, cols = np.nonzero(np.isin(a["object_id"], (1, 2)))
    o, d = cam.rays(rows, cols)
    expect = np.zeros(len(rows), bool)
    where = np.zeros((len(rows), 3))
    for i in range(len(rows)):
        first = a["object_id"][rows[i], cols[i]]
        other_axis = 2 if first == 1 else 0  # the second mirror's plane: z = 0 after A, x = 0 after B
        s2 = -o[i, other_axis] / d[i, other_axis] if d[i, other_axis] != 0 else -1.0
        if s2 <= 0:
            continue
        # the unfolded ray: its second crossing, mirrored back across the first plane, on the second square
        p2 = (o[i] + s2 * d[i]) * flip[first]
        if not (0 <= p2[2 - other_axis] <= 2 and -1 <= p2[1] <= 1):
            continue
        s1 = -o[i, 0 if first == 1 else 2] / d[i, 0 if first == 1 else 2]
        if s2 <= s1:
            continue
        # between the mirrors the real ray meets the box when the unfolded one meets its mirror image
        between = _first_hit(o[i], d[i], tris * flip[first])
        if s1 < between < s2:
            continue
        s3 = _first_hit(o[i], d[i], tris * turn)  # the double image
        if s2 < s3 < np.inf:
            expect[i] = True
            where[i] = (o[i] + s3 * d[i]) * turn
    got = (a["bounce_depth"][rows, cols] == 2) & (a["reflected_id"][rows, cols] == 3)
    print(f"corner: {expect.sum()} pixels show the double image analytically, the truth {got.sum()}; agree on "
          f"{100 * np.mean(got == expect):.3f}% of {len(rows)} mirror pixels")
    assert expect.sum() > 30 and np.mean(got == expect) >= 0.999
    both = got & expect
    assert np.abs(a["reflected_hit"][rows[both], cols[both]] - where[both]).max() < 1e-9
    # paths from A go on to B and from B to A: both show the image
    assert set(a["object_id"][rows[both], cols[both]]) == {1, 2}


# --- N = 1 and the first-order truth -----------------------------------------------------------

def _same(a, b):
    """Bit for bit (NaN included)."""
    a, b = np.ascontiguousarray(a), np.ascontiguousarray(b)
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


def test_one_bounce_is_the_default_and_deeper_paths_keep_the_first_order_pixels():
    scene = two_balls_and_a_box()
    default = TruthRenderer(scene).render_frame(0).arrays
    one = TruthRenderer(scene, bounces=1).render_frame(0).arrays
    three = TruthRenderer(scene, bounces=3).render_frame(0).arrays
    assert set(default) == set(one) == set(three)
    for k in default:
        assert _same(default[k], one[k]), k
    on = np.isin(default["object_id"], scene.reflector_ids)
    assert np.all(one["bounce_depth"][on] == 1) and np.all(one["bounce_depth"][~on] == 0)
    # a path that takes one reflection ends where the first-order ray does, bit for bit
    d1 = three["bounce_depth"] == 1
    assert d1.sum() > 100 and (three["bounce_depth"] >= 2).sum() > 40
    for k in ("reflected_id", "reflected_hit", "image"):
        assert _same(three[k][d1], one[k][d1]), k
    assert _same(three["image"][~on], one["image"][~on])
    # and one reflector alone (it cannot see itself) gives the first-order truth at any N
    alone = Scene((scene.objects[0],) + scene.objects[2:], scene.camera, None, "one_ball")
    a = TruthRenderer(alone, bounces=1).render_frame(0).arrays
    b = TruthRenderer(alone, bounces=4).render_frame(0).arrays
    for k in a:
        assert _same(a[k], b[k]), k


def test_mirrors_alone_see_each_other_and_nothing_else():
    """A scene of reflectors only: at N = 1 every reflector pixel shows nothing; at N = 2 the
    balls see each other (and then nothing)."""
    scene = two_balls_and_a_box()
    alone = Scene(scene.objects[:2], scene.camera, None, "two_balls_alone")
    one = TruthRenderer(alone, exact=False).render_frame(0).arrays
    two = TruthRenderer(alone, exact=False, bounces=2).render_frame(0).arrays
    on = one["object_id"] > 0
    assert on.sum() > 400 and np.all(one["reflected_id"][on] == 0) and np.all(two["reflected_id"][on] == 0)
    assert np.all(one["bounce_depth"][on] == 1) and (two["bounce_depth"][on] == 2).sum() > 20


def test_moving_mirrors_are_traced_where_they_are_at_each_frame():
    """A ball that moves: frame 2 traced after frames 0 and 1 is frame 2 traced alone (the
    reflectors' Embree scenes follow it), and differs from frame 0."""
    from refsoft import Animation

    scene = two_balls_and_a_box()
    right = scene.objects[1]
    keys = {right.name: ((0, right.transform), (2, Transform((0.9, 0.05, -0.4))))}
    moving = Scene(scene.objects, scene.camera, Animation(3, (), keys), "moving")
    walk = TruthRenderer(moving, exact=False, bounces=2)
    first = [walk.render_frame(f).arrays for f in (0, 1, 2)]
    alone = TruthRenderer(moving, exact=False, bounces=2).render_frame(2).arrays
    for k in alone:
        assert _same(first[2][k], alone[k]), k
    assert not _same(first[0]["bounce_depth"], first[2]["bounce_depth"])


def test_paths_are_the_same_bits_on_every_run_and_thread_count():
    import numba

    scene = two_balls_and_a_box(96, 72)
    runs = []
    before = numba.get_num_threads()
    try:
        for threads in (1, 2, 2):
            numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
            runs.append(TruthRenderer(scene, exact=False, bounces=3).render_frame(0).arrays)
    finally:
        numba.set_num_threads(before)
    for other in runs[1:]:
        for k in runs[0]:
            assert _same(runs[0][k], other[k]), k


def test_colour_blends_each_reflector_it_meets():
    """With reflectivity 0.5 on the second ball, a path that meets it shows half its own shaded
    colour (the composite rule applied at every reflection); with 1.0 the path's end alone."""
    from dataclasses import replace

    scene = two_balls_and_a_box(96, 72)
    half = Scene((scene.objects[0], replace(scene.objects[1], reflectivity=0.5)) + scene.objects[2:], scene.camera,
                 None, "half")
    full, part = (TruthRenderer(s, exact=False, bounces=2).render_frame(0).arrays for s in (scene, half))
    assert np.array_equal(full["reflected_id"], part["reflected_id"])
    via = (full["object_id"] == 1) & (full["bounce_depth"] == 2) & (full["reflected_id"] > 0)
    assert via.sum() > 20
    assert not np.array_equal(full["image"][via], part["image"][via])
    d1 = (full["object_id"] == 1) & (full["bounce_depth"] == 1)
    assert np.array_equal(full["image"][d1], part["image"][d1])


# --- bad values --------------------------------------------------------------------------------

@pytest.mark.parametrize("bad", [0, 9, 2.5, "x", True, None])
def test_bad_bounces_are_refused_in_one_line(bad):
    scene = two_balls_and_a_box(8, 6)
    for make in (lambda: render_truth(scene, bounces=bad), lambda: TruthRenderer(scene, bounces=bad),
                 lambda: RayTracedTruth(scene, bounces=bad)):
        with pytest.raises(RefsoftError, match="bounces must be an integer from 1 to 8") as e:
            make()
        assert "\n" not in str(e.value)


@pytest.mark.parametrize("bad", ["0", "9", "2.5", "x", "-1", ""])
def test_cli_refuses_bad_bounces(bad, tmp_path, capsys):
    assert cli.main(["truth", "sphere", "--width", "8", "--height", "6", "--bounces", bad,
                     "--out", str(tmp_path / "t")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--bounces must be an integer from 1 to 8" in err
    assert not (tmp_path / "t").exists()  # refused before anything is written


def test_cli_bounces(tmp_path, capsys):
    assert cli.main(["truth", "concave", "--width", "32", "--height", "24", "--frames", "1", "--bounces", "3",
                     "--out", str(tmp_path / "t")]) == 0
    out = capsys.readouterr().out
    assert "reflector pixels by reflections taken: 1:" in out and "3:" in out
    with np.load(tmp_path / "t" / "frame_0000.npz") as z:
        assert z["bounce_depth"].dtype == np.int8 and z["bounce_depth"].max() == 3


# --- the built-in scene of mirrors facing each other --------------------------------------------

def test_each_ball_of_the_mirrors_scene_shows_another(tmp_path, capsys):
    """Every ball of ``mirrors`` shows another ball at its first and last frame (depth 2 and 3
    on each), and compare takes such a truth as it takes a first-order one."""
    from refsoft import load_scene, render

    scene = load_scene("mirrors", width=96, height=72)
    for frame in (0, scene.n_frames - 1):
        a = TruthRenderer(scene, exact=False, bounces=3).render_frame(frame).arrays
        for k in scene.reflector_ids:
            depth = a["bounce_depth"][a["object_id"] == k]
            assert (depth == 2).sum() >= 5 and (depth == 3).sum() >= 1, (frame, k)
    size = ["--width", "32", "--height", "24", "--frames", "1"]
    assert cli.main(["render", "mirrors", *size, "--out", str(tmp_path / "r")]) == 0
    assert cli.main(["truth", "mirrors", *size, "--bounces", "2", "--out", str(tmp_path / "t")]) == 0
    assert cli.main(["compare", str(tmp_path / "r"), str(tmp_path / "t"), "--out", str(tmp_path / "c")]) == 0
    assert "reflected_id differs on" in capsys.readouterr().out
