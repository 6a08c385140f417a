"""Search time for 15k, 82k and 1M vertices, cold and coherent, on a 1024x768 G-buffer of a
mirror ball covering about a quarter of the view.

Run: ``pytest benchmarks/test_bench_search.py --benchmark-columns=min,median,rounds``; each
benchmark's ``extra_info`` holds the mean iterations and the candidate evaluations per second.
"""

import numpy as np
import pytest

from refsoft import Camera, primitives, raster, search

CAM = Camera(eye=(0.0, 0.0, 3.75), target=(0.0, 0.0, 0.0), fov_y=45.0, width=1024, height=768)
MOVED = Camera(eye=(0.03, 0.02, 3.74), target=(0.0, 0.0, 0.0), fov_y=45.0, width=1024, height=768)
COUNTS = {"15k": 15_000, "82k": 82_000, "1M": 1_000_000}
_CACHE = {}


def setup(n):
    if "gb" not in _CACHE:
        ball = primitives.icosphere(5, 1.0)
        _CACHE["gb"] = raster.gbuffer(ball, CAM, origin=CAM.eye)
        _CACHE["gb_moved"] = raster.gbuffer(ball, MOVED, origin=MOVED.eye)
    if n not in _CACHE:
        rng = np.random.default_rng(0)
        d = rng.normal(size=(n, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        d[:, 2] = np.abs(d[:, 2])  # in front of the ball, where most reflections are visible
        _CACHE[n] = d * rng.uniform(1.3, 4.0, (n, 1))
    return _CACHE["gb"], _CACHE["gb_moved"], _CACHE[n]


def _record(benchmark, res, n_cand):
    evals = float(np.sum(1 + (n_cand - 1) * res.iterations.astype(np.int64)))
    t = benchmark.stats.stats.median
    benchmark.extra_info.update(mean_iterations=float(res.iterations.mean()), max_iterations=int(res.iterations.max()),
                                evaluations_per_second=evals / t, ns_per_evaluation=1e9 * t / evals)


@pytest.mark.parametrize("size", list(COUNTS))
@pytest.mark.parametrize("neighbourhood", ["cross", "box"])
def test_search_cold(benchmark, size, neighbourhood):
    gb, _, verts = setup(COUNTS[size])
    search.search(gb, CAM.eye, verts[:100], neighbourhood)  # compile outside the timing
    benchmark.group = f"search {size} vertices"
    res = benchmark.pedantic(search.search, (gb, CAM.eye, verts, neighbourhood), rounds=3 if size == "1M" else 5)
    _record(benchmark, res, search.NEIGHBOURHOODS[neighbourhood])


@pytest.mark.parametrize("size", list(COUNTS))
def test_search_coherent(benchmark, size):
    gb, gb_moved, verts = setup(COUNTS[size])
    previous = search.search(gb, CAM.eye, verts).pixel
    benchmark.group = f"search {size} vertices"
    res = benchmark.pedantic(search.search, (gb_moved, MOVED.eye, verts), {"previous": previous},
                             rounds=3 if size == "1M" else 5)
    _record(benchmark, res, 5)
