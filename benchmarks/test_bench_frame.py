"""Full frames of the paper scenes at 1024x768, cold (first frame) and coherent (a later frame
rendered right after its predecessor), with per-stage times in ``extra_info``.

Run: ``pytest benchmarks/test_bench_frame.py --benchmark-columns=min,median,rounds``.
"""

import pytest

import refsoft
from refsoft.frame import FrameDriver

SCENES = ["kitchen", "ufo", "ants"]


def _stages(benchmark, frame):
    benchmark.extra_info.update({f"{k}_ms": round(v, 2) for k, v in frame.time_ms.items()})


@pytest.mark.parametrize("name", SCENES)
def test_frame_cold(benchmark, name):
    scene = refsoft.load_scene(name, width=1024, height=768)
    FrameDriver(scene).render_frame(0)  # compile outside the timing
    benchmark.group = f"frame {name} 1024x768"

    def cold():
        return FrameDriver(scene).render_frame(0)

    _stages(benchmark, benchmark.pedantic(cold, rounds=3))


@pytest.mark.parametrize("name", SCENES)
def test_frame_coherent(benchmark, name):
    scene = refsoft.load_scene(name, width=1024, height=768)
    driver = FrameDriver(scene)
    driver.render_frame(0)
    benchmark.group = f"frame {name} 1024x768"
    state = {"f": 0}

    def coherent():
        state["f"] = state["f"] % (scene.n_frames - 1) + 1
        return driver.render_frame(state["f"])

    _stages(benchmark, benchmark.pedantic(coherent, rounds=5))


@pytest.mark.parametrize("name", SCENES)
def test_frame_truth(benchmark, name):
    """The ray-traced truth of the same frames as ``test_frame_coherent`` (frames 1, 2, ...):
    the ratio of the two medians is the coherence speed-up."""
    from refsoft.truth.raytrace import TruthRenderer

    scene = refsoft.load_scene(name, width=1024, height=768)
    renderer = TruthRenderer(scene, exact=False)
    renderer.render_frame(0)  # Embree scene and kernels warmed up outside the timing
    benchmark.group = f"frame {name} 1024x768"
    state = {"f": 0}

    def traced():
        state["f"] = state["f"] % (scene.n_frames - 1) + 1
        return renderer.render_frame(state["f"])

    fr = benchmark.pedantic(traced, rounds=5)
    _stages(benchmark, fr)
    benchmark.extra_info["reflector_pixels"] = fr.report["reflector_pixels"]
