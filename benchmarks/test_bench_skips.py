"""Each built-in animation rendered with the exact skips on and off (outputs are
bit-identical either way: tests/search/test_skips.py), 640x480, the first 6 frames, coherent.
``extra_info`` lists what was skipped.

Run: ``pytest benchmarks/test_bench_skips.py --benchmark-columns=min,median,rounds``.
"""

import pytest

import refsoft
from refsoft.frame import FrameDriver, RenderOptions

SCENES = ["sphere", "ellipsoid", "planar", "concave", "torus", "quad", "kitchen", "ufo", "ants"]
FRAMES = 6


def _animation(scene, options):
    driver = FrameDriver(scene, options)
    return [driver.render_frame(f) for f in range(min(FRAMES, scene.n_frames) if scene.animation else FRAMES)]


@pytest.mark.parametrize("skips", ["on", "off"])
@pytest.mark.parametrize("name", SCENES)
def test_animation_skips(benchmark, name, skips):
    scene = refsoft.load_scene(name, width=640, height=480)
    options = RenderOptions() if skips == "on" else RenderOptions().without_skips()
    _animation(scene, options)  # compile outside the timing
    benchmark.group = f"skips {name} 640x480 x{FRAMES}"
    frames = benchmark.pedantic(_animation, args=(scene, options), rounds=3)
    sk = [f.skipped for f in frames]
    benchmark.extra_info.update({
        "reflectors_outside_view": sum(len(s["reflectors_outside_view"]) for s in sk),
        "gbuffers_reused": sum(len(s["gbuffers_reused"]) for s in sk),
        "searches_reused": sum(sum(s["searches_reused"].values()) for s in sk),
        "virtual_objects_culled": sum(sum(s["virtual_objects_culled"].values()) for s in sk),
        "virtual_ms": round(sum(f.time_ms["virtual"] for f in frames), 1),
        "search_ms": round(sum(f.time_ms["search"] for f in frames), 1),
    })
