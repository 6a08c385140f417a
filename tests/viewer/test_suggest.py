"""``refsoft trace SCENE`` without a vertex lists vertices worth tracing, and each is what it says."""

import numpy as np
import pytest

import refsoft
from refsoft import cli
from refsoft.search import BORDER, CULLED, HIDDEN
from refsoft.search.reflect import reflect
from refsoft.search.suggest import interesting_vertices
from refsoft.search.trace import trace_vertex


@pytest.fixture(scope="module")
def sphere():
    return refsoft.load_scene("sphere", width=96, height=72)


def test_suggestions_are_what_they_say(sphere):
    found = interesting_vertices(sphere, inverse="search")
    res = reflect(sphere, 0, inverse="search")[2][1].result
    live = (res.flags & CULLED) == 0
    by = {f["kind"]: f for f in found}
    assert by["longest search"]["iterations"] == int(res.iterations[live].max())
    assert by["hidden (behind the tangent plane)"]["flags"] & HIDDEN
    assert by["on the reflector's border"]["flags"] & BORDER
    for f in found:
        v = f["vertex"]
        assert f["iterations"] == res.iterations[v] and f["flags"] == res.flags[v]
        assert f["pixel"] == list(res.pixel[v])
        # the trace of a suggestion (without coherence) is the search listed
        tr = trace_vertex(sphere, v, coherence=False, inverse="search").trace
        assert tr.iterations == f["iterations"] and tr.pixel == f["pixel"]


def test_trace_without_vertex_lists_instead_of_refusing(capsys):
    assert cli.main(["trace", "sphere", "--width", "96", "--height", "72"]) == 0
    out = capsys.readouterr().out
    assert "vertices worth tracing" in out and "longest search" in out and "typical (median length)" in out
    assert "refsoft trace sphere --vertex " in out and "--width 96 --height 72" in out
    assert "search options given here" not in out


def test_the_suggested_command_carries_the_search_options_given(capsys):
    assert cli.main(["trace", "sphere", "--width", "96", "--height", "72", "--neighbourhood", "box",
                     "--inverse", "search"]) == 0
    line = [x for x in capsys.readouterr().out.splitlines() if x.startswith("trace one with:")][0]
    assert "--neighbourhood box" in line and "--inverse search" in line


def test_several_images_are_suggested_and_circled_in_the_page(tmp_path, capsys):
    import json
    import re

    scene = refsoft.load_scene("concave", width=160, height=120)
    found = {f["kind"]: f for f in interesting_vertices(scene)}
    several = found["several images"]
    assert several["flags"] & 32  # SEVERAL
    v = several["vertex"]
    assert cli.main(["trace", "concave", "--vertex", str(v), "--width", "160", "--height", "120",
                     "--out", str(tmp_path)]) == 0
    assert "every image circled" in capsys.readouterr().out
    listed = json.loads((tmp_path / "images.json").read_text())["images"]
    page = (tmp_path / "trace.html").read_text()
    data = json.loads(re.search(r'id="trace-data">(.*?)</script>', page, re.S).group(1))
    assert len(listed) >= 2 and data["images"] == listed
    assert f"every image: {len(listed)} found" in data["result"][-1]
    # trace.png circles every image too, and its title says SEVERAL
    import imageio.v3 as iio

    from refsoft.search import pictures

    png = iio.imread(tmp_path / "trace.png")[..., :3]
    assert np.all(png == pictures._RING, axis=-1).sum() > 2 * 40 * len(listed)


def test_hierarchy_trace_prints_pixels_as_the_rest_and_explains_attempt(tmp_path, capsys):
    assert cli.main(["trace", "sphere", "--vertex", "100", "--method", "hierarchy", "--width", "80", "--height", "60",
                     "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    result = [x for x in out.splitlines() if x.startswith("result: pixel")][0]
    assert "[" not in result and "(" in result
    assert "attempt: " in out
