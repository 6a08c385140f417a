"""`refsoft bench scaling`'s plan, slope fits and frame series, at sizes that run in seconds."""

import numpy as np

from refsoft.bench.scaling import FRAME_STAGES, fit_slope, frame_scene, plan, scaling_task, stage_slopes, top_slope


def _sizes(tasks, series):
    return [t.key["size"] for t in tasks if t.key["series"] == series]


def test_plan_spans_1k_to_1m():
    tasks = plan(max_vertices=1 << 20, max_subdivisions=8, max_width=2048, repeats=1)
    for series in ("search_cold", "search_coherent"):
        assert _sizes(tasks, series)[0] == 1 << 10 and _sizes(tasks, series)[-1] == 1 << 20
    faces = [20 * 4 ** s for s in _sizes(tasks, "raster_triangles")]  # an icosphere's faces
    assert faces[0] < 2000 and faces[-1] > 1_000_000
    pixels = [w * (w * 3 // 4) for w in _sizes(tasks, "raster_resolution")]
    assert pixels[0] < 1000 and pixels[-1] > 1_000_000
    tris = [sum(o.mesh.n_faces for o in frame_scene(s, 64, 48).objects) for s in _sizes(tasks, "frame_triangles")]
    assert tris[0] < 2000 and tris[-1] > 1_000_000


def test_small_plans_keep_two_sizes_per_series():
    tasks = plan(max_vertices=4096, max_subdivisions=2, max_width=256, repeats=1)
    for series in ("search_cold", "raster_triangles", "raster_resolution", "frame_triangles"):
        assert len(_sizes(tasks, series)) == 2, series


def test_fit_and_stage_slopes_recover_power_laws():
    sizes = np.array([1e3, 1e4, 1e5, 1e6])
    assert abs(fit_slope(sizes, 3.0 * sizes ** 1.25) - 1.25) < 1e-9
    rows = [{"series": "frame_triangles", "size": float(n), "time_ms": 1.0,
             "stages": {"search": 2.0 * n ** 0.5, "main": 0.1 * n, "tessellate": 0.0}} for n in sizes]
    got = stage_slopes(rows)
    assert set(got) == {"search", "main"}  # a stage that took no time at some size is left out
    assert abs(got["search"] - 0.5) < 1e-9 and abs(got["main"] - 1.0) < 1e-9


def test_top_slope_fits_the_largest_sizes_only():
    sizes = np.array([1e3, 1e4, 1e5, 1e6, 4e6])
    times = np.where(sizes < 5e5, 1.0, sizes ** 1.5)  # flat (a fixed cost), then steep
    assert abs(top_slope(sizes[::-1], times[::-1]) - 1.5) < 1e-9  # 1e6 and 4e6, in any order
    assert abs(top_slope(sizes, times, span=400) - fit_slope(sizes[1:], times[1:])) < 1e-12  # 1e4 and up


def test_frame_task_reports_stages():
    row = scaling_task("frame_triangles", 1, 64, 48, 1)["row"]
    assert row["size"] == sum(o.mesh.n_faces for o in frame_scene(1, 64, 48).objects)
    assert set(row["stages"]) == set(FRAME_STAGES)
    assert 0 < sum(row["stages"].values()) <= row["time_ms"]
