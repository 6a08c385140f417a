"""The scenes like the layered-depth-texture paper's: closed, consistently wound reflected objects
with the depth layers their descriptions claim, small enough for the test suite."""

import numpy as np
import pytest
import trimesh

import refsoft
from refsoft.scene.builtin import BUILTIN_SCENES
from refsoft.scene.builtin.ldt import closed_cylinder, make_manifold, revolve, voxel_surface

LDT_SCENES = ("balls", "hollow_box", "genus3", "cup", "touching", "cylinder")


def _edges(faces):
    f = np.asarray(faces, dtype=np.int64)
    return np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])


def _closed_and_wound(mesh):
    """Every edge (by vertex index) in exactly two triangles, once in each direction."""
    d = _edges(mesh.faces)
    n = mesh.n_vertices
    undirected = np.unique(np.sort(d, axis=1) @ [n, 1], return_counts=True)[1]
    directed = d @ [n, 1]
    reverse = d[:, ::-1] @ [n, 1]
    return (bool(np.all(undirected == 2)) and len(np.unique(directed)) == len(directed)
            and bool(np.all(np.isin(directed, reverse))))


def _volume(mesh):
    v, f = mesh.vertices, mesh.faces
    return float(np.sum(np.einsum("ij,ij->i", v[f[:, 0]], np.cross(v[f[:, 1]], v[f[:, 2]])))) / 6.0


def _genus(mesh):
    edges = len(np.unique(np.sort(_edges(mesh.faces), axis=1), axis=0))
    return (2 - (mesh.n_vertices - edges + mesh.n_faces)) // 2


def _max_layers(mesh, n=40):
    """The most solid intervals along one ray of a grid of axis-parallel rays (crossings / 2)."""
    tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    lo, hi = mesh.bounds()
    best = 0
    for a in range(3):
        u, v = (a + 1) % 3, (a + 2) % 3
        gu, gv = np.meshgrid(np.linspace(lo[u], hi[u], n + 2)[1:-1] + 1e-4,
                             np.linspace(lo[v], hi[v], n + 2)[1:-1] + 1.3e-4)
        o = np.zeros((gu.size, 3))
        o[:, u], o[:, v], o[:, a] = gu.ravel(), gv.ravel(), lo[a] - 1.0
        d = np.zeros_like(o)
        d[:, a] = 1.0
        _, ray, _ = tm.ray.intersects_location(o, d, multiple_hits=True)
        best = max(best, int(np.bincount(ray, minlength=len(o)).max()) // 2)
    return best


def test_the_scenes_are_built_in_with_descriptions():
    for name in LDT_SCENES:
        builder, text = BUILTIN_SCENES[name]
        assert text and "\n" not in text
        assert refsoft.load_scene(name).name == name


@pytest.mark.parametrize("name", LDT_SCENES)
def test_reflected_objects_are_closed_and_wound_outwards(name):
    scene = refsoft.load_scene(name)
    c = scene.counts()
    assert c["vertices"] < 20_000 and c["reflectors"] == 1
    assert scene.camera.width == 640 and scene.camera.height == 480
    ball = scene.object_by_id(scene.reflector_ids[0])
    assert _closed_and_wound(ball.mesh)
    for obj in scene.objects:
        if obj.reflector:
            continue
        assert _closed_and_wound(obj.mesh), obj.name
        assert _volume(obj.mesh) > 0, obj.name  # counter-clockwise seen from outside
        # normals point outwards: on average along the triangles' own normals
        v, f = obj.mesh.vertices, obj.mesh.faces
        area = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
        assert np.all(np.einsum("ij,ij->i", area, obj.mesh.normals[f].sum(axis=1)) > 0), obj.name


@pytest.mark.parametrize("name, obj, layers, genus", [
    ("balls", "red_ball", 1, 0), ("hollow_box", "hollow_box", 2, 0), ("genus3", "genus3", 3, 3),
    ("cup", "cup", 3, 1), ("cylinder", "cylinder", 1, 0)])
def test_depth_layers_and_genus(name, obj, layers, genus):
    """Layers counted by ray casts along the three axes (the paper's Table 1: ball 1, hollow
    box 2, genus3 3): the hollow box has exactly 2; the genus-3 solid and the cup at least 3
    (measured 2026-12-01 on this grid: 7 and 3)."""
    scene = refsoft.load_scene(name)
    mesh = next(o.mesh for o in scene.objects if o.name == obj)
    got = _max_layers(mesh)
    assert got == layers if layers < 3 else got >= layers
    assert _genus(mesh) == genus


def test_touching_box_rests_on_the_ball():
    scene = refsoft.load_scene("touching")
    ball, box = scene.world_mesh(1), scene.world_mesh(2)
    top = ball.vertices[:, 1].max()
    bottom = box.vertices[:, 1].min()
    assert top - 0.01 < bottom < top  # the floor dips just below the ball's top vertex
    # the box's floor covers the ball's top: some ball vertices lie inside its footprint, above it
    under = ball.vertices[ball.vertices[:, 1] > bottom]
    assert len(under) > 0 and np.all(np.hypot(under[:, 0], under[:, 2]) < 0.3)


def test_cylinder_stands_upright_beside_the_ball():
    scene = refsoft.load_scene("cylinder")
    cyl = scene.world_mesh(2)
    lo, hi = cyl.bounds()
    assert np.isclose(hi[1] - lo[1], 1.6) and np.allclose(hi[[0, 2]] - lo[[0, 2]], 0.6)
    assert np.hypot(*(0.5 * (lo + hi))[[0, 2]]) > 1.3  # beside the unit ball, not touching it
    assert abs(scene.camera.eye[1]) < 1e-9  # seen from the side


def test_voxel_surface_is_made_manifold_and_closed():
    occ = np.zeros((4, 4, 4), bool)
    occ[0, 0, 0] = occ[1, 1, 0] = True  # cells touching along an edge only: 4 quads on it
    v, f = voxel_surface(np.pad(occ, 1), 1.0)
    assert not _closed_and_wound(refsoft.Mesh(v, f))
    fixed, pad = make_manifold(occ)
    assert pad == 2  # the fills reached the border: one more empty layer
    assert fixed.sum() > occ.sum() and np.all(fixed[pad:-pad, pad:-pad, pad:-pad] >= occ)
    v, f = voxel_surface(fixed, 0.5, (1.0, 2.0, 3.0))
    m = refsoft.Mesh(v, f)
    assert _closed_and_wound(m) and _volume(m) == pytest.approx(0.125 * (fixed.sum()))
    assert np.all(v.min(axis=0) >= (1.5, 2.5, 3.5))  # the outermost layer stays empty


def test_revolve_and_cylinder_are_closed():
    prof = [(0.0, 1.0), (1.0, 0.0), (0.0, -1.0)]
    m = revolve(prof, [(0.0, 1.0), (1.0, 0.0), (0.0, -1.0)], 8)
    assert _closed_and_wound(m) and _volume(m) > 0 and m.n_vertices == 10
    c = closed_cylinder(0.5, 2.0, 32)
    assert _closed_and_wound(c)
    assert _volume(c) == pytest.approx(np.pi * 0.25 * 2.0 * (32 / (2 * np.pi)) * np.sin(2 * np.pi / 32), rel=1e-9)
