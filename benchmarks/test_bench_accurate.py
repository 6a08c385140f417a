"""The accurate preset's price: its coherent frame against the paper preset's, on every built-in
convex scene at 1024x768 and 640x480. The two presets render the same frames alternately in
one process (each driver renders frame 0 first, outside the timing: the kernels compiled and
the searches coherent); the timed call is the accurate frame, the paper frame of the same frame
number is timed just before it (in the untimed setup), and ``extra_info`` holds the paper
median, the ratio of the medians, the ratio of the two presets' median process CPU time per frame
(``cpu_ratio``: every thread's; it varies less with a shared machine's load) and the accurate
frame's median stage times (``tessellate`` holds the tessellation and the silhouette cut).

Run: ``pytest benchmarks/test_bench_accurate.py --benchmark-columns=min,median,rounds``
(``benchmarks/accurate_price.py`` prints the same ratios with the tessellation and the cut
timed apart).
"""

import statistics
import time

import pytest

import refsoft
from refsoft.frame import FrameDriver, RenderOptions

SCENES = ["sphere", "ellipsoid", "quad", "kitchen", "ufo", "ants", "planar"]
SIZES = [(1024, 768), (640, 480)]


@pytest.mark.parametrize("size", SIZES, ids=lambda s: f"{s[0]}x{s[1]}")
@pytest.mark.parametrize("name", SCENES)
def test_accurate_against_paper(benchmark, name, size):
    scene = refsoft.load_scene(name, width=size[0], height=size[1])
    paper = FrameDriver(scene, RenderOptions(preset="paper"))
    accurate = FrameDriver(scene, RenderOptions(preset="accurate"))
    paper.render_frame(0)
    accurate.render_frame(0)
    benchmark.group = f"accurate against paper {size[0]}x{size[1]}"
    state = {"f": 0, "paper": [], "stages": [], "cpu": {"paper": [], "accurate": []}}

    def paper_first():
        state["f"] = state["f"] % max(1, scene.n_frames - 1) + 1 if scene.n_frames > 1 else 0
        t, c = time.perf_counter(), time.process_time()
        paper.render_frame(state["f"])
        state["paper"].append(1000 * (time.perf_counter() - t))
        state["cpu"]["paper"].append(time.process_time() - c)
        return (state["f"],), {}

    def accurate_frame(f):
        c = time.process_time()
        fr = accurate.render_frame(f)
        state["cpu"]["accurate"].append(time.process_time() - c)
        state["stages"].append(fr.time_ms)
        return fr

    benchmark.pedantic(accurate_frame, setup=paper_first, rounds=3)
    paper_ms = statistics.median(state["paper"])
    accurate_ms = benchmark.stats.stats.median * 1000
    stages = {k: round(statistics.median(s.get(k, 0.0) for s in state["stages"]), 2) for k in state["stages"][0]}
    cpu = {p: statistics.median(v) for p, v in state["cpu"].items()}
    benchmark.extra_info.update(paper_ms=round(paper_ms, 2), ratio=round(accurate_ms / paper_ms, 3),
                                cpu_ratio=round(cpu["accurate"] / cpu["paper"], 3),
                                **{f"{k}_ms": v for k, v in stages.items()})
    assert paper_ms > 0
