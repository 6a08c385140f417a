"""A case's inputs (`refsoft export`, every golden case's `inputs/`): read back by a plain PLY
reader they give the world meshes, normals and matrices bit for bit; a scene built from them
alone renders the golden frames bit for bit; trimesh reads the PLY files too."""

import json
import os

import numpy as np
import pytest

from refsoft import cli
from refsoft.conformance.export import read_inputs, write_inputs
from refsoft.conformance.golden import case_by_name, render_case
from refsoft.frame import FrameDriver
from refsoft.options import RenderOptions
from refsoft.scene.camera import Camera
from refsoft.scene.mesh import Mesh
from refsoft.scene.model import Animation, Scene, SceneObject, Transform

_PLY_TYPES = {"double": "<f8", "float": "<f4", "int": "<i4", "uint": "<u4", "uchar": "u1", "char": "i1"}


def plain_ply(path):
    """A PLY reader written from the format's description: the header's elements and properties
    give the binary layout (little-endian; one list property of a fixed count per face)."""
    data = open(path, "rb").read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii").split("\n")
    assert header[0] == "ply" and header[1] == "format binary_little_endian 1.0"
    elements = []
    for line in header:
        words = line.split()
        if words[:1] == ["element"]:
            elements.append((words[1], int(words[2]), []))
        elif words[:1] == ["property"]:
            elements[-1][2].append(words[1:])
    out, pos = {}, end
    for name, count, props in elements:
        if props[0][0] == "list":
            _, ctype, itype, pname = props[0]
            n = np.frombuffer(data, _PLY_TYPES[ctype], 1, pos)[0]
            dt = np.dtype([("n", _PLY_TYPES[ctype]), (pname, _PLY_TYPES[itype], (int(n),))])
        else:
            dt = np.dtype([(p[1], _PLY_TYPES[p[0]]) for p in props])
        out[name] = np.frombuffer(data, dt, count, pos)
        pos += dt.itemsize * count
    assert pos == len(data)
    v = out["vertex"]
    return (np.c_[v["x"], v["y"], v["z"]], np.c_[v["nx"], v["ny"], v["nz"]], out["face"]["vertex_indices"],
            out["face"]["n"])


def _camera(rec):
    return Camera(rec["eye"], rec["target"], rec["up"], rec["fov_y"], rec["width"], rec["height"], rec["near"],
                  rec["far"], rec["projection"], rec.get("ortho_height", 2.0))


def _exact(v, n, f):
    """A Mesh holding exactly these normals (the constructor renormalises, which can move the
    last bit of a unit vector)."""
    m = Mesh(v, f, n)
    object.__setattr__(m, "normals", n)
    return m


class InputScene(Scene):
    """A scene made from exported inputs alone: each frame's world meshes and camera as read."""

    def world_mesh(self, object_id, frame=0, proxy=False):
        table = self._inputs["proxies" if proxy and object_id in self._inputs["proxies"][frame] else "meshes"]
        return _exact(*table[frame][object_id])

    def camera_at(self, frame=0):
        return self._cameras[frame]

    def transform_at(self, object_id, frame=0):
        # only compared by the reuse skip: a moving object gets another transform each frame
        return Transform((float(frame), 0.0, 0.0)) if self.objects[object_id - 1].name in self._moving else Transform()


def scene_from_inputs(folder):
    inp = read_inputs(folder)
    case = inp["case"]
    f0 = case["frames"][0]["frame"]
    moving = {o["name"] for o in case["objects"]
              if len({fr["meshes"][str(o["id"])] for fr in case["frames"]}) > 1}
    objects = []
    for o in case["objects"]:
        k = o["id"]
        proxy = inp["proxies"][f0].get(k)
        objects.append(SceneObject(o["name"], _exact(*inp["meshes"][f0][k]), tuple(o["color"]), Transform(),
                                   o["reflector"], None if proxy is None else _exact(*proxy), o["reflectivity"],
                                   o["open"]))
    n_frames = max(fr["frame"] for fr in case["frames"]) + 1
    anim = Animation(n_frames, (), {name: ((0, Transform()),) for name in moving})
    scene = InputScene(tuple(objects), _camera(case["frames"][0]["camera"]), anim, case["scene"])
    object.__setattr__(scene, "_inputs", inp)
    object.__setattr__(scene, "_moving", moving)
    object.__setattr__(scene, "_cameras", {fr["frame"]: _camera(fr["camera"]) for fr in case["frames"]})
    opts = {k: (tuple(v) if isinstance(v, list) else v) for k, v in case["options"].items()}
    return scene, RenderOptions(**opts), [fr["frame"] for fr in case["frames"]]


@pytest.mark.parametrize("name", ["sphere", "ants", "pixel_grid"])
def test_round_trip_is_bit_identical(name, tmp_path):
    case = case_by_name(name)
    scene = case.load()
    files = write_inputs(tmp_path, scene, case.frames, case.options, case.name)
    assert files[0] == "case.json" and sorted(os.listdir(tmp_path)) == sorted(files)
    rec = json.loads((tmp_path / "case.json").read_text())
    assert list(rec) == ["format", "refsoft", "case", "scene", "width", "height", "options", "shading", "objects",
                         "frames"]
    assert rec["options"] == RenderOptions(**case.options).as_dict() and rec["case"] == name
    assert [fr["frame"] for fr in rec["frames"]] == list(case.frames)
    for fr in rec["frames"]:
        f = fr["frame"]
        cam = scene.camera_at(f)
        c = fr["camera"]
        for key, m in (("view", cam.view_matrix()), ("projection_matrix", cam.projection_matrix()),
                       ("view_proj", cam.view_proj())):
            assert np.array(c[key]).tobytes() == m.tobytes(), key
        assert np.array(c["eye"]).tobytes() == cam.eye.tobytes() and c["fov_y"] == cam.fov_y
        for k in range(1, len(scene.objects) + 1):
            for kind, proxy in (("meshes", False), ("proxies", True)):
                if kind == "proxies" and scene.objects[k - 1].closed_proxy is None:
                    assert str(k) not in fr[kind]
                    continue
                mesh = scene.world_mesh(k, f, proxy=proxy)
                v, n, faces, counts = plain_ply(tmp_path / fr[kind][str(k)])
                assert v.tobytes() == mesh.vertices.tobytes() and n.tobytes() == mesh.normals.tobytes()
                assert np.array_equal(faces, mesh.faces) and np.all(counts == 3)
    moving = {name for fr in rec["frames"] for name in fr["meshes"].values() if name.endswith(f"_{fr['frame']:04d}.ply")}
    assert bool(moving) == (name == "ants")  # the ants walk; sphere and pixel_grid are static


@pytest.mark.parametrize("name", ["sphere", "ants", "pixel_grid", "kitchen_widen"])
def test_a_scene_from_the_inputs_alone_renders_the_golden_frames(name, tmp_path):
    case = case_by_name(name)
    write_inputs(tmp_path, case.load(), case.frames, case.options, case.name)
    scene, opts, frames = scene_from_inputs(tmp_path)
    assert frames == list(case.frames)
    driver = FrameDriver(scene, opts)
    for (f, golden, _), g in zip(render_case(case), frames):
        arrays = driver.render_frame(g).arrays
        assert f == g and sorted(arrays) == sorted(k for k in golden if not k.startswith("gbuffer_depth_margin_"))
        for key in arrays:
            assert arrays[key].dtype == golden[key].dtype and arrays[key].tobytes() == golden[key].tobytes(), key


def test_trimesh_reads_the_ply_files(tmp_path):
    import trimesh

    case = case_by_name("kitchen")
    scene = case.load()
    rec = write_inputs(tmp_path, scene, case.frames[:1], case.options, case.name)
    assert "proxy_1.ply" in rec  # the open bowl's closed proxy
    for name in rec[1:]:
        k = int(name.split("_")[1].split(".")[0])
        mesh = scene.world_mesh(k, 0, proxy=name.startswith("proxy"))
        t = trimesh.load(tmp_path / name, process=False)
        assert np.array_equal(np.asarray(t.vertices), mesh.vertices) and np.array_equal(np.asarray(t.faces), mesh.faces)
        assert np.allclose(np.asarray(t.vertex_normals), mesh.normals, atol=1e-12)


def test_read_inputs_gives_what_was_written(tmp_path):
    case = case_by_name("ants")
    scene = case.load()
    write_inputs(tmp_path, scene, case.frames, case.options)
    inp = read_inputs(tmp_path)
    assert inp["case"]["case"] == "ants" and sorted(inp["meshes"]) == list(case.frames)
    v, n, f = inp["meshes"][1][2]
    m = scene.world_mesh(2, 1)
    assert v.tobytes() == m.vertices.tobytes() and n.tobytes() == m.normals.tobytes() and np.array_equal(f, m.faces)


def test_cli_export(tmp_path, capsys):
    out = tmp_path / "e"
    assert cli.main(["export", "planar", "--frames", "1:3", "--width", "64", "--height", "48", "--preset", "paper",
                     "--neighbourhood", "box", "--out", str(out)]) == 0
    assert "2 frame(s) at 64x48" in capsys.readouterr().out
    rec = json.loads((out / "case.json").read_text())
    assert [fr["frame"] for fr in rec["frames"]] == [1, 2] and rec["width"] == 64
    assert rec["options"]["preset"] == "paper" and rec["options"]["neighbourhood"] == "box"
    assert cli.main(["export", "planar", "--frame", "2", "--out", str(out)]) == 2  # an earlier export: refused
    assert "--overwrite" in capsys.readouterr().err
    assert cli.main(["export", "ants", "--frames", "2", "--out", str(out), "--overwrite"]) == 0
    rec = json.loads((out / "case.json").read_text())
    listed = {"case.json"} | {n for fr in rec["frames"] for k in ("meshes", "proxies") for n in fr[k].values()}
    assert set(os.listdir(out)) == listed  # the planar export's meshes are gone
    assert rec["options"] == RenderOptions().as_dict()  # the accurate preset by default
    for bad in (["--frames", "3:1"], ["--frames", "x"], ["--frame", "99"]):
        assert cli.main(["export", "planar", *bad, "--out", str(tmp_path / "f")]) == 2
        assert capsys.readouterr().err.startswith("refsoft: error:")
    assert cli.main(["export", "sphere", "--out", str(tmp_path / "s")]) == 0  # a static scene: frame 0
    assert [fr["frame"] for fr in json.loads((tmp_path / "s" / "case.json").read_text())["frames"]] == [0]
    capsys.readouterr()
    assert cli.main(["export", "balls", "--frame", "0", "--method", "ldt", "--ldt-resolution", "64", "--out",
                     str(tmp_path / "l")]) == 0  # the comparison methods' options too
    assert "method ldt" in capsys.readouterr().out
    rec = json.loads((tmp_path / "l" / "case.json").read_text())
    assert rec["options"] == RenderOptions(method="ldt", ldt_resolution=64).as_dict()


def test_write_inputs_refuses_bad_frames(tmp_path):
    from refsoft.errors import RefsoftError

    scene = case_by_name("planar").load()
    for frames in ([], [1, 1], [-1], [30]):
        with pytest.raises(RefsoftError):
            write_inputs(tmp_path, scene, frames, {"preset": "paper"})
    assert not (tmp_path / "case.json").exists()
