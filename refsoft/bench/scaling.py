"""``refsoft bench scaling``: how run time grows with the work.

- search: a unit mirror ball's G-buffer (``width`` x ``height``), N random vertices in a shell
  around it (radius 1.5 to 6, a fixed seed), cold and coherent (restarted at the cold result),
  N = 1k .. ``max_vertices``;
- raster against triangles: the ball's G-buffer (raster + interpolation) with 80 x 4^s
  triangles, s = 1 .. ``max_subdivisions``;
- raster against resolution: the ball with 20,480 triangles at 128x96 .. ``max_width``.

For each series the slope of log(time) against log(size) is fitted (1 = linear). Each series
and size is one timed task (:mod:`refsoft.bench.tasks`).
"""

from __future__ import annotations

import os

import numpy as np

from ..errors import RefsoftError
from ._common import machine, markdown_table, median_time, plt_or_none, run_bench, write_csv, write_text

COLUMNS = ["series", "size", "time_ms", "per_item_ns"]


def _ball_camera(width, height):
    from ..scene.camera import Camera

    return Camera(eye=(0.0, 0.0, 3.75), target=(0.0, 0.0, 0.0), width=width, height=height)


def _vertices(n, seed=7):
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return d * rng.uniform(1.5, 6.0, size=(n, 1))


def fit_slope(sizes, times) -> float:
    """Slope of log(time) against log(size), least squares."""
    return float(np.polyfit(np.log(np.asarray(sizes, float)), np.log(np.asarray(times, float)), 1)[0])


def plan(width=1024, height=768, max_vertices=1 << 20, max_subdivisions=7, max_width=2048, repeats=3) -> list:
    """The tasks (:class:`refsoft.bench.tasks.Task`), one per series and size; inputs checked here."""
    from .tasks import Task

    for name, v, lo in (("width", width, 1), ("height", height, 1), ("max_vertices", max_vertices, 1),
                        ("max_subdivisions", max_subdivisions, 0), ("max_width", max_width, 1), ("repeats", repeats, 1)):
        if v < lo:
            raise RefsoftError(f"{name.replace('_', '-')} must be at least {lo}, got {v}")
    counts = [n for n in (1 << 10, 1 << 12, 1 << 14, 1 << 16, 1 << 18, 1 << 20) if n <= max_vertices]
    jobs = [("search_cold", n) for n in counts] + [("search_coherent", n) for n in counts]
    jobs += [("raster_triangles", s) for s in range(1, max_subdivisions + 1)]
    jobs += [("raster_resolution", w) for w in (128, 256, 512, 1024, 2048, 4096) if w <= max_width]
    return [Task({"bench": "scaling", "series": series, "size": size, "gbuffer": [width, height], "repeats": repeats},
                 scaling_task, (series, size, width, height, repeats), timing=True, label=f"{series} {size}")
            for series, size in jobs]


_BALL = {}


def _ball_gbuffer(width, height):
    """The unit ball's G-buffer at ``width`` x ``height`` and its camera (once per process)."""
    from ..raster import gbuffer
    from ..scene.primitives import icosphere

    from ._common import _CACHE_LOCK

    with _CACHE_LOCK:
        if (width, height) not in _BALL:
            _BALL.clear()
            cam = _ball_camera(width, height)
            _BALL[(width, height)] = (gbuffer(icosphere(5, 1.0), cam, origin=cam.eye), cam)
        return _BALL[(width, height)]


def scaling_task(series, size, width, height, repeats) -> dict:
    """One series at one size: ``{"row": {"series", "size", "time_ms", "per_item_ns"}}``."""
    from ..raster import gbuffer
    from ..scene.primitives import icosphere
    from ..search import search

    gb, cam = _ball_gbuffer(width, height)
    if series.startswith("search"):
        search(gb, cam.eye, _vertices(64))  # compile outside the timing
        v = _vertices(size)
        if series == "search_cold":
            t, _ = median_time(lambda: search(gb, cam.eye, v), repeats)
        else:
            cold = search(gb, cam.eye, v).pixel
            t, _ = median_time(lambda: search(gb, cam.eye, v, previous=cold), repeats)
        items = size
    elif series == "raster_triangles":
        mesh = icosphere(size, 1.0)
        gbuffer(mesh, cam)
        t, _ = median_time(lambda: gbuffer(mesh, cam), repeats)
        items = size = mesh.n_faces
    else:
        mesh = icosphere(5, 1.0)
        c = _ball_camera(size, size * 3 // 4)
        gbuffer(mesh, c)
        t, _ = median_time(lambda: gbuffer(mesh, c), repeats)
        items = size = c.width * c.height
    return {"row": {"series": series, "size": size, "time_ms": t, "per_item_ns": 1e6 * t / items}}


def scaling(out=None, width=1024, height=768, max_vertices=1 << 20, max_subdivisions=7, max_width=2048, repeats=3,
            progress_bar=False, *, scheduler="serial", workers=None, fresh=False, connect_timeout=None,
            run_info=None) -> dict:
    """Run the three series; returns ``{"rows": [...], "slopes": {series: slope}}`` (written to
    ``out`` as ``scaling.csv``, ``scaling.md``, ``tasks.csv``, ``report.html`` and, with
    matplotlib, ``scaling.png``). ``scheduler``, ``workers``, ``fresh``, ``connect_timeout``: as
    :func:`refsoft.bench.tasks.run_tasks` (results stored in ``out/tasks``); ``run_info``: a
    dict, given the runner's report as ``"run"``."""
    tasks = plan(width, height, max_vertices, max_subdivisions, max_width, repeats)
    run = run_bench(tasks, out, "scaling", progress_bar, scheduler, workers, fresh, connect_timeout)
    if run_info is not None:
        run_info["run"] = run
    rows = [r["row"] for r in run.results]
    slopes = {}
    for s in ("search_cold", "search_coherent", "raster_triangles", "raster_resolution"):
        sel = [r for r in rows if r["series"] == s]
        if len(sel) >= 2:
            slopes[s] = fit_slope([r["size"] for r in sel], [r["time_ms"] for r in sel])
    result = {"rows": rows, "slopes": slopes}
    if out is not None:
        _write(out, result, width, height, repeats, run)
    return result


def _write(out, result, width, height, repeats, run):
    from .report import write_report, write_tasks_csv

    os.makedirs(out, exist_ok=True)
    rows, slopes = result["rows"], result["slopes"]
    write_csv(os.path.join(out, "scaling.csv"), rows, COLUMNS)
    write_tasks_csv(out, run)
    m = machine()
    intro = (f"Median of {repeats} runs; G-buffer {width}x{height} for the search and the triangle series; {m['cpu']}, "
             f"{m['cores']} cores, numpy {m['numpy']}, numba {m['numba']}.")
    slope_rows = [{"series": k, "slope": round(v, 3)} for k, v in slopes.items()]
    headers = ["series", "size", "ms", "ns per item"]
    text = (f"# Scaling\n\n{intro}\n\nFitted slopes of log(time) against log(size) (1 = linear):\n\n"
            + markdown_table(slope_rows, ["series", "slope"]) + "\n" + markdown_table(rows, COLUMNS, headers))
    write_text(os.path.join(out, "scaling.md"), text)
    blocks = [("p", intro), ("p", "Fitted slopes of log(time) against log(size) (1 = linear):"),
              ("table", slope_rows, ["series", "slope"], None), ("table", rows, COLUMNS, headers)]
    plt = plt_or_none()
    if plt is not None:
        _plot(plt, out, rows, slopes)
        blocks.insert(1, ("image", os.path.join(out, "scaling.png"), "time against size, log-log"))
    write_report(out, "Scaling", blocks, run, plots=plt is not None)


def _plot(plt, out, rows, slopes):
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
    panels = ((("search_cold", "search_coherent"), "vertices"), (("raster_triangles",), "triangles"),
              (("raster_resolution",), "pixels"))
    for ax, (series, xlabel) in zip(axes, panels):
        for s in series:
            sel = [r for r in rows if r["series"] == s]
            if sel:
                ax.loglog([r["size"] for r in sel], [r["time_ms"] for r in sel], "o-",
                          label=f"{s} (slope {slopes.get(s, float('nan')):.2f})")
        ax.set_xlabel(xlabel)
        ax.set_ylabel("ms")
        ax.legend(fontsize=7)
        ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    from ..io import atomic_path

    with atomic_path(os.path.join(out, "scaling.png"), ".png") as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
