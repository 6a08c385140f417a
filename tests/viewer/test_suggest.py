"""``refsoft trace SCENE`` without a vertex lists vertices worth tracing, and each is what it says."""

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
