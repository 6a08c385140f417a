"""The replay of one pixel's LDT search (refsoft.ldt.trace): it ends where the kernel ends, bit for
bit, at every reflector pixel; its table, JSON and picture; refusals."""

import json

import numpy as np
import pytest

import refsoft
from refsoft import Camera, FrameDriver, RenderOptions, Scene
from refsoft.errors import RefsoftError
from refsoft.ldt import constants as C
from refsoft.ldt import trace as T
from refsoft.ldt.method import LayeredDepthTextures
from test_pixel_search import small_scene


def balls():
    return refsoft.load_scene("balls", width=64, height=48)


def small_ortho():
    s = small_scene()
    cam = Camera(eye=(0.0, 0.3, 4.0), target=(0, 0, 0), width=48, height=36, projection="orthographic",
                 ortho_height=3.0)
    return Scene(list(s.objects), cam, name="ldt-small-ortho")


CONFIGS = {
    "balls float32 three 32": (balls, dict()),
    "balls float32 entry 32": (balls, dict(faces="entry")),
    "balls float64 three texel": (balls, dict(linear="texel", precision="float64")),
    "small float32 none three 5": (small_scene, dict(regions="none", linear=5)),
    "small ortho float32 cone three 32": (small_ortho, dict()),
}

_MEMO = {}


def rendered(name):
    """(scene, method, frame) of a configuration, rendered once per test session."""
    if name not in _MEMO:
        make, cfg = CONFIGS[name]
        scene = make()
        method = LayeredDepthTextures(scene, resolution=32, **cfg)
        _MEMO[name] = scene, method, FrameDriver(scene, RenderOptions(method="ldt", ldt_resolution=32),
                                                 method=method).render_frame(0)
    return _MEMO[name]


@pytest.mark.parametrize("name", sorted(CONFIGS))
def test_the_replay_ends_where_the_kernel_ends_at_every_reflector_pixel(name):
    scene, method, frame = rendered(name)
    st = frame.reflectors[scene.reflector_ids[0]].state
    res = st.result
    assert len(st.rows) > 300
    flags = uncrossed = 0
    for i in range(len(st.rows)):
        tr = T.trace_pixel(scene, int(st.rows[i]), int(st.cols[i]), 0, method=method, rendered=frame)
        r = tr.result
        got = (r["object"], r["distance"], r["face"], r["layer"], tuple(r["texel"]), r["residual"], r["margin"],
               r["flags"], r["linear_samples"], r["binary_steps"], r["faces_searched"], r["objects_tested"],
               r["object_distance"], r["hit"], tr.ray["direction"])
        want = (res.object[i], res.distance[i], res.face[i], res.layer[i], tuple(res.texel[i]), res.residual[i],
                res.margin[i], res.flags[i], res.linear_samples[i], res.binary_steps[i], res.faces_searched[i],
                res.objects_tested[i], res.object_distance[i].tolist(), res.hit[i].tolist(), res.ray[i].tolist())
        assert got == want, f"pixel ({st.rows[i]}, {st.cols[i]})"
        # the record adds up to the totals, and each sample's decision is Algorithm 1's (an open
        # sheet's: the crossing rule, behind it is inside only right after a sample in front)
        faces = [(bool(method.stack.open[j]), fc) for j, o in enumerate(tr.objects) for fc in o["faces"]]
        assert sum(len(fc["samples"]) for _, fc in faces) == r["linear_samples"]
        assert sum(len(fc["bisection"]["points"]) for _, fc in faces if fc["bisection"]) == r["binary_steps"]
        for sheet, fc in faces:
            before = None
            for s in fc["samples"]:
                for v in s["layers"][:-1]:
                    assert v["test"] == "behind" and v["z"] <= s["h"] and s["h"] > v["d"]
                if s["layers"]:
                    v = s["layers"][-1]
                    assert (v["test"] == "front") == (s["h"] < v["z"])
                    crossed = not sheet or (before is not None and before["layers"] != []
                                            and before["layers"][-1]["test"] == "front")
                    within = v["d"] is not None and v["z"] <= s["h"] <= v["d"]
                    assert (v["test"] == "inside") == (within and crossed)
                    assert (v["test"] == "not crossed") == (within and not crossed)
                assert s["inside"] == (bool(s["layers"]) and s["layers"][-1]["test"] == "inside")
                uncrossed += bool(s["layers"]) and s["layers"][-1]["test"] == "not crossed"
                before = s
        if r["object"] >= 0:
            o = tr.objects[r["object"]]
            assert o["chosen_face"] == r["face"] and o["distance"] == r["distance"]
        # the table: a header, a rule, one line per linear sample, one per object, the result
        lines = tr.table().splitlines()
        K = len(method.stack.ids)
        assert len(lines) == 3 + r["linear_samples"] + K
        body = lines[2:2 + r["linear_samples"]]
        assert [ln.split()[:3] for ln in body] == [[str(oid), T.FACE_NAMES[f], str(s["m"])]
                                                   for oid, f, s in tr.samples()]
        assert lines[-1].startswith("result: ")
        flags |= r["flags"]
    hit = res.object >= 0
    assert hit.sum() >= 20 and res.binary_steps.max() > 0
    if name.startswith("small"):  # layers beyond the first, open sheets seen from both sides, no face within tau
        assert (res.layer[hit] == 1).any()
        assert flags & C.OPEN_OBJECT and flags & C.ORIGIN_IN_CUBE and uncrossed > 0
        assert flags & C.NO_FACE_WITHIN_TAU
    if name == "small float32 none three 5":  # a ray starting within a texel of the sunk ball
        assert flags & C.START_INSIDE
    if name.startswith("balls"):  # the cone test skips objects the ray's line meets
        assert flags & C.REGION_CULLED


def test_rendering_it_itself_gives_the_same_trace_by_parameters_or_options():
    scene, method, frame = rendered("balls float32 three 32")
    st = frame.reflectors[1].state
    i = int(np.argmax(st.result.binary_steps))
    row, col = int(st.rows[i]), int(st.cols[i])
    want = T.trace_pixel(scene, row, col, method=method, rendered=frame).to_dict()
    assert want["result"]["binary_steps"] > 0
    assert T.trace_pixel(scene, row, col, resolution=32).to_dict() == want
    assert T.trace_pixel(scene, row, col, options=RenderOptions(method="ldt", ldt_resolution=32)).to_dict() == want
    assert json.loads(T.trace_pixel(scene, row, col, method=method).to_json()) == want
    assert want["pixel"] == [row, col] and want["reflector"] == 1 and want["options"]["resolution"] == 32
    tab = T.trace_pixel(scene, row, col, method=method, rendered=frame).table(bisection=True).splitlines()
    assert len(tab) == 3 + want["result"]["linear_samples"] + want["result"]["binary_steps"] + 2


def test_an_animated_frame_is_traced_as_the_render_of_that_frame():
    scene = balls()
    assert scene.n_frames > 5
    method = LayeredDepthTextures(scene, resolution=32)
    frame = FrameDriver(scene, RenderOptions(method="ldt", ldt_resolution=32), method=method).render_frame(5)
    st = frame.reflectors[1].state
    i = int(np.flatnonzero(st.result.object >= 0)[0])
    tr = T.trace_pixel(scene, int(st.rows[i]), int(st.cols[i]), 5, method=method)
    assert tr.frame == 5 and tr.result["distance"] == st.result.distance[i] and tr.result["face"] == st.result.face[i]


def test_trace_json_and_the_march_picture_are_written(tmp_path, monkeypatch):
    import imageio.v3 as iio

    scene, method, frame = rendered("small float32 none three 5")
    st = frame.reflectors[1].state
    i = int(np.flatnonzero((st.result.layer == 1) & (st.result.binary_steps > 0))[0])
    tr = T.trace_pixel(scene, int(st.rows[i]), int(st.cols[i]), method=method, rendered=frame)
    assert T.write_pixel_trace(tmp_path / "a", tr) == ["trace.json", "trace.png"]
    assert json.loads((tmp_path / "a" / "trace.json").read_text()) == tr.to_dict()
    img = iio.imread(tmp_path / "a" / "trace.png")
    assert img.ndim == 3 and img.shape[0] > 200 and img.shape[1] > 400
    # without matplotlib: the JSON alone, and a clear refusal of the picture
    monkeypatch.setattr(T, "_pyplot", lambda: None)
    assert T.write_pixel_trace(tmp_path / "b", tr) == ["trace.json"]
    assert sorted(p.name for p in (tmp_path / "b").iterdir()) == ["trace.json"]
    with pytest.raises(RefsoftError, match="needs matplotlib"):
        T.march_figure(tr)


@pytest.mark.parametrize("where, match", [
    ((-1, 10), r"pixel \(-1, 10\) is off the 64x48 image"),
    ((48, 10), r"pixel \(48, 10\) is off the 64x48 image"),
    ((10, 64), r"pixel \(10, 64\) is off the 64x48 image"),
    ((1.5, 10), "row must be an integer"),
    ((10, True), "col must be an integer"),
    ((0, 0), r"pixel \(0, 0\) shows the background, not a reflector \(reflectors: 1 'ball'\)"),
])
def test_bad_pixels_are_refused_in_one_line(where, match):
    scene, method, frame = rendered("balls float32 three 32")
    with pytest.raises(RefsoftError, match=match) as e:
        T.trace_pixel(scene, *where, method=method, rendered=frame)
    assert "\n" not in str(e.value)


def test_a_pixel_of_a_reflected_object_is_refused():
    scene, method, frame = rendered("balls float32 three 32")
    rows, cols = np.nonzero(frame.arrays["object_id"] == 2)
    with pytest.raises(RefsoftError, match=r"shows object 2 'red_ball', not a reflector"):
        T.trace_pixel(scene, int(rows[0]), int(cols[0]), method=method, rendered=frame)


@pytest.mark.parametrize("kwargs, match", [
    (dict(resolution=32, method="m"), "not method and parameters"),
    (dict(resolution=32, steps=3), "unknown LDT parameter 'steps'"),
    (dict(options=RenderOptions()), "method='ldt'"),
    (dict(rendered="f"), "rendered must be frame 0 as rendered with the given method"),
    (dict(frame=-1), "frame must be"),
])
def test_bad_arguments_are_refused(kwargs, match):
    scene, method, frame = rendered("balls float32 three 32")
    kwargs = dict(kwargs)
    if kwargs.get("method") == "m":
        kwargs["method"] = method
    if kwargs.get("rendered") == "f":
        kwargs.update(rendered=frame, method=LayeredDepthTextures(scene, resolution=32))
    with pytest.raises(RefsoftError, match=match):
        T.trace_pixel(scene, 20, 30, **kwargs)
