"""``refsoft bench table1``: the papers' table 1 for the ``kitchen``, ``ufo`` and ``ants``
animations (maximum over frames of the per-frame mean search iterations, and their mean over
the animation), beside the paper's numbers and its frame times (Estalella et al. 2006, table 1:
a 2006 GPU), with this machine's frame times. Each animation is one task
(:mod:`refsoft.bench.tasks`): its frames are rendered in order, each coherent with the last.
"""

from __future__ import annotations

import os

import numpy as np

from ..errors import RefsoftError
from ._common import machine, markdown_table, plan_scene, run_bench, scene_digest, task_scene, write_csv, write_text

#: Estalella et al. 2006, table 1: (max frame mean iterations, total mean, ms per frame).
PAPER_TABLE1 = {"kitchen": (14.9, 4.7, 11.5), "ufo": (71.2, 4.2, 83.0), "ants": (7.5, 3.3, 83.0)}
COLUMNS = ["scene", "frames", "max_frame_mean", "paper_max_frame_mean", "total_mean", "paper_total_mean",
           "ms_per_frame", "paper_ms_per_frame"]


def plan(scenes=("kitchen", "ufo", "ants"), width=1024, height=768, frames=None, timing=True) -> list:
    """The tasks (:class:`refsoft.bench.tasks.Task`), one per animation; inputs checked here."""
    from ..options import RenderOptions
    from .tasks import Task

    if frames is not None and frames < 1:
        raise RefsoftError(f"frames must be at least 1, got {frames}")
    if width < 1 or height < 1:
        raise RefsoftError(f"width and height must be at least 1, got {width}x{height}")
    tasks = []
    for name in scenes:
        scene, spec = plan_scene(name, width, height)
        n = scene.n_frames if frames is None else min(frames, scene.n_frames)
        key = {"bench": "table1", "scene": name, "scene_digest": scene_digest(scene), "size": [width, height],
               "frames": list(range(n)), "options": RenderOptions(preset="paper").as_dict(), "timing": bool(timing)}
        tasks.append(Task(key, table1_task, (name, spec, width, height, n, bool(timing)), timing=bool(timing),
                          label=f"{name} {n} frames"))
    return tasks


def table1_task(name, spec, width, height, n, timing) -> dict:
    """One animation's frames 0..n-1, coherent, paper preset: ``{"row": {...}}``."""
    from .. import interrupt
    from ..frame import FrameDriver, frame_stats
    from ..options import RenderOptions

    scene = task_scene(spec, width, height)
    paper = RenderOptions(preset="paper")
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
    return {"row": {"scene": name, "frames": n, "max_frame_mean": round(s["max_frame_mean_iterations"], 2),
                    "paper_max_frame_mean": ref[0], "total_mean": round(s["total_mean_iterations"], 2),
                    "paper_total_mean": ref[1], "ms_per_frame": ms, "paper_ms_per_frame": ref[2]}}


def table1(scenes=("kitchen", "ufo", "ants"), out=None, width=1024, height=768, frames=None, progress_bar=False, *,
           timing=True, scheduler="serial", workers=None, fresh=False, connect_timeout=None, run_info=None) -> list:
    """Render each animation coherently with the paper preset (``frames``: the first N, default
    all) and tabulate. ``timing=False``: iterations only. ``scheduler``, ``workers``, ``fresh``,
    ``connect_timeout``: as :func:`refsoft.bench.tasks.run_tasks` (results stored in
    ``out/tasks``); ``run_info``: a dict, given the runner's report as ``"run"``."""
    tasks = plan(list(scenes), width, height, frames, timing)
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
        intro = (f"{width}x{height}, coherent, paper preset; ms per frame: "
                 + (f"median of the coherent frames on {m['cpu']} ({m['cores']} cores)" if timing else
                    "not measured (--no-timing)") + "; the paper's on a 2006 GPU.")
        headers = ["scene", "frames", "max frame mean", "paper", "total mean", "paper", "ms/frame", "paper ms"]
        write_text(os.path.join(out, "table1.md"), f"# Table 1: search iterations per animation\n\n{intro}\n\n"
                   + markdown_table(rows, COLUMNS, headers))
        write_report(out, "Table 1: search iterations per animation", [("p", intro), ("table", rows, COLUMNS, headers)],
                     run, plots=True)
    return rows
