"""The ray-traced truth against the render it measures: every built-in scene at 1024x768, the
accurate preset's coherent frame and the truth's (exact sphere points included) of the same
frames, in one run.

Run: ``pytest benchmarks/test_bench_truth.py --benchmark-columns=median,rounds``; the ratio of
the ``truth`` and ``render`` medians of a scene is its truth/render ratio.
"""

import pytest

import refsoft
from refsoft.frame import FrameDriver
from refsoft.truth.raytrace import TruthRenderer

SCENES = refsoft.builtin_names()


def _frames(scene, rounds=4):
    """Frames spread over the animation (frame 0 for a static scene), the first one warm-up."""
    n = scene.n_frames
    return [0] * (rounds + 1) if n == 1 else [round(i * (n - 1) / rounds) for i in range(rounds + 1)]


@pytest.mark.parametrize("kind", ["render", "truth"])
@pytest.mark.parametrize("name", SCENES)
def test_truth_against_render(benchmark, name, kind):
    scene = refsoft.load_scene(name, width=1024, height=768)
    runner = FrameDriver(scene) if kind == "render" else TruthRenderer(scene)
    frames = iter(_frames(scene))
    runner.render_frame(next(frames))  # compiled, Embree scene built, coherent from here
    benchmark.group = f"truth against render {name} 1024x768"
    fr = benchmark.pedantic(lambda: runner.render_frame(next(frames)), rounds=4, iterations=1)
    benchmark.extra_info.update({f"{k}_ms": round(v, 2) for k, v in fr.time_ms.items()})
