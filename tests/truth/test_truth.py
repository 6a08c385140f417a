"""Ray-traced truth (Embree) and the error metrics: against analytic answers and hand cases."""

import json

import numpy as np
import pytest

from refsoft import Camera, Scene, SceneObject, Transform, cli, load_scene
from refsoft.truth import metrics
from refsoft.truth.analytic import fit_sphere, sphere_reflection_points
from refsoft.scene.primitives import icosphere, plane_grid
from refsoft.raster import color_pass
from refsoft.frame import render
from refsoft.raster.rays import ray_triangle
from refsoft.truth.raytrace import TruthRenderer, exact_sphere_vertices, render_truth as truth

FLOOR_Y = -1.5
FLOOR_HALF = 6.0


def ball_over_floor(width=160, height=120):
    objects = (
        SceneObject("ball", icosphere(4, 1.0), (0.9, 0.9, 0.9), Transform((0.2, 0.1, -0.3)), reflector=True),
        SceneObject("floor", plane_grid((2 * FLOOR_HALF, 2 * FLOOR_HALF), (6, 6)), (0.3, 0.6, 0.3),
                    Transform((0.0, FLOOR_Y, 0.0))),
    )
    cam = Camera(eye=(0.5, 2.5, 4.0), target=(0.2, 0.0, -0.3), fov_y=40.0, width=width, height=height)
    return Scene(objects, cam, None, "ball_over_floor")


def _naive_reflected_floor_hits(scene):
    """Per reflector pixel, independently of refsoft.truth.raytrace: the pixel ray meets the visible ball
    triangle (a 3x3 solve), reflects about the interpolated normal and meets the plane y = FLOOR_Y."""
    cam = scene.camera
    ball = scene.world_mesh(1)
    view = color_pass([scene.world_mesh(k) for k in (1, 2)], [o.color for o in scene.objects], cam)
    rows, cols = np.nonzero(view.object_id == 1)
    o, d = cam.rays(rows, cols)
    hits = np.full((len(rows), 3), np.nan)
    for i in range(len(rows)):
        a, b, c = ball.vertices[ball.faces[view.triangle[rows[i], cols[i]]]]
        # o + t d = a + u (b - a) + v (c - a)
        t, u, v = np.linalg.solve(np.c_[d[i], a - b, a - c], a - o[i])
        p = o[i] + t * d[i]
        na, nb, nc = ball.normals[ball.faces[view.triangle[rows[i], cols[i]]]]
        n = (1 - u - v) * na + u * nb + v * nc
        n /= np.linalg.norm(n)
        r = d[i] - 2 * (d[i] @ n) * n
        if r[1] < -1e-9:
            s = (FLOOR_Y - p[1]) / r[1]
            hits[i] = p + s * r
    return rows, cols, hits


def test_truth_hits_on_a_plane_match_the_analytic_reflection():
    scene = ball_over_floor()
    fr = TruthRenderer(scene).render_frame(0)
    rows, cols, expect = _naive_reflected_floor_hits(scene)
    on_floor = np.all(np.isfinite(expect), axis=1) & np.all(np.abs(expect[:, [0, 2]]) < FLOOR_HALF - 1e-3, axis=1)
    assert on_floor.sum() > 500
    rid = fr.arrays["reflected_id"][rows, cols]
    # every reflected ray that meets the floor's plane inside the floor hits the floor ...
    assert np.all(rid[on_floor] == 2)
    # ... and nothing where it does not
    assert np.all(rid[~on_floor] == 0)
    got = fr.arrays["reflected_hit"][rows[on_floor], cols[on_floor]]
    err = np.abs(got - expect[on_floor]).max()
    print(f"max reflected hit error {err:.2e} over {on_floor.sum()} rays")
    assert err < 1e-6
    # off the reflector the truth is the plain view: -1 and the rasterized ids
    assert np.all(fr.arrays["reflected_id"][fr.arrays["object_id"] != 1] == -1)


def test_truth_output_layout(tmp_path):
    frames, stats = truth(ball_over_floor(40, 30), frames=1, out=tmp_path)
    with np.load(tmp_path / "frame_0000.npz") as z:
        assert z["image"].shape == (30, 40, 3) and z["image"].dtype == np.uint8
        assert z["object_id"].dtype == np.int32 and z["reflected_id"].dtype == np.int32
        assert z["reflected_hit"].shape == (30, 40, 3) and z["reflected_hit"].dtype == np.float64
        assert np.all(z["reflected_hit"][z["reflected_id"] <= 0] == 0)
        assert z["exact_reflection_point_1"].shape == (49, 3)  # one per vertex of the floor (7 x 7 grid)
        assert np.all(z["vertex_object_1"] == 2)
    assert (tmp_path / "frame_0000.png").exists()
    st = json.loads((tmp_path / "stats.json").read_text())
    assert set(st["frames"][0]["time_ms"]) >= {"main", "trace", "total"}


def test_exact_sphere_vertices_solve_alhazen():
    scene = ball_over_floor()
    verts = scene.world_mesh(2).vertices
    pts, virt = exact_sphere_vertices(scene, 1, 0, verts)
    centre, radius = np.array([0.2, 0.1, -0.3]), 1.0
    assert np.allclose(pts, sphere_reflection_points(centre, radius, scene.camera.eye, verts), equal_nan=True)
    ok = np.all(np.isfinite(pts), axis=1)
    assert ok.sum() > 30
    # the virtual vertex is the mirror image across the tangent plane: same distance to it, other side
    n = (pts[ok] - centre) / radius
    assert np.allclose(np.sum((verts[ok] - pts[ok]) * n, axis=1), -np.sum((virt[ok] - pts[ok]) * n, axis=1))


def test_fit_sphere_finds_spheres_only():
    m = icosphere(3, 2.5)
    c, r = fit_sphere(m.vertices + [1.0, -2.0, 3.0])
    assert np.allclose(c, [1.0, -2.0, 3.0], atol=1e-12) and abs(r - 2.5) < 1e-12
    assert fit_sphere(m.vertices * [1.4, 1.0, 0.8]) is None
    assert fit_sphere(plane_grid(2.0, 3).vertices) is None


def test_ray_triangle_barycentrics():
    a, b, c = np.array([[0.0, 0, 0]]), np.array([[1.0, 0, 0]]), np.array([[0.0, 1, 0]])
    t, bary = ray_triangle(np.array([[0.25, 0.5, 2.0]]), np.array([[0.0, 0, -1]]), a, b, c)
    assert np.allclose(t, 2.0) and np.allclose(bary, [[0.25, 0.25, 0.5]])
    t, _ = ray_triangle(np.array([[0.25, 0.5, 2.0]]), np.array([[1.0, 0, 0]]), a, b, c)
    assert np.isnan(t[0])  # parallel


# --- metrics against hand-computed cases ------------------------------------------------------

def test_disagreement_counts_reflector_pixels_only():
    truth_id = np.array([[-1, 0, 2], [3, 3, -1]])
    render_id = np.array([[5, 0, 2], [3, 4, -1]])
    assert metrics.disagreement(render_id, truth_id) == pytest.approx(1 / 4)
    assert metrics.disagreement(render_id, truth_id, where=np.array([[1, 1, 1], [1, 0, 1]], bool)) == 0.0
    assert metrics.disagreement(np.full((1, 1), -1), np.full((1, 1), -1)) == 0.0
    with pytest.raises(ValueError, match="shapes differ"):
        metrics.disagreement(render_id, truth_id[:1])


def test_rim_is_the_band_inside_the_edge():
    mask = np.zeros((9, 9), bool)
    mask[1:8, 1:8] = True
    r1 = metrics.rim(mask, 1)
    assert r1.sum() == 7 * 7 - 5 * 5 and not r1[4, 4] and r1[1, 4]
    assert metrics.rim(mask, 3).sum() == 7 * 7 - 1
    assert not metrics.rim(mask, 3)[4, 4]


def test_color_error_and_distances():
    a = np.zeros((2, 2, 3), np.uint8)
    b = a.copy()
    b[0, 0] = (255, 0, 0)  # mean channel difference 1/3
    e = metrics.color_error(a, b)
    assert e["mean"] == pytest.approx(1 / 12) and e["max"] == pytest.approx(1 / 3)
    assert metrics.color_error(a, b, np.array([[0, 1], [1, 1]], bool))["mean"] == 0.0
    assert np.allclose(metrics.virtual_distance([[0, 0, 0], [1, 1, 1]], [[3, 4, 0], [1, 1, 1]]), [5, 0])
    assert np.allclose(metrics.score_error([1.0, 0.75]), [0.0, 0.25])


def test_window_to_pixel_puts_pixel_centres_on_integers():
    cam = Camera(eye=(0, 0, 5), target=(0, 0, 0), width=64, height=48)
    o, d = cam.rays(np.array([0, 10, 47]), np.array([0, 33, 63]))
    pts = o + 3.0 * d
    rc = metrics.window_to_pixel(pts, cam.view_proj(), (48, 64))
    assert np.allclose(rc, [[0, 0], [10, 33], [47, 63]], atol=1e-9)
    dist = metrics.pixel_distance([[0, 1], [10, 33], [44, 63]], pts, cam.view_proj(), (48, 64))
    assert np.allclose(dist, [1, 0, 3], atol=1e-9)


def test_frame_metrics_of_a_truth_against_itself_are_zero():
    fr = TruthRenderer(ball_over_floor(80, 60)).render_frame(0)
    m = metrics.frame_metrics(fr.arrays, fr.arrays)
    assert m["reflected_id_disagreement"] == 0 and m["color_error"]["max"] == 0 and m["object_id_mismatch"] == 0
    with pytest.raises(ValueError, match="lacks"):
        metrics.frame_metrics({"image": fr.image}, fr.arrays)


# --- render against truth on the built-in scenes ---------------------------------------------

# Agreement of reflected_id with the truth, measured at 320x240, frame 0 (docs/method.md, "Render
# against truth"): sphere discard 87.8%, plane 11.0%; planar search 99.998%, discard 98.07%; quad
# search 97.7%, discard 94.7%. Each floor sits about one point below (Embree's float32 traversal
# and libm may differ between machines at edge pixels). Why they are not all >= 99%: the rim of
# a curved reflector (region C: triangles with hidden vertices are dropped, or, with equation (1)
# verbatim, rotated onto the reflector), and large triangles whose straight virtual edges cut the
# curved true image (the quad).
AGREEMENT_FLOORS = {
    ("sphere", "discard"): 0.86,
    ("sphere", "plane"): 0.10,
    ("planar", "search"): 0.999,
    ("planar", "discard"): 0.97,
    ("quad", "search"): 0.965,
    ("quad", "discard"): 0.935,
}


@pytest.mark.parametrize("name,mode", sorted(AGREEMENT_FLOORS))
def test_render_agrees_with_truth(name, mode):
    scene = load_scene(name, width=320, height=240)
    frames, _ = render(scene, frames=1, inverse=mode)
    tr = TruthRenderer(scene).render_frame(0)
    m = metrics.frame_metrics(frames[0].arrays, tr.arrays)
    agree = 1 - m["reflected_id_disagreement"]
    print(f"{name} {mode}: agreement {100 * agree:.2f}% of {m['reflector_pixels']} px, interior "
          f"{100 * (1 - m['interior_disagreement']):.2f}%, vertices {m.get('vertices')}")
    assert m["object_id_mismatch"] == 0  # both run the same main pass
    assert agree >= AGREEMENT_FLOORS[name, mode]
    for v in m.get("vertices", {}).values():  # the search lands within a pixel of Alhazen's point
        assert v["pixel_distance_max"] <= 1.5


# --- CLI ---------------------------------------------------------------------------------------

def test_truth_and_compare_commands(tmp_path, capsys):
    size = ["--width", "64", "--height", "48"]
    assert cli.main(["render", "sphere", "--out", str(tmp_path / "r"), *size]) == 0
    assert cli.main(["truth", "sphere", "--out", str(tmp_path / "t"), *size]) == 0
    assert cli.main(["compare", str(tmp_path / "r"), str(tmp_path / "t"), "--out", str(tmp_path / "c")]) == 0
    out = capsys.readouterr().out
    assert "reflected_id differs on" in out
    rep = json.loads((tmp_path / "c" / "metrics.json").read_text())
    assert 0 <= rep["summary"]["reflected_id_disagreement"] <= 1
    # specks and holes per frame, added up in the summary and printed with it
    s, f = rep["summary"], rep["frames"][0]
    assert (s["specks"], s["holes"]) == (f["specks"], f["holes"])
    assert s["speck_fraction"] == f["speck_fraction"] == f["specks"] / f["reflector_pixels"]
    assert f"{s['specks']} specks" in out and f"{s['holes']} holes" in out
    assert "1" in rep["frames"][0]["vertices"]
    import imageio.v3 as iio

    assert iio.imread(tmp_path / "c" / "side_0000.png").shape == (48, 3 * 64 + 8, 3)
    assert iio.imread(tmp_path / "c" / "agreement_0000.png").shape == (48, 64, 3)


def test_compare_errors_are_one_line(tmp_path, capsys):
    assert cli.main(["compare", str(tmp_path / "nope"), str(tmp_path)]) == 2
    assert "is not a folder" in capsys.readouterr().err
    (tmp_path / "a").mkdir()
    assert cli.main(["compare", str(tmp_path / "a"), str(tmp_path)]) == 2
    assert "no frame_NNNN.npz common" in capsys.readouterr().err
    assert cli.main(["render", "sphere", "--out", str(tmp_path / "r"), "--width", "32", "--height", "24"]) == 0
    assert cli.main(["truth", "sphere", "--out", str(tmp_path / "t"), "--width", "40", "--height", "30"]) == 0
    assert cli.main(["compare", str(tmp_path / "r"), str(tmp_path / "t")]) == 2
    assert "same --width/--height" in capsys.readouterr().err
    assert cli.main(["truth", "sphere", "--frame", "3", "--frames", "2"]) == 2


def test_flip_is_information_only_and_called_reference_first(monkeypatch):
    import sys
    import types

    a = np.zeros((4, 4, 3), np.uint8)
    b = np.full((4, 4, 3), 255, np.uint8)
    calls = []
    fake = types.SimpleNamespace(evaluate=lambda ref, test, rng: calls.append((ref.max(), test.max(), rng)) or
                                 (None, 0.25, {}))
    monkeypatch.setitem(sys.modules, "flip_evaluator", fake)
    assert metrics.flip_mean(a, b) == 0.25
    assert calls == [(1.0, 0.0, "LDR")]  # the truth (second argument) is FLIP's reference, in [0, 1]
    monkeypatch.setitem(sys.modules, "flip_evaluator", None)  # not installed
    assert metrics.flip_mean(a, b) is None


def test_closed_meshes_are_told_from_open_ones():
    from refsoft.scene.builtin.shapes import bowl as make_bowl
    from refsoft.scene.primitives import box as refsoft_box
    from refsoft.truth.raytrace import _is_closed

    ball = icosphere(2)
    assert _is_closed(ball.faces, ball.n_vertices)
    assert not _is_closed(ball.faces[1:], ball.n_vertices)  # a hole
    doubled = np.concatenate([ball.faces, ball.faces[:1]])
    assert not _is_closed(doubled, ball.n_vertices)  # an edge shared by three or four triangles
    bowl, _ = make_bowl(1.0, 4, 8)
    assert not _is_closed(bowl.faces, bowl.n_vertices)
    box = refsoft_box(3)
    assert _is_closed(box.faces, box.n_vertices) == (box.boundary_edges() == 0 and len(np.unique(box.vertices, axis=0)) == box.n_vertices)


def test_primary_ray_kernel_equals_the_numpy_rays_and_hits():
    """The truth's primary-ray kernel against camera.rays, ray_triangle and the interpolated,
    renormalised normal in NumPy, on the ball of the sphere scene (perspective) and an
    orthographic view of it; the box-shaped kernel of the exact drawing against it, bit for
    bit."""
    from refsoft.raster.rays import box_rays, primary_rays
    from refsoft.truth.raytrace import _interpolated_normals

    scene = load_scene("sphere", width=96, height=72)
    for cam in (scene.camera, Camera(eye=(0, 0.5, 6), target=(0, 0, 0), width=96, height=72,
                                     projection="orthographic", ortho_height=3.0)):
        ball = scene.world_mesh(1)
        view = color_pass([ball], [(1, 1, 1)], cam)
        rows, cols = np.nonzero(view.object_id == 1)
        tri = view.triangle[rows, cols]
        hit, ray, ok = primary_rays(cam, ball, rows, cols, tri)
        o, d = cam.rays(rows, cols)
        f = ball.faces.astype(np.int64)[tri]
        t, bary = ray_triangle(o, d, ball.vertices[f[:, 0]], ball.vertices[f[:, 1]], ball.vertices[f[:, 2]])
        assert ok.all() and np.all(np.isfinite(t))
        np.testing.assert_allclose(hit, o + t[:, None] * d, rtol=0, atol=1e-12)
        n = _interpolated_normals(ball.normals, ball.faces.astype(np.int64), tri, bary)
        np.testing.assert_allclose(ray, d - 2 * np.sum(d * n, axis=1, keepdims=True) * n, rtol=0, atol=1e-12)
        # the same rays written into a box's arrays: the same bits, zeros off the stencil
        stencil = view.object_id == 1
        box = (rows.min() - 2, rows.max() + 3, cols.min() - 1, cols.max() + 2)
        valid, origin, direction = box_rays(cam, ball, view.triangle, stencil, box)
        at = (rows - box[0], cols - box[2])
        assert np.array_equal(valid[at], ok) and valid.sum() == len(rows)
        assert origin[at].tobytes() == hit.tobytes() and direction[at].tobytes() == ray.tobytes()
        assert not origin[~valid].any() and not direction[~valid].any()
        # written into arrays holding anything (scratch memory): the same arrays
        h, w = box[1] - box[0], box[3] - box[2]
        out = np.ones((h, w), bool), np.full((h, w, 3), np.nan), np.full((h, w, 3), -7.0)
        again = box_rays(cam, ball, view.triangle, stencil, box, out=out)
        assert all(a is b for a, b in zip(again, out))
        assert all(a.tobytes() == b.tobytes() for a, b in zip(again, (valid, origin, direction)))


def test_reflected_rays_split_over_threads_hit_what_one_embree_call_hits():
    """The rays are traced in parts, one per thread: the triangles hit are trimesh's
    ``intersects_first`` of all the rays at once, for 1 and 2 threads."""
    import numba

    from refsoft.truth.raytrace import _Targets

    scene = load_scene("sphere")
    targets = _Targets(scene, [scene.world_mesh(k) for k in range(1, len(scene.objects) + 1)])
    rng = np.random.default_rng(5)
    n = 50_000
    origins = rng.normal(0.0, 0.5, (n, 3))
    directions = rng.normal(0.0, 1.0, (n, 3))
    want = targets.intersector.intersects_first(origins, directions)
    assert (want >= 0).sum() > n // 10  # many rays hit something
    before = numba.get_num_threads()
    try:
        for threads in (1, 2):
            numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
            np.testing.assert_array_equal(targets._trace(origins, directions), want)
    finally:
        numba.set_num_threads(before)
