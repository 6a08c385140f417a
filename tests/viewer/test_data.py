"""What trace.html embeds (refsoft.viewer.data): every step and every candidate of the trace, the
heat map's values at every pixel, the side view's geometry; the page is one file that fetches nothing."""

import json
import re

import numpy as np
import pytest

from refsoft.errors import RefsoftError
from refsoft.search import BORDER
from refsoft.viewer import page_html, trace_data, write_trace_page


def _page_data(html):
    m = re.search(r'<script type="application/json" id="trace-data">(.*?)</script>', html, re.S)
    return json.loads(m.group(1))


def _same(a, b):
    return a is None and b is None or a is not None and b is not None and float(f"{b:.9g}") == a


@pytest.mark.parametrize("which", ["walk_replay", "inverse_replay"])
def test_walk_data_holds_every_step_and_every_candidate(which, request):
    rp = request.getfixturevalue(which)
    tr = rp.trace
    d = trace_data(rp)
    assert d["kind"] == "walk" and len(d["steps"]) == len(tr.steps) == tr.iterations
    assert d["start"] == tr.start and d["end"] == tr.pixel
    for st, s in zip(d["steps"], tr.steps):
        assert st["pixel"] == s["pixel"] and st["phase"] == s["phase"]
        assert st["grid"] == (1 if s["phase"] == "inverse" else 0)
        assert [c["name"] for c in st["cells"]] == [c["name"] for c in s["candidates"]] == d["columns"]
        for c, sc in zip(st["cells"], s["candidates"]):
            assert c["pixel"] == sc["pixel"] and c["status"] == sc["status"] and _same(c["value"], sc["score"])
        assert (st["chosen"] is None) == (s["move_to"] is None)
        if s["move_to"] is not None:
            assert st["cells"][st["chosen"]]["pixel"] == s["move_to"]
    assert ("Capped" in d["stop"]) == (tr.stop == "capped")


@pytest.mark.parametrize("which", ["walk_replay", "inverse_replay"])
def test_walk_heat_maps_are_the_score_fields_at_every_pixel(which, request):
    rp = request.getfixturevalue(which)
    mask = rp.gbuffer.mask
    d = trace_data(rp)
    fields = [rp.trace.score_map] + ([] if rp.trace.inverse_map is None else [rp.trace.inverse_map])
    assert len(d["grids"]) == len(fields)
    for g, field in zip(d["grids"], fields):
        vals = np.array(g["values"], dtype=object).reshape(g["h"], g["w"])
        rows, cols = np.nonzero(mask)
        assert g["r0"] <= rows.min() and rows.max() < g["r0"] + g["h"]  # the box holds every covered pixel
        assert g["c0"] <= cols.min() and cols.max() < g["c0"] + g["w"]
        for i in range(g["h"]):
            for j in range(g["w"]):
                r, c = g["r0"] + i, g["c0"] + j
                want = float(field[r, c]) if mask[r, c] else None
                assert _same(vals[i, j], want), (r, c)


def test_walk_side_view_keeps_distances_in_the_plane(walk_replay):
    rp = walk_replay
    d = trace_data(rp)
    pts = {p["name"]: np.array(p["xy"]) for p in d["side"]["points"]}
    P = rp.gbuffer.position[tuple(rp.trace.pixel)].astype(np.float64) + rp.gbuffer.origin
    assert np.allclose(pts["reflection point P"], 0.0)
    # eye and vertex lie in the drawing's plane: their distances to P are kept
    for name, X in (("eye O", rp.eye), ("vertex V", rp.position)):
        assert np.isclose(np.linalg.norm(pts[name]), np.linalg.norm(X - P), rtol=1e-6)
    # the virtual vertex, mirrored across the tangent plane, is off the drawing's plane by the
    # normal's tilt out of it: drawn no farther from P than the vertex
    assert np.linalg.norm(pts["virtual vertex V'"]) <= np.linalg.norm(rp.position - P) * (1 + 1e-9)
    assert len([s for s in d["steps"] if s["side"] is not None]) == len(d["steps"])


def test_hierarchy_data_holds_every_event(hierarchy_replay):
    tr = hierarchy_replay.trace
    d = trace_data(hierarchy_replay)
    assert d["kind"] == "hierarchy"
    popped = [s for s in tr.steps if s["event"] in ("popped", "chosen")]
    assert [s["phase"] for s in d["steps"]] == [s["event"] for s in popped]
    first = next(i for i, s in enumerate(tr.steps) if s["event"] == "popped")
    assert sum(len(s["cells"]) for s in d["steps"]) == len(tr.steps) - first - len(popped)
    assert d["steps"][-1]["rect"][:2] == tr.pixel and d["end"] == tr.pixel
    for st, ev in zip(d["steps"], popped):
        side = 1 << ev["level"]
        assert st["rect"][2:] == [side, side]


def test_ldt_data_holds_every_sample_and_bisection_point(ldt_trace):
    tr = ldt_trace
    d = trace_data(tr)
    faces = [fc for o in tr.objects for fc in o["faces"]]
    want = []
    for fc in faces:
        want += [("linear", s["texel"], len(s["layers"])) for s in fc["samples"]]
        points = (fc["bisection"] or {"points": []})["points"]
        want += [("bisection", p["texel"], 0 if p["z"] is None else 1) for p in points]
    assert [(s["phase"], s["pixel"], len(s["cells"])) for s in d["steps"]] == want
    assert len(d["grids"]) == len(faces)
    assert d["steps"][-1]["pixel"] == tr.result["texel"] or tr.result["binary_steps"] == 0
    assert "Hit: object" in d["stop"]
    hit = next(p for p in d["side"]["points"] if p["name"].startswith("hit"))
    assert np.isclose(np.linalg.norm(hit["xy"]), tr.result["distance"], rtol=1e-5)


def test_page_is_one_file_that_fetches_nothing(walk_replay, tmp_path):
    write_trace_page(tmp_path, walk_replay)
    html = (tmp_path / "trace.html").read_text()
    assert _page_data(html) == json.loads(json.dumps(trace_data(walk_replay)))
    assert not re.search(r"(src|href)\s*=|https?://(?!www\.w3\.org/2000/svg)|fetch\(|XMLHttpRequest|import\(", html)


def test_page_data_cannot_close_its_script_block(walk_replay):
    d = trace_data(walk_replay)
    d["title"] = "a </script><script>alert(1)</script>"
    html = page_html(d)
    assert html.count("</script>") == 2 and _page_data(html)["title"] == d["title"]


def test_trace_data_refuses_other_objects():
    with pytest.raises(RefsoftError, match="VertexReplay or a PixelTrace"):
        trace_data(object())


def test_page_is_the_same_bytes_on_every_run_and_thread_count(walk_replay, tmp_path):
    import numba

    from refsoft.search.trace import trace_vertex

    write_trace_page(tmp_path / "a", walk_replay)
    scene = __import__("refsoft").load_scene("sphere", width=160, height=120)
    numba.set_num_threads(1)
    try:
        write_trace_page(tmp_path / "b", trace_vertex(scene, 1500, neighbourhood="box"))
    finally:
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    assert (tmp_path / "a" / "trace.html").read_bytes() == (tmp_path / "b" / "trace.html").read_bytes()


def test_hierarchy_result_counts_the_popped_texels_apart_from_the_chosen_pixel(hierarchy_replay):
    tr = hierarchy_replay.trace
    d = trace_data(hierarchy_replay)
    popped = sum(s["event"] == "popped" for s in tr.steps)
    chosen = sum(s["event"] == "chosen" for s in tr.steps)
    assert chosen == 1 and f"{tr.tests} texel tests, {popped} texels popped, then the chosen pixel" == d["result"][0]
    assert sum(s["phase"] == "popped" for s in d["steps"]) == popped


@pytest.mark.parametrize("which", ["walk_replay", "inverse_replay"])
def test_side_caption_says_which_case_it_draws(which, request):
    rp = request.getfixturevalue(which)
    gb = rp.gbuffer
    P = gb.position[tuple(rp.trace.pixel)].astype(np.float64) + gb.origin
    N = gb.normal[tuple(rp.trace.pixel)].astype(np.float64)
    behind = float((rp.position - P) @ N) < 0.0
    caption = trace_data(rp)["side"]["caption"]
    assert ("behind the tangent plane" in caption) == behind
    border = bool(rp.trace.flags & BORDER)
    assert ("coincide to the pixel grid's precision" in caption) == (not behind and not border)
    assert ("on the reflector's border" in caption) == (border and not behind)
    if behind:
        assert "do not coincide" in caption


def test_each_method_has_its_own_legend_and_last_column(walk_replay, hierarchy_replay, ldt_trace):
    w, h, l = trace_data(walk_replay), trace_data(hierarchy_replay), trace_data(ldt_trace)
    assert len({w["legend"], h["legend"], l["legend"]}) == 3
    assert "moved to" in w["legend"] and "pink" not in w["legend"]  # no images were given
    assert all(k in h["legend"] for k in ("pushed", "rejected", "green dot", "L0")) and "moved to" not in h["legend"]
    assert "layer" in l["legend"] and "sample" in l["legend"] and "moved to" not in l["legend"]
    assert (w["last_column"], h["last_column"], l["last_column"]) == ("move", "children pushed", "decision")
    assert w["label_column"] is None and h["label_column"] == "texel" and l["label_column"] == "sample"
    for st in h["steps"]:  # the label is the texel, not the event again
        assert st["phase"] not in st["label"]
        assert st["note"] == ("the result" if st["phase"] == "chosen" else
                              f"{sum(c['status'] == 'pushed' for c in st['cells'])} of {len(st['cells'])} pushed"
                              if st["cells"] else "none tested")


def test_ldt_side_ray_reaches_the_last_sample(ldt_trace):
    d = trace_data(ldt_trace)
    a, b = (np.array(p) for p in d["side"]["rays"][1])
    reach = np.linalg.norm(b - a)
    far = max(np.linalg.norm(np.array(s["side"]["xy"]) - a) for s in d["steps"])
    assert reach >= far * (1 - 1e-6)


def test_an_empty_map_says_so():
    from refsoft.viewer.data import _grid

    vals = np.arange(12.0).reshape(3, 4)
    assert _grid(vals, np.zeros((3, 4), bool), (0, 3, 0, 4), "t", "l", "f", "linear")["empty"]
    assert not _grid(vals, np.eye(3, 4, dtype=bool), (0, 3, 0, 4), "t", "l", "f", "linear")["empty"]


def test_hierarchy_labels_name_the_pass_after_the_first(hierarchy_replay):
    tr = hierarchy_replay.trace
    d = trace_data(hierarchy_replay)
    events = [s for s in tr.steps if s["event"] in ("popped", "chosen")]
    for st, ev in zip(d["steps"], events):
        assert (f"pass {ev['attempt'] + 1}" in st["label"]) == (ev["attempt"] > 0)
