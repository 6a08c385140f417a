"""``refsoft bench scaling``: how run time grows with the work.

- search: a unit mirror ball's G-buffer (``width`` x ``height``), N random vertices in a shell
  around it (radius 1.5 to 6, a fixed seed), cold and coherent (restarted at the cold result),
  N = 1k .. ``max_vertices``;
- raster against triangles: the ball's G-buffer (raster + interpolation) with 20 x 4^s
  triangles, s = 3 (1,280) .. ``max_subdivisions`` (8: 1,310,720);
- raster against resolution: the ball with 20,480 triangles at widths 32, 128, 512, 2048 and
  8192 (4:3; 768 pixels to 3.1M at 2048), those up to ``max_width``;
- a whole frame against scene triangles: the coherent second frame (accurate preset, ``width``
  x ``height``) of a small scene, a mirror ball (1,280 triangles) and a reflected icosphere of
  20 x 4^s triangles beside it (s = 2 .. ``max_subdivisions``), the camera moving a little
  between the frames so nothing is reused; its rows keep the frame's per-stage milliseconds.

A series starts lower when ``max_subdivisions`` is too small to give it two sizes. For each
series the slope of log(time) against log(size) is fitted (1 = linear). Each series and size
is one timed task (:mod:`refsoft.bench.tasks`).
"""

from __future__ import annotations

import os

import numpy as np

from ..errors import RefsoftError
from ._common import machine, markdown_table, median_time, plt_or_none, run_bench, write_csv, write_text

COLUMNS = ["series", "size", "time_ms", "per_item_ns"]
SERIES = ("search_cold", "search_coherent", "raster_triangles", "raster_resolution", "frame_triangles")
#: The frame series' stages, in the order its table and plot show them.
FRAME_STAGES = ("gbuffer", "search", "tessellate", "virtual", "main", "composite")


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


def top_slope(sizes, times, span=16.0) -> float:
    """:func:`fit_slope` over the sizes within ``span`` of the largest (at least the two
    largest): the growth where fixed costs no longer hide it."""
    sizes, times = np.asarray(sizes, float), np.asarray(times, float)
    order = np.argsort(sizes)
    sizes, times = sizes[order], times[order]
    keep = max(int(np.sum(sizes >= sizes[-1] / span)), 2)
    return fit_slope(sizes[-keep:], times[-keep:])


def plan(width=1024, height=768, max_vertices=1 << 20, max_subdivisions=8, max_width=2048, repeats=3) -> list:
    """The tasks (:class:`refsoft.bench.tasks.Task`), one per series and size; inputs checked here."""
    from .tasks import Task

    for name, v, lo in (("width", width, 1), ("height", height, 1), ("max_vertices", max_vertices, 1),
                        ("max_subdivisions", max_subdivisions, 0), ("max_width", max_width, 1), ("repeats", repeats, 1)):
        if v < lo:
            raise RefsoftError(f"{name.replace('_', '-')} must be at least {lo}, got {v}")
    counts = [n for n in (1 << 10, 1 << 12, 1 << 14, 1 << 16, 1 << 18, 1 << 20) if n <= max_vertices]
    jobs = [("search_cold", n) for n in counts] + [("search_coherent", n) for n in counts]
    jobs += [("raster_triangles", s) for s in range(max(1, min(3, max_subdivisions - 1)), max_subdivisions + 1)]
    jobs += [("raster_resolution", w) for w in (32, 128, 512, 2048, 8192) if w <= max_width]
    jobs += [("frame_triangles", s) for s in range(max(1, min(2, max_subdivisions - 1)), max_subdivisions + 1)]
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


def frame_scene(subdivisions, width, height):
    """The frame series' scene: a mirror ball (icosphere, 3 subdivisions) and a reflected
    icosphere of ``subdivisions`` beside it, 2 frames, the camera moving 0.05 sideways."""
    from ..scene.camera import Camera
    from ..scene.model import Animation, Scene, SceneObject, Transform
    from ..scene.primitives import icosphere

    objects = (SceneObject("ball", icosphere(3, 1.0), (0.9, 0.9, 0.9), Transform((0.0, 0.0, 0.0)), reflector=True),
               SceneObject("other", icosphere(subdivisions, 0.7), (0.85, 0.2, 0.15), Transform((1.4, -0.2, 1.3))))
    camera = Camera(eye=(0.0, 1.2, 5.0), target=(0.0, 0.0, 0.0), fov_y=45.0, width=width, height=height)
    anim = Animation(2, ((0, {"eye": [0.0, 1.2, 5.0]}), (1, {"eye": [0.05, 1.2, 5.0]})))
    return Scene(objects, camera, anim, f"scaling_frame_{subdivisions}")


def _frame_task(subdivisions, width, height, repeats):
    """Median time of the coherent frame 1 (after an untimed frame 0, a fresh driver each
    repeat), the scene's triangles and the median run's stages."""
    import time

    from ..frame.driver import FrameDriver
    from ..options import RenderOptions

    scene = frame_scene(subdivisions, width, height)
    runs = []
    for _ in range(max(int(repeats), 1)):
        driver = FrameDriver(scene, RenderOptions(preset="accurate"))
        driver.render_frame(0)
        t = time.perf_counter()
        fr = driver.render_frame(1)
        runs.append((1000 * (time.perf_counter() - t), fr.time_ms))
    runs.sort(key=lambda r: r[0])
    t, stages = runs[len(runs) // 2]
    triangles = sum(o.mesh.n_faces for o in scene.objects)
    return t, triangles, {k: float(stages.get(k, 0.0)) for k in FRAME_STAGES}


def scaling_task(series, size, width, height, repeats) -> dict:
    """One series at one size: ``{"row": {"series", "size", "time_ms", "per_item_ns"}}`` (the
    frame series' row also has ``stages``, ms per stage)."""
    from ..raster import gbuffer
    from ..scene.primitives import icosphere
    from ..search import search

    if series == "frame_triangles":
        _frame_task(1, width, height, 1)  # kernels compiled outside the timing
        t, triangles, stages = _frame_task(size, width, height, repeats)
        return {"row": {"series": series, "size": triangles, "time_ms": t, "per_item_ns": 1e6 * t / triangles,
                        "stages": stages}}
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


def scaling(out=None, width=1024, height=768, max_vertices=1 << 20, max_subdivisions=8, max_width=2048, repeats=3,
            progress_bar=False, *, scheduler="serial", workers=None, fresh=False, connect_timeout=None,
            run_info=None) -> dict:
    """Run the five series; returns ``{"rows": [...], "slopes": {series: slope}, "top_slopes":
    {series: slope}, "stage_slopes": {stage: slope}, "stage_top_slopes": {stage: slope}}``
    (:func:`fit_slope` over all sizes, :func:`top_slope` over the largest; the stages are the
    frame series'; written to
    ``out`` as ``scaling.csv``, ``scaling.md``, ``tasks.csv``, ``report.html`` and, with
    matplotlib, ``scaling.png``). ``scheduler``, ``workers``, ``fresh``, ``connect_timeout``: as
    :func:`refsoft.bench.tasks.run_tasks` (results stored in ``out/tasks``); ``run_info``: a
    dict, given the runner's report as ``"run"``."""
    tasks = plan(width, height, max_vertices, max_subdivisions, max_width, repeats)
    run = run_bench(tasks, out, "scaling", progress_bar, scheduler, workers, fresh, connect_timeout)
    if run_info is not None:
        run_info["run"] = run
    rows = [r["row"] for r in run.results]
    slopes, top = {}, {}
    for s in SERIES:
        sel = [r for r in rows if r["series"] == s]
        if len(sel) >= 2:
            slopes[s] = fit_slope([r["size"] for r in sel], [r["time_ms"] for r in sel])
            top[s] = top_slope([r["size"] for r in sel], [r["time_ms"] for r in sel])
    result = {"rows": rows, "slopes": slopes, "top_slopes": top, "stage_slopes": stage_slopes(rows),
              "stage_top_slopes": stage_slopes(rows, top_slope)}
    if out is not None:
        _write(out, result, width, height, repeats, run)
    return result


def stage_slopes(rows, fit=fit_slope) -> dict:
    """The slope (``fit``) of each stage of the frame series (stages that took time at every size)."""
    sel = [r for r in rows if r["series"] == "frame_triangles"]
    if len(sel) < 2:
        return {}
    return {k: fit([r["size"] for r in sel], [r["stages"][k] for r in sel])
            for k in FRAME_STAGES if all(r["stages"].get(k, 0.0) > 0 for r in sel)}


def _frame_rows(rows):
    return [{"size": r["size"], "time_ms": r["time_ms"], **r["stages"]}
            for r in rows if r["series"] == "frame_triangles"]


def _write(out, result, width, height, repeats, run):
    from .report import write_report, write_tasks_csv

    os.makedirs(out, exist_ok=True)
    rows, slopes = result["rows"], result["slopes"]
    write_csv(os.path.join(out, "scaling.csv"), rows, COLUMNS)
    write_tasks_csv(out, run)
    m = machine()
    intro = (f"Median of {repeats} runs; {width}x{height} for the search, the triangle and the frame series; {m['cpu']}, "
             f"{m['cores']} cores, numpy {m['numpy']}, numba {m['numba']}.")
    top, stage_top = result["top_slopes"], result["stage_top_slopes"]
    slope_rows = [{"series": k, "slope": round(v, 3), "top": round(top[k], 3)} for k, v in slopes.items()]
    slope_rows += [{"series": f"frame_triangles: {k}", "slope": round(v, 3), "top": round(stage_top[k], 3)}
                   for k, v in result["stage_slopes"].items()]
    slope_cols, slope_headers = ["series", "slope", "top"], ["series", "slope", "slope over the top 16x of sizes"]
    headers = ["series", "size", "ms", "ns per item"]
    frame_rows = _frame_rows(rows)
    frame_cols = ["size", "time_ms", *FRAME_STAGES]
    frame_headers = ["scene triangles", "frame ms", *(f"{k} ms" for k in FRAME_STAGES)]
    text = (f"# Scaling\n\n{intro}\n\nFitted slopes of log(time) against log(size) (1 = linear):\n\n"
            + markdown_table(slope_rows, slope_cols, slope_headers) + "\n" + markdown_table(rows, COLUMNS, headers))
    blocks = [("p", intro), ("p", "Fitted slopes of log(time) against log(size) (1 = linear):"),
              ("table", slope_rows, slope_cols, slope_headers), ("table", rows, COLUMNS, headers)]
    if frame_rows:
        text += "\nThe frame series by stage (ms):\n\n" + markdown_table(frame_rows, frame_cols, frame_headers)
        blocks += [("p", "The frame series by stage (ms):"), ("table", frame_rows, frame_cols, frame_headers)]
    write_text(os.path.join(out, "scaling.md"), text)
    plt = plt_or_none()
    if plt is not None:
        _plot(plt, out, rows, slopes, top)
        blocks.insert(1, ("image", os.path.join(out, "scaling.png"), "time against size, log-log"))
    write_report(out, "Scaling", blocks, run, plots=plt is not None)


def _plot(plt, out, rows, slopes, top):
    fig, axes = plt.subplots(2, 2, figsize=(14, 9.5))
    axes = axes.ravel()
    panels = ((("search_cold", "search_coherent"), "vertices"), (("raster_triangles",), "triangles"),
              (("raster_resolution",), "pixels"), (("frame_triangles",), "scene triangles (whole frame, by stage)"))
    for ax, (series, xlabel) in zip(axes, panels):
        for s in series:
            sel = [r for r in rows if r["series"] == s]
            if sel:
                ax.loglog([r["size"] for r in sel], [r["time_ms"] for r in sel], "o-",
                          label=f"{s} (slope {slopes.get(s, float('nan')):.2f}, top {top.get(s, float('nan')):.2f})")
            if s == "frame_triangles" and sel:
                stage_top = stage_slopes(rows, top_slope)
                for k, v in stage_slopes(rows).items():
                    ax.loglog([r["size"] for r in sel], [r["stages"][k] for r in sel], ".--", lw=0.8,
                              label=f"{k} ({v:.2f}, top {stage_top[k]:.2f})")
        ax.set_xlabel(xlabel, fontsize=11)
        ax.set_ylabel("ms", fontsize=11)
        ax.tick_params(labelsize=10)
        ax.legend(fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    from ..io import atomic_path

    with atomic_path(os.path.join(out, "scaling.png"), ".png") as tmp:  # "tight": no label clipped at an edge
        fig.savefig(tmp, dpi=110, format="png", bbox_inches="tight")
    plt.close(fig)
