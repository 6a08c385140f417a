"""``refsoft bench table1``: the papers' table 1 for the ``kitchen``, ``ufo`` and ``ants``
animations (maximum over frames of the per-frame mean search iterations, and their mean over
the animation), beside the paper's numbers and its frame times (Estalella et al. 2006, table 1:
a 2006 GPU), with this machine's frame times. Each animation is one task
(:mod:`refsoft.bench.tasks`): its frames are rendered in order, each coherent with the last.

The paper states neither its G-buffer's resolution nor how far its cameras move per frame, the
two things the counts depend on most; ``gbuffer_scales`` (the G-buffer's pixel density against
the view's, DESIGN 4.5) and ``slowdowns`` (the same animation rendered with m times the frames,
:func:`slowed`, so the camera and the objects move 1/m as far per frame) tabulate the counts
against both.
"""

from __future__ import annotations

import os

import numpy as np

from ..errors import RefsoftError
from ._common import machine, markdown_table, plan_scene, run_bench, scene_digest, task_scene, write_csv, write_text

#: Estalella et al. 2006, table 1: (max frame mean iterations, total mean, ms per frame).
PAPER_TABLE1 = {"kitchen": (14.9, 4.7, 11.5), "ufo": (71.2, 4.2, 83.0), "ants": (7.5, 3.3, 83.0)}
COLUMNS = ["scene", "gbuffer", "slowdown", "frames", "max_frame_mean", "paper_max_frame_mean", "total_mean",
           "paper_total_mean", "ms_per_frame", "paper_ms_per_frame"]


def slowed(scene, m: int):
    """``scene`` with its animation rendered with ``m`` times the frames: the keys of frame k
    move to frame ``m k`` (``(F - 1) m + 1`` frames), so every pose of the original is frame
    ``m k`` here and the poses between are the same linear path; each frame moves 1/m as far."""
    from dataclasses import replace

    from ..scene.model import Animation

    if not isinstance(m, int) or m < 1:
        raise RefsoftError(f"slowdown must be a positive integer, got {m!r}")
    a = scene.animation
    if a is None or m == 1:
        return scene
    keys = lambda ks: tuple((f * m, v) for f, v in ks)  # noqa: E731
    anim = Animation(frames=(a.frames - 1) * m + 1, camera_keys=keys(a.camera_keys),
                     object_keys={k: keys(v) for k, v in a.object_keys.items()})
    return replace(scene, animation=anim)


def _gbuffer_size(width, height, scale):
    """The G-buffer size of a pixel density ``scale`` times the view's (None: the view's own)."""
    import math

    return None if scale == 1.0 else (max(1, math.ceil(width * scale)), max(1, math.ceil(height * scale)))


def plan(scenes=("kitchen", "ufo", "ants"), width=1024, height=768, frames=None, timing=True,
         gbuffer_scales=(1.0,), slowdowns=(1,)) -> list:
    """The tasks (:class:`refsoft.bench.tasks.Task`), one per animation, G-buffer scale and
    slowdown; inputs checked here. ``frames`` counts the original animation's frames (a slowdown
    m renders ``(frames - 1) m + 1``)."""
    from ..options import RenderOptions
    from .tasks import Task

    if frames is not None and frames < 1:
        raise RefsoftError(f"frames must be at least 1, got {frames}")
    if width < 1 or height < 1:
        raise RefsoftError(f"width and height must be at least 1, got {width}x{height}")
    for g in gbuffer_scales:
        if not (isinstance(g, (int, float)) and 0 < g <= 8):
            raise RefsoftError(f"a G-buffer scale must be in (0, 8], got {g!r}")
    for m in slowdowns:
        if not isinstance(m, int) or not 1 <= m <= 16:
            raise RefsoftError(f"a slowdown must be an integer in [1, 16], got {m!r}")
    tasks = []
    for name in scenes:
        scene, spec = plan_scene(name, width, height)
        n0 = scene.n_frames if frames is None else min(frames, scene.n_frames)
        for g in gbuffer_scales:
            opts = RenderOptions(preset="paper", gbuffer_size=_gbuffer_size(width, height, float(g)))
            for m in slowdowns:
                n = (n0 - 1) * m + 1 if scene.animation is not None else n0
                key = {"bench": "table1", "scene": name, "scene_digest": scene_digest(slowed(scene, m)),
                       "size": [width, height], "frames": list(range(n)), "options": opts.as_dict(),
                       "timing": bool(timing)}
                tasks.append(Task(key, table1_task, (name, spec, width, height, n, bool(timing), float(g), m),
                                  timing=bool(timing), label=f"{name} {n} frames, G-buffer x{g:g}, slowdown {m}"))
    return tasks


def table1_task(name, spec, width, height, n, timing, gbuffer_scale=1.0, slowdown=1) -> dict:
    """One animation's frames 0..n-1 (of the animation slowed ``slowdown`` times), coherent,
    paper preset, the G-buffer at ``gbuffer_scale`` times the view's density: ``{"row": {...}}``."""
    from .. import interrupt
    from ..frame import FrameDriver, frame_stats
    from ..options import RenderOptions

    scene = slowed(task_scene(spec, width, height), slowdown)
    size = _gbuffer_size(width, height, gbuffer_scale)
    paper = RenderOptions(preset="paper", gbuffer_size=size)
    if timing:
        FrameDriver(scene, paper).render_frame(0)  # compile outside the timing
    driver = FrameDriver(scene, paper)
    done = []
    for f in range(n):
        interrupt.check()
        fr = driver.render_frame(f)
        fr.arrays = {}
        done.append(fr)
    s = frame_stats(done)["summary"]
    ref = PAPER_TABLE1.get(name, (None, None, None))
    ms = round(float(np.median([f.time_ms["total"] for f in done[1:] or done])), 1) if timing else None
    gb = "x".join(str(v) for v in (size or (width, height)))
    return {"row": {"scene": name, "gbuffer": gb, "slowdown": slowdown, "frames": n,
                    "max_frame_mean": round(s["max_frame_mean_iterations"], 2),
                    "paper_max_frame_mean": ref[0], "total_mean": round(s["total_mean_iterations"], 2),
                    "paper_total_mean": ref[1], "ms_per_frame": ms, "paper_ms_per_frame": ref[2]}}


def table1(scenes=("kitchen", "ufo", "ants"), out=None, width=1024, height=768, frames=None, progress_bar=False, *,
           timing=True, scheduler="serial", workers=None, fresh=False, connect_timeout=None, run_info=None,
           gbuffer_scales=(1.0,), slowdowns=(1,)) -> list:
    """Render each animation coherently with the paper preset (``frames``: the first N, default
    all) and tabulate, once per G-buffer scale and slowdown (:func:`plan`). ``timing=False``:
    iterations only. ``scheduler``, ``workers``, ``fresh``, ``connect_timeout``: as
    :func:`refsoft.bench.tasks.run_tasks` (results stored in ``out/tasks``); ``run_info``: a
    dict, given the runner's report as ``"run"``."""
    tasks = plan(list(scenes), width, height, frames, timing, tuple(gbuffer_scales), tuple(slowdowns))
    run = run_bench(tasks, out, "table1", progress_bar, scheduler, workers, fresh, connect_timeout)
    if run_info is not None:
        run_info["run"] = run
    rows = [r["row"] for r in run.results]
    if out is not None:
        from .report import write_report, write_tasks_csv

        os.makedirs(out, exist_ok=True)
        write_csv(os.path.join(out, "table1.csv"), rows, COLUMNS)
        write_tasks_csv(out, run)
        m = machine()
        intro = (f"{width}x{height}, coherent, paper preset; gbuffer: the G-buffer's size (the view's own unless "
                 "scaled); slowdown m: the animation rendered with m times the frames, each moving 1/m as far; "
                 "ms per frame: "
                 + (f"median of the coherent frames on {m['cpu']} ({m['cores']} cores)" if timing else
                    "not measured (--no-timing)") + "; the paper's on a 2006 GPU.")
        headers = ["scene", "G-buffer", "slowdown", "frames", "max frame mean", "paper", "total mean", "paper",
                   "ms/frame", "paper ms"]
        write_text(os.path.join(out, "table1.md"), f"# Table 1: search iterations per animation\n\n{intro}\n\n"
                   + markdown_table(rows, COLUMNS, headers))
        write_report(out, "Table 1: search iterations per animation", [("p", intro), ("table", rows, COLUMNS, headers)],
                     run, plots=True)
    return rows
