"""The example scenes of ``examples/`` work as written: each renders through the command line,
its mirror shows the objects around it, the mesh files are the ones ``make_meshes.py`` writes,
and docs/scenes.md's annotated scene is ``examples/bowl.toml`` itself."""

import glob
import importlib.util
import os

import numpy as np
import pytest

from refsoft import cli
from refsoft.scene import load_mesh, load_scene

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
EXAMPLES = os.path.join(ROOT, "examples")
SCENES = sorted(glob.glob(os.path.join(EXAMPLES, "*.toml")))


def test_there_are_examples():
    names = {os.path.basename(p) for p in SCENES}
    assert {"mirror_ball.toml", "bowl.toml", "meshes.toml", "subdivide.toml"} <= names


@pytest.mark.parametrize("path", SCENES, ids=os.path.basename)
def test_example_renders_and_its_mirror_shows_objects(path, tmp_path):
    out = tmp_path / "out"
    assert cli.main(["render", path, "--width", "64", "--height", "48", "--frames", "2", "--out", str(out)]) == 0
    assert {"frame_0000.npz", "frame_0000.png", "frame_0001.npz", "frame_0001.png", "stats.json"} <= set(
        os.listdir(out))
    scene = load_scene(path)
    with np.load(out / "frame_0001.npz") as z:
        rid, oid = z["reflected_id"], z["object_id"]
        assert z["image"].shape == (48, 64, 3)
    on_mirror = np.isin(oid, scene.reflector_ids)
    assert on_mirror.any()
    assert np.array_equal(rid >= 0, on_mirror)
    assert (rid[on_mirror] > 0).any()  # the mirror reflects something, not only the background
    assert set(np.unique(rid[rid > 0])) <= {k for k in range(1, len(scene.objects) + 1)
                                            if k not in scene.reflector_ids}


def test_mesh_files_are_what_make_meshes_writes(tmp_path):
    spec = importlib.util.spec_from_file_location("make_meshes", os.path.join(EXAMPLES, "make_meshes.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    module.main(str(tmp_path))
    written = sorted(os.listdir(tmp_path))
    assert written == ["bowl_closed.ply", "bowl_open.ply", "cube_flat.obj", "cube_shared.obj"]
    for name in written:
        assert (tmp_path / name).read_bytes() == open(os.path.join(EXAMPLES, name), "rb").read(), name


def test_open_bowl_and_its_closed_proxy():
    bowl, proxy = load_mesh(os.path.join(EXAMPLES, "bowl_open.ply")), load_mesh(os.path.join(EXAMPLES, "bowl_closed.ply"))
    assert bowl.boundary_edges() > 0 and proxy.boundary_edges() == 0
    scene = load_scene(os.path.join(EXAMPLES, "bowl.toml"))
    assert scene.objects[0].closed_proxy is not None and scene.objects[0].reflector


def test_shared_cube_is_smooth_and_flat_cube_is_flat():
    """docs/scenes.md: without normals in the file, a vertex shared by several faces gets the
    normalised sum of its triangles' cross products; a face with its own vertices stays flat."""
    shared = load_mesh(os.path.join(EXAMPLES, "cube_shared.obj"))
    flat = load_mesh(os.path.join(EXAMPLES, "cube_flat.obj"))
    assert shared.n_vertices == 8 and flat.n_vertices == 24
    f, v = shared.faces.astype(np.int64), shared.vertices
    cross = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    expected = np.zeros_like(v)
    for k in range(3):
        np.add.at(expected, f[:, k], cross)
    expected /= np.linalg.norm(expected, axis=1, keepdims=True)
    assert np.allclose(shared.normals, expected)
    assert np.all(np.sum(np.abs(shared.normals) > 1e-6, axis=1) == 3)  # no normal along an axis: smooth
    # each face of the flat cube: its 4 vertices share one axis-aligned normal, the face's own
    for k in range(6):
        n = flat.normals[4 * k:4 * k + 4]
        assert np.all(n == n[0]) and np.sum(np.abs(n[0])) == 1.0
        quad = flat.vertices[4 * k:4 * k + 4]
        assert np.allclose((quad - quad[0]) @ n[0], 0.0)


def test_docs_scene_example_is_the_bowl_example():
    text = open(os.path.join(ROOT, "docs", "scenes.md")).read()
    block = text.split("```toml\n", 1)[1].split("```", 1)[0]
    assert block == open(os.path.join(EXAMPLES, "bowl.toml")).read()
