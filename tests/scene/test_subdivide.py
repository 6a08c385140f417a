"""Loader subdivision of long triangles: the rule, its guarantees, limits and the scene files."""

import textwrap
import tracemalloc

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import refsoft
from refsoft import LimitError, Mesh, SceneError, primitives
from refsoft.scene import model
from refsoft.scene.subdivide import (apply_subdivision, counts_before_after, effective_max_edge, estimate_counts,
                                     subdivide)

from naive import naive_subdivide


def _edge_len2(mesh, scale=(1.0, 1.0, 1.0)):
    f = mesh.faces.astype(np.int64)
    d = (mesh.vertices[f[:, [1, 2, 0]]] - mesh.vertices[f]) * np.asarray(scale)
    return np.sum(d * d, axis=2)


def _directed_edges(faces):
    f = np.asarray(faces, dtype=np.int64)
    return np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])


def _area_vector(mesh):
    v, f = mesh.vertices, mesh.faces
    return np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]).sum(axis=0)


def _thin_can():
    return primitives.cylinder(0.45, 1.4, 24, 1)


# --- The rule --------------------------------------------------------------------------------


def test_one_long_edge_splits_in_two():
    m = Mesh([[0, 0, 0], [2, 0, 0], [1, 0.5, 0]], [[0, 1, 2]])
    out = subdivide(m, 1.5)  # only edge 0-1 (length 2) is long
    assert out.vertices.tolist() == [[0, 0, 0], [2, 0, 0], [1, 0.5, 0], [1, 0, 0]]
    assert out.faces.tolist() == [[0, 3, 2], [3, 1, 2]]


def test_three_long_edges_split_in_four_with_midpoints_in_edge_order():
    h = np.sqrt(3.0)
    m = Mesh([[0, 0, 0], [2, 0, 0], [1, h, 0]], [[0, 1, 2]])
    out = subdivide(m, 1.5)
    # new vertices in (lo, hi) order: (0, 1) -> 3, (0, 2) -> 4, (1, 2) -> 5
    assert np.array_equal(out.vertices[3:], [[1, 0, 0], [0.5, h / 2, 0], [1.5, h / 2, 0]])
    # m0 = mid(0, 1) = 3, m1 = mid(1, 2) = 5, m2 = mid(2, 0) = 4
    assert out.faces.tolist() == [[0, 3, 4], [1, 5, 3], [2, 4, 5], [3, 5, 4]]


def test_two_long_edges_cut_the_quad_along_its_shorter_diagonal():
    # apex p = 2 far from the short kept edge 0-1; the quad 0, 1, m12, m20
    m = Mesh([[0, 0, 0], [1, 0, 0], [0.9, 3, 0]], [[0, 1, 2]])
    out = subdivide(m, 2.0)
    v = out.vertices
    m12, m20 = 4, 3  # (0, 2) -> 3, (1, 2) -> 4
    assert np.allclose(v[m20], [0.45, 1.5, 0]) and np.allclose(v[m12], [0.95, 1.5, 0])
    da, db = np.sum((v[m12] - v[0]) ** 2), np.sum((v[m20] - v[1]) ** 2)
    assert da > db  # so the diagonal is 1-m20
    assert out.faces.tolist()[:3] == [[m12, 2, m20], [0, 1, m20], [1, m12, m20]]


def test_ties_take_the_diagonal_from_the_smaller_index():
    # isosceles: both diagonals of the quad 0, 1, mid(1, 2), mid(2, 0) have the same length
    v = [[-0.5, 0, 0], [0.5, 0, 0], [0, 3, 0]]
    for face in ([0, 1, 2], [1, 0, 2]):
        out = subdivide(Mesh(v, [face]), 2.0)
        mid02, mid12 = 3, 4
        edges = {frozenset(e) for e in _directed_edges(out.faces).tolist()}
        assert frozenset((0, mid12)) in edges and frozenset((1, mid02)) not in edges
        assert len(out.faces) == 3


@pytest.mark.parametrize("mesh", [primitives.icosphere(1, 1.0), _thin_can(), primitives.box((3.0, 0.5, 1.0), 1),
                                  primitives.torus(1.0, 0.3, 12, 6)], ids=["ico", "can", "box", "torus"])
def test_closed_meshes_stay_closed_and_every_edge_is_short(mesh):
    for scale in ((1.0, 1.0, 1.0), (2.5, 0.4, 1.0)):
        L = 0.3
        out = subdivide(mesh, L, scale)
        assert out.n_faces > mesh.n_faces
        assert np.all(_edge_len2(out, scale) <= L * L)
        assert mesh.boundary_edges() == 0 and out.boundary_edges() == 0
        # every directed edge once; an index-closed mesh stays index-closed (each edge also reversed)
        e = _directed_edges(out.faces)
        assert len(np.unique(e, axis=0)) == len(e)
        if _index_closed(mesh):
            assert set(map(tuple, e)) == set(map(tuple, e[:, ::-1]))
        assert np.array_equal(out.vertices[:mesh.n_vertices], mesh.vertices)
        assert np.array_equal(out.normals[:mesh.n_vertices], mesh.normals)
        assert np.allclose(np.linalg.norm(out.normals, axis=1), 1.0)
        assert np.allclose(_area_vector(out), _area_vector(mesh), atol=1e-9)


def _index_closed(mesh):
    e = _directed_edges(mesh.faces)
    return set(map(tuple, e)) == set(map(tuple, e[:, ::-1]))


def test_open_grid_keeps_its_boundary_on_the_boundary():
    grid = primitives.plane_grid((4.0, 2.0), (3, 2))
    out = subdivide(grid, 0.4)
    assert np.all(_edge_len2(out) <= 0.16)
    e = np.sort(_directed_edges(out.faces), axis=1)
    _, counts = np.unique(e, axis=0, return_counts=True)
    assert set(counts.tolist()) == {1, 2}  # manifold: interior edges twice, boundary edges once
    uniq = np.unique(e, axis=0)
    once = uniq[counts == 1]
    p = out.vertices
    # a boundary edge of the result lies on the grid's rim, and the rim's length is kept
    on_rim = (np.isclose(np.abs(p[:, 0]), 2.0) | np.isclose(np.abs(p[:, 2]), 1.0))
    assert np.all(on_rim[once[:, 0]] & on_rim[once[:, 1]])
    assert np.isclose(np.linalg.norm(p[once[:, 1]] - p[once[:, 0]], axis=1).sum(), 12.0)
    assert np.allclose(_area_vector(out), _area_vector(grid))


def test_children_keep_the_winding_of_their_face():
    rng = np.random.default_rng(4)
    for _ in range(20):
        v = rng.uniform(-1, 1, (3, 3))
        m = Mesh(v, [[0, 1, 2]])
        parent = np.cross(v[1] - v[0], v[2] - v[0])
        out = subdivide(m, 0.2)
        w, f = out.vertices, out.faces
        kids = np.cross(w[f[:, 1]] - w[f[:, 0]], w[f[:, 2]] - w[f[:, 0]])
        assert np.all(kids @ parent > 0)


def test_nothing_long_returns_the_mesh_itself_and_runs_are_byte_identical():
    m = _thin_can()
    assert subdivide(m, 10.0) is m
    a, b = subdivide(m, 0.15, (1.0, 2.0, 1.0)), subdivide(m, 0.15, (1.0, 2.0, 1.0))
    for k in ("vertices", "faces", "normals"):
        assert getattr(a, k).tobytes() == getattr(b, k).tobytes()


def test_new_normals_are_renormalised_means_and_opposite_ends_fall_back():
    v = [[0, 0, 0], [2, 0, 0], [0, 0.5, 0]]
    n = [[0, 0, 1], [0, 0, -1], [0, 1, 0]]
    out = subdivide(Mesh(v, [[0, 1, 2]], n), 1.5)
    assert out.normals[3].tolist() == [0.0, 0.0, 1.0]  # the mean of +z and -z is zero: the lower end's
    out = subdivide(Mesh(v, [[0, 1, 2]], [[0, 0, 1], [1, 0, 0], [0, 1, 0]]), 1.5)
    assert np.allclose(out.normals[3], np.array([1, 0, 1]) / np.sqrt(2))


# --- Against the plain reference ---------------------------------------------------------------


@st.composite
def small_meshes(draw):
    nv = draw(st.integers(3, 7))
    coords = st.floats(-1.0, 1.0, allow_nan=False, width=64)
    v = np.array(draw(st.lists(st.tuples(coords, coords, coords), min_size=nv, max_size=nv)))
    idx = st.integers(0, nv - 1)
    f = np.array(draw(st.lists(st.tuples(idx, idx, idx), min_size=1, max_size=5)))
    n = np.array(draw(st.lists(st.tuples(coords, coords, coords), min_size=nv, max_size=nv)))
    n[np.all(n == 0, axis=1)] = [0.0, 0.0, 1.0]
    scale = draw(st.tuples(*[st.floats(0.5, 2.0)] * 3))
    L = draw(st.floats(0.3, 2.0))
    return Mesh(v, f, n), scale, L


@settings(max_examples=60, deadline=None)
@given(small_meshes())
def test_matches_the_naive_reference(case):
    mesh, scale, L = case
    out = subdivide(mesh, L, scale)
    v, f, n = naive_subdivide(mesh.vertices, mesh.faces, mesh.normals, L, scale)
    assert np.array_equal(out.vertices, v)
    assert np.array_equal(out.faces, f)
    assert np.array_equal(out.normals[:mesh.n_vertices], mesh.normals)
    assert np.array_equal(out.normals, n)
    assert np.all(_edge_len2(out, scale) <= L * L)


def test_matches_the_naive_reference_on_a_scaled_can():
    can = _thin_can()
    out = subdivide(can, 0.2, (1.0, 1.5, 0.7))
    v, f, n = naive_subdivide(can.vertices, can.faces, can.normals, 0.2, (1.0, 1.5, 0.7))
    assert out.n_faces > 10 * can.n_faces
    assert np.array_equal(out.vertices, v) and np.array_equal(out.faces, f) and np.array_equal(out.normals, n)


# --- Bad values and limits ---------------------------------------------------------------------


@pytest.mark.parametrize("bad", [0, 0.0, -1.0, float("nan"), float("inf"), True, "1", None])
def test_bad_max_edge_is_one_line(bad):
    with pytest.raises(SceneError, match="max_edge must be a finite positive number") as info:
        subdivide(_thin_can(), bad)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("bad", [0.0, -1.0, [1.0, float("nan"), 1.0], [1.0, 2.0], True])
def test_bad_scale_is_one_line(bad):
    with pytest.raises(SceneError, match="scale must be") as info:
        subdivide(_thin_can(), 0.2, bad)
    assert "\n" not in str(info.value)


def test_absurd_max_edge_is_refused_before_allocating():
    mesh = primitives.icosphere(3, 1.0)
    tracemalloc.start()
    try:
        with pytest.raises(LimitError, match=r"mesh 'icosphere'.*would make about [0-9.e+]+ triangles") as info:
            subdivide(mesh, 1e-7)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert "\n" not in str(info.value)
    assert peak < 2_000_000  # the edge lengths of 1280 faces, not the billions of triangles


def test_estimate_is_exact_for_uniform_refinement_and_checked_against_the_limits(monkeypatch):
    grid = primitives.plane_grid((4.0, 4.0), (4, 4))  # right triangles, legs 1
    for L, per_face in ((1.2, 2), (0.9, 4), (0.45, 16)):
        assert estimate_counts(grid, L)[1] == per_face * grid.n_faces == subdivide(grid, L).n_faces
    monkeypatch.setattr(refsoft.constants, "MAX_TRIANGLES", 16 * grid.n_faces - 1)
    with pytest.raises(LimitError, match="would make about"):
        subdivide(grid, 0.45)
    subdivide(grid, 0.9)


def test_each_pass_checks_its_exact_counts(monkeypatch):
    # one face split in four: the estimate counts its boundary edges' midpoints half (5 vertices), 6 are made
    h = np.sqrt(3.0)
    m = Mesh([[0, 0, 0], [2, 0, 0], [1, h, 0]], [[0, 1, 2]])
    assert estimate_counts(m, 1.5) == (5.0, 4.0)
    monkeypatch.setattr(refsoft.constants, "MAX_VERTICES", 5)
    with pytest.raises(LimitError, match="reaches 6 vertices and 4 triangles"):
        subdivide(m, 1.5)


def test_below_float_resolution_is_refused():
    m = Mesh([[1e6, 0, 0], [np.nextafter(1e6, 2e6), 0, 0], [1e6, 1e-12, 0]], [[0, 1, 2]])
    with pytest.raises(SceneError, match="floating-point resolution"):
        subdivide(m, 1e-13)


# --- Scenes and files ---------------------------------------------------------------------------

SCENE = """
[scene]
subdivide = {default}

[camera]
eye = [0.0, 1.0, 5.0]
target = [0.0, 0.0, 0.0]
width = 32
height = 24

[[objects]]
name = "ball"
primitive = {{ type = "icosphere", subdivisions = 1 }}
reflector = true
{ball}

[[objects]]
name = "floor"
primitive = {{ type = "plane", size = [6.0, 6.0], divisions = [2, 2] }}
{floor}

[[objects]]
name = "can"
primitive = {{ type = "cylinder", radius = 0.45, height = 1.4, sections = 24, segments = 1 }}
scale = [1.0, 2.0, 1.0]
{can}
"""


def _write(tmp_path, default=0.5, ball="", floor="", can=""):
    p = tmp_path / "s.toml"
    p.write_text(textwrap.dedent(SCENE.format(default=default, ball=ball, floor=floor, can=can)))
    return p


def test_scene_default_applies_to_non_reflectors_only(tmp_path):
    raw = refsoft.load_scene(_write(tmp_path, default=0))
    s = refsoft.load_scene(_write(tmp_path, default=0.5))
    assert [o.subdivide for o in s.objects] == [None, 0.5, 0.5]
    assert s.objects[0].mesh.vertices.tobytes() == raw.objects[0].mesh.vertices.tobytes()
    assert s.objects[0].source_counts is None
    for i in (1, 2):
        o = s.objects[i]
        assert o.mesh.n_faces > raw.objects[i].mesh.n_faces
        assert o.source_counts == (raw.objects[i].mesh.n_vertices, raw.objects[i].mesh.n_faces)
        assert np.all(_edge_len2(o.mesh, o.transform.scale) <= 0.25)
    before, after = counts_before_after(s)["vertices"]
    assert before == raw.counts()["vertices"] and after == s.counts()["vertices"] > before


def test_per_object_value_overrides_the_default(tmp_path):
    s = refsoft.load_scene(_write(tmp_path, default=0.5, floor="subdivide = 0", can="subdivide = 1.0",
                                  ball="subdivide = 0.3"))
    assert [o.subdivide for o in s.objects] == [0.3, 0.0, 1.0]
    ball, floor, can = s.objects
    assert floor.source_counts is None and ball.source_counts is not None
    assert np.all(_edge_len2(ball.mesh) <= 0.09) and ball.mesh.boundary_edges() == 0
    assert np.all(_edge_len2(can.mesh, can.transform.scale) <= 1.0)
    assert np.any(_edge_len2(can.mesh, can.transform.scale) > 0.25)


def test_an_open_reflector_asking_for_it_has_its_closed_proxy_subdivided_too():
    bowl = [o for o in refsoft.load_scene("kitchen").objects if o.closed_proxy is not None][0]
    scene = model.Scene((model.SceneObject(bowl.name, bowl.mesh, reflector=True, closed_proxy=bowl.closed_proxy,
                                           subdivide=0.05),), refsoft.load_scene("quad").camera)
    out = apply_subdivision(scene).objects[0]
    assert out.closed_proxy.n_faces > bowl.closed_proxy.n_faces and out.closed_proxy.boundary_edges() == 0
    assert out.mesh.n_faces > bowl.mesh.n_faces


def test_override_replaces_values_and_zero_turns_off(tmp_path):
    path = _write(tmp_path, default=0.5, floor="subdivide = 0", ball="")
    s = refsoft.load_scene(path, subdivide=1.0)
    assert [o.subdivide for o in s.objects] == [None, 1.0, 1.0]  # the reflector did not ask
    off = refsoft.load_scene(path, subdivide=0)
    assert all(o.source_counts is None for o in off.objects)
    ball = refsoft.load_scene(_write(tmp_path, ball="subdivide = 0.3"), subdivide=0.4).objects[0]
    assert ball.subdivide == 0.4
    assert effective_max_edge(model.SceneObject("x", _thin_can(), reflector=True, subdivide=0.0), 0.4) == 0.0


def test_builtin_scenes_take_the_override():
    s = refsoft.load_scene("quad", subdivide=0.5, width=32, height=24)
    ids = {o.name: o for o in s.objects}
    assert ids["quad"].source_counts == (4, 2) and ids["quad"].mesh.n_vertices > 4
    assert all(o.source_counts is None for o in s.objects if o.reflector)
    assert s.camera.width == 32
    assert all(o.source_counts is None for o in refsoft.load_scene("quad", subdivide=0).objects)


@pytest.mark.parametrize("edit, message", [
    (dict(default="-1"), r"s.toml: scene.subdivide: must be a finite number >= 0"),
    (dict(default="nan"), r"s.toml: scene.subdivide: must be a finite number >= 0"),
    (dict(default="true"), r"s.toml: scene.subdivide: must be a finite number >= 0"),
    (dict(default='"x"'), r"s.toml: scene.subdivide: must be a finite number >= 0"),
    (dict(can="subdivide = -0.5"), r"s.toml: objects\[2\].subdivide: must be a finite number >= 0"),
    (dict(can="subdivide = inf"), r"s.toml: objects\[2\].subdivide: must be a finite number >= 0"),
    (dict(default="0.5\nsubdivid = 1"), r"s.toml: scene.subdivid: unknown key"),
    (dict(can="subdivid = 0.5"), r"s.toml: objects\[2\].subdivid: unknown key"),
    (dict(can="subdivide = 1e-9"), r"s.toml: scene 's': object 'can'.*would make about"),
])
def test_bad_subdivide_values_name_file_and_key(tmp_path, edit, message):
    path = _write(tmp_path, **edit)
    with pytest.raises((SceneError, LimitError), match=message) as info:
        refsoft.load_scene(path)
    assert "\n" not in str(info.value)
    if "would make" in message:
        assert isinstance(info.value, LimitError)


@pytest.mark.parametrize("bad", [-1.0, float("nan"), True, "0.5"])
def test_bad_override_is_refused(tmp_path, bad):
    with pytest.raises(SceneError, match="subdivide override must be a finite number >= 0"):
        refsoft.load_scene(_write(tmp_path), subdivide=bad)
    with pytest.raises(SceneError, match="subdivide override"):
        refsoft.load_scene("quad", subdivide=bad)


@pytest.mark.parametrize("bad", [-1.0, float("nan"), True])
def test_scene_object_refuses_bad_subdivide(bad):
    with pytest.raises(SceneError, match="subdivide must be a finite number >= 0"):
        model.SceneObject("x", _thin_can(), subdivide=bad)


def test_object_scale_covers_every_animation_key():
    can = _thin_can()
    T = model.Transform
    scene = model.Scene((model.SceneObject("can", can, transform=T(scale=(1.0, 1.0, 1.0))),),
                        refsoft.load_scene("quad").camera,
                        model.Animation(3, (), {"can": ((0, T(scale=(1.0, 1.0, 1.0))), (2, T(scale=(1.0, 3.0, 0.5))))}))
    out = apply_subdivision(replace_subdivide(scene, 0.3)).objects[0]
    assert np.all(_edge_len2(out.mesh, (1.0, 3.0, 1.0)) <= 0.09)


def replace_subdivide(scene, L):
    from dataclasses import replace

    return replace(scene, objects=tuple(replace(o, subdivide=L) for o in scene.objects))
