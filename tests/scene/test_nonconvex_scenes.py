"""The built-in mirrors that are not convex: the shaving mirror's cap lies on its sphere and faces
its centre, the wavy sheet carries its analytic normals, and at a small size the ray-traced truth
shows objects several times over where the optics says so."""

import numpy as np
import pytest
from scipy import ndimage

import refsoft
from refsoft import cli
from refsoft.scene.builtin.nonconvex import SHAVING_CENTRE, SHAVING_RADIUS, spherical_cap, wavy_sheet
from refsoft.truth.raytrace import render_truth


def test_the_cap_lies_on_its_sphere_and_faces_the_centre():
    m = spherical_cap(2.0, 40.0, 8, 24)
    np.testing.assert_allclose(np.linalg.norm(m.vertices, axis=1), 2.0, rtol=1e-12)
    np.testing.assert_allclose(m.normals, -m.vertices / 2.0, atol=1e-12)
    # within 40 degrees of -z, and every face wound towards the centre
    assert np.all(-m.vertices[:, 2] / 2.0 >= np.cos(np.radians(40.0)) - 1e-12)
    v = m.vertices[m.faces]
    face_n = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    assert np.all(np.sum(face_n * -v.mean(axis=1), axis=1) > 0)
    assert m.boundary_edges() > 0  # an open sheet


def test_the_wavy_sheet_has_analytic_normals():
    m = wavy_sheet((6.0, 3.0), 4, 0.15, 64, 4)
    x = m.vertices[:, 0]
    k = 2 * np.pi * 4 / 6.0
    np.testing.assert_allclose(m.vertices[:, 2], 0.15 * np.sin(k * x), atol=1e-12)
    slope = 0.15 * k * np.cos(k * x)
    np.testing.assert_allclose(m.normals, np.c_[-slope, 0 * x, np.ones_like(x)] / np.sqrt(1 + slope**2)[:, None],
                               atol=1e-12)
    v = m.vertices[m.faces]
    face_n = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    assert np.all(face_n[:, 2] > 0)  # facing +z, the side the objects are on


def test_the_shaving_mirror_is_a_concave_cap_with_objects_inside_f_near_c_and_beyond():
    s = refsoft.load_scene("shaving")
    assert s.reflector_ids == [1] and s.objects[0].open and s.n_frames == 24
    centre = np.asarray(SHAVING_CENTRE)
    mirror = s.world_mesh(1, 0)
    np.testing.assert_allclose(np.linalg.norm(mirror.vertices - centre, axis=1), SHAVING_RADIUS, rtol=1e-12)
    vertex = centre - [0.0, 0.0, SHAVING_RADIUS]  # the mirror's vertex, on its axis
    dist = {o.name: float(np.linalg.norm(s.world_mesh(k, 0).vertices.mean(axis=0) - vertex))
            for k, o in enumerate(s.objects, 1)}
    f = SHAVING_RADIUS / 2
    assert dist["red_ball"] < f < dist["yellow_box"] < SHAVING_RADIUS < dist["blue_cylinder"]
    assert abs(dist["green_ball"] - SHAVING_RADIUS) < 0.1


@pytest.mark.parametrize("name, frame, reflected, images", [
    ("wavy", 0, "red_ball", 3),      # once in several waves
    ("shaving", 6, "yellow_box", 2),  # in the caustic: twice
])
def test_render_and_truth_run_and_the_truth_shows_several_images(tmp_path, name, frame, reflected, images):
    frames, _ = refsoft.render(name, frames=[frame], width=160, height=120, out=tmp_path / "r")
    truth, _ = render_truth(name, frames=[frame], width=160, height=120, out=tmp_path / "t")
    assert frames[0].arrays["image"].shape == truth[0].arrays["image"].shape == (120, 160, 3)
    s = refsoft.load_scene(name)
    k = [o.name for o in s.objects].index(reflected) + 1
    rid = truth[0].arrays["reflected_id"]
    _, pieces = ndimage.label(rid == k)
    assert pieces >= images
    assert (frames[0].arrays["reflected_id"] == k).any()


def test_scenes_lists_them_with_their_counts(capsys):
    assert cli.main(["scenes"]) == 0
    out = capsys.readouterr().out
    for name in ("shaving", "wavy"):
        n = refsoft.load_scene(name).counts()["vertices"]
        assert f"{name} " in out and f"{n} -> {n}" in out.split(f"\n{name} ")[1].split("\n")[0]
