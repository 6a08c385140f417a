"""Shared traces for the viewer's tests: a walk, a hierarchy traversal and an LDT pixel search,
each made once per session on small scenes."""

import pytest

import refsoft


@pytest.fixture(scope="session")
def walk_replay():
    from refsoft.search.trace import trace_vertex

    scene = refsoft.load_scene("sphere", width=160, height=120)
    return trace_vertex(scene, 1500, neighbourhood="box")


@pytest.fixture(scope="session")
def inverse_replay():
    """A walk with an inverse phase: the first vertex whose search goes on behind the tangent plane."""
    from refsoft.search.trace import trace_vertex

    scene = refsoft.load_scene("sphere", width=96, height=72)
    for v in range(0, 3000, 37):
        rp = trace_vertex(scene, v, inverse="search")
        if any(s["phase"] == "inverse" for s in rp.trace.steps):
            return rp
    raise AssertionError("no vertex of the sphere scene had an inverse search")


@pytest.fixture(scope="session")
def hierarchy_replay():
    from refsoft.search.trace import trace_vertex

    scene = refsoft.load_scene("sphere", width=160, height=120)
    return trace_vertex(scene, 1500, method="hierarchy")


@pytest.fixture(scope="session")
def ldt_trace():
    """The reflector pixel of a small balls frame whose search samples most before a hit found by bisection."""
    from refsoft import FrameDriver, RenderOptions
    from refsoft.ldt.method import LayeredDepthTextures
    from refsoft.ldt.trace import trace_pixel

    scene = refsoft.load_scene("balls", width=64, height=48)
    method = LayeredDepthTextures(scene, resolution=32)
    frame = FrameDriver(scene, RenderOptions(method="ldt", ldt_resolution=32), method=method).render_frame(0)
    st = frame.reflectors[scene.reflector_ids[0]].state
    best = None
    for i in range(0, len(st.rows), 7):
        tr = trace_pixel(scene, int(st.rows[i]), int(st.cols[i]), 0, method=method, rendered=frame)
        r = tr.result
        if r["object"] >= 0 and r["binary_steps"] > 0 and (best is None or r["linear_samples"] > best[0]):
            best = (r["linear_samples"], tr)
    assert best is not None, "no pixel of the balls frame hit by bisection"
    return best[1]
