"""Adaptive against full against no tessellation, with and without sub-texel
reflection points (``refine``). The timed call is one coherent frame (frame 1, right after
frame 0 rendered by the same fresh driver in the untimed setup); the agreement of its
``reflected_id`` with the ray-traced truth of the same frame goes in ``extra_info``, with the
vertices searched by the tessellation and the triangles drawn.

Run: ``pytest benchmarks/test_bench_tessellate.py --benchmark-columns=min,median,rounds``.
"""

import numpy as np
import pytest

import refsoft
from refsoft.truth.metrics import disagreement, interior_disagreement
from refsoft.frame import FrameDriver, RenderOptions

SETTINGS = {
    "none": {},
    "none, refine": {"refine": True},
    "adaptive 1e-3": {"tessellate": 1e-3},
    "adaptive 1e-3, refine": {"tessellate": 1e-3, "refine": True},
    "adaptive 1e-5, refine": {"tessellate": 1e-5, "refine": True},
    "full 2 levels": {"tessellate": 0.0, "max_level": 2},
}
CASES = [("quad", "search", (320, 240)), ("quad", "search", (640, 480)), ("quad", "discard", (320, 240)),
         ("sphere", "discard", (320, 240))]
_TRUTH = {}


def _truth(name, size):
    if (name, size) not in _TRUTH:
        scene = refsoft.load_scene(name, width=size[0], height=size[1])
        _TRUTH[name, size] = (scene, refsoft.TruthRenderer(scene).render_frame(1).arrays)
    return _TRUTH[name, size]


@pytest.mark.parametrize("setting", list(SETTINGS))
@pytest.mark.parametrize("name, inverse, size", CASES)
def test_tessellation(benchmark, name, inverse, size, setting):
    scene, truth = _truth(name, size)
    options = RenderOptions(inverse=inverse, **SETTINGS[setting])
    FrameDriver(scene, options).render_frame(0)  # compile outside the timing

    def fresh():
        driver = FrameDriver(scene, options)
        driver.render_frame(0)
        return (driver,), {}

    benchmark.group = f"tessellation {name} {inverse} {size[0]}x{size[1]}"
    frame = benchmark.pedantic(lambda d: d.render_frame(1), setup=fresh, rounds=5)
    got, want = frame.arrays["reflected_id"], truth["reflected_id"]
    counts = frame.skipped.get("tessellation", {}).get("1", {})
    benchmark.extra_info.update(agreement=1.0 - disagreement(got, want),
                                interior=1.0 - interior_disagreement(got, want, truth["object_id"]),
                                vertices_searched=counts.get("vertices_searched", 0),
                                triangles=counts.get("triangles", 0))
    assert np.any(want > 0)
