"""``refsoft bench sweep``: run time against error over the knobs that trade one for the other.

One factor at a time around the defaults (the paper's method): each knob takes each of its
values while the others keep theirs. The knobs: G-buffer resolution scale, widen factor, search
method (walk or Szabo's hierarchy, and the comparison methods: the layered depth textures and
the environment map, beside the ray-traced truth's own run time), neighbourhood (crosshair or box), precision, hidden-vertex mode and Szabo's adaptive
tessellation (threshold 1e-3, 3 levels), and sub-texel
reflection points (``refine``). For every scene and setting: the median run time of
``repeats`` coherent renders of frames 0..F-1 (a fresh driver each time, JIT warmed up before),
and the error of the last render against the ray-traced truth of the same frames (computed once
per scene): reflected-id disagreement (all and interior), mean colour error, and for spherical
reflectors the mean distance of the virtual vertices and reflection pixels from the exact ones.

Each scene and setting is one task (:mod:`refsoft.bench.tasks`), run serially or on a Dask
cluster, its result stored in ``OUT/tasks`` and reused by a later run with the same inputs.
"""

from __future__ import annotations

import math
import os

import numpy as np

from ..errors import RefsoftError
from ._common import (machine, markdown_table, median_time, numba_threads, plan_scene, plt_or_none, run_bench,
                      scene_digest, task_scene, task_truths, write_csv, write_text)

#: The knobs and their values; the first value of each is the paper preset's. Each other value
#: is one setting: the paper preset with that knob changed (``preset=accurate``: the accurate
#: preset itself; ``method=ldt|envmap``: that method with its defaults; ``method=truth``: the
#: ray-traced truth itself, whose error is zero by definition: its run time is the reference).
KNOBS = {
    "preset": ("paper", "accurate"),
    "gbuffer_scale": (1.0, 0.5, 2.0),
    "widen": (1.0, 1.25, 1.5),
    "neighbourhood": ("cross", "box"),
    "method": ("walk", "hierarchy", "ldt", "envmap", "truth"),
    "precision": ("float32", "float64"),
    "inverse": ("plane", "search", "discard"),
    "tessellate": (None, 1e-3),
    "refine": (False, True),
    "virtual": ("mirror", "unfold"),
    "silhouette": ("texel", "clip"),
}
COLUMNS = ["scene", "setting", "knob", "value", "time_ms", "threads", "disagreement", "interior_disagreement",
           "color_error_mean", "virtual_distance_mean", "pixel_distance_mean", "iterations_mean", "pareto"]


def settings(knobs=None) -> list:
    """``[(name, knob, value, options)]``: the paper preset ("paper"), then each knob's other
    values, named by their preset ("paper, KNOB=VALUE"; the preset knob's rows by the preset's name;
    the per-pixel methods, which read no preset, "method=NAME")."""
    knobs = KNOBS if knobs is None else {k: v for k, v in KNOBS.items() if k in knobs}
    out = [("paper", "", "", {})]
    for knob, values in knobs.items():
        for v in values[1:]:
            if knob == "preset":
                name = str(v)
            elif knob == "method" and v in ("ldt", "envmap", "truth"):  # per-pixel methods: no preset read
                name = f"method={v}"
            else:
                name = f"paper, {knob}={v}"
            out.append((name, knob, v, {knob: v}))
    return out


def _options(setting, width, height):
    from ..options import RenderOptions

    opts = dict(setting)
    if opts.get("method") == "truth":
        return None
    if opts.get("method") in ("ldt", "envmap"):  # the per-pixel methods read none of the presets' options
        return RenderOptions(method=opts["method"])
    preset = opts.pop("preset", "paper")
    scale = opts.pop("gbuffer_scale", 1.0)
    widen = opts.get("widen", 1.0)
    if scale != 1.0:
        opts["gbuffer_size"] = (max(1, math.ceil(width * widen * scale)), max(1, math.ceil(height * widen * scale)))
    return RenderOptions(preset=preset, **opts)


def _errors(frames, truths) -> dict:
    from ..truth.metrics import frame_metrics

    ms = [frame_metrics(f.arrays, t.arrays) for f, t in zip(frames, truths)]
    row = {"disagreement": float(np.mean([m["reflected_id_disagreement"] for m in ms])),
           "interior_disagreement": float(np.mean([m["interior_disagreement"] for m in ms])),
           "color_error_mean": float(np.mean([m["color_error"]["mean"] for m in ms]))}
    vd = [v["virtual_distance_mean"] for m in ms for v in m.get("vertices", {}).values() if "virtual_distance_mean" in v]
    pd = [v["pixel_distance_mean"] for m in ms for v in m.get("vertices", {}).values() if "pixel_distance_mean" in v]
    row["virtual_distance_mean"] = float(np.mean(vd)) if vd else None
    row["pixel_distance_mean"] = float(np.mean(pd)) if pd else None
    its = [v["mean"] for f in frames for v in f.iterations.values()]
    row["iterations_mean"] = float(np.mean(its)) if its else 0.0
    return row


def pareto_front(times, errors) -> np.ndarray:
    """True for the settings no other setting beats in both time and error."""
    t, e = np.asarray(times, float), np.asarray(errors, float)
    front = np.ones(len(t), dtype=bool)
    for i in range(len(t)):
        better = (t <= t[i]) & (e <= e[i]) & ((t < t[i]) | (e < e[i]))
        front[i] = not better.any()
    return front


def plan(scenes=("sphere", "quad", "kitchen"), width=320, height=240, frames=3, repeats=3, knobs=None,
         timing=True) -> list:
    """The sweep's tasks (:class:`refsoft.bench.tasks.Task`), one per scene and setting, in the
    order of the rows; every input checked here, before any work."""
    from .tasks import Task

    if knobs is not None:
        unknown = [k for k in knobs if k not in KNOBS]
        if unknown:
            raise RefsoftError(f"unknown knob {unknown[0]!r} (knobs: {', '.join(KNOBS)})")
    if frames < 1 or repeats < 1:
        raise RefsoftError("frames and repeats must be at least 1")
    if width < 1 or height < 1:
        raise RefsoftError(f"width and height must be at least 1, got {width}x{height}")
    tasks = []
    for name in scenes:
        scene, spec = plan_scene(name, width, height)
        n = min(frames, scene.n_frames)
        digest = scene_digest(scene)
        for label, knob, value, setting in settings(knobs):
            opts = _options(setting, width, height)  # checked here
            key = {"bench": "sweep", "scene": name, "scene_digest": digest, "size": [width, height],
                   "frames": list(range(n)), "setting": label,
                   "options": {"method": "truth"} if opts is None else opts.as_dict(), "timing": bool(timing),
                   "repeats": repeats if timing else None}
            tasks.append(Task(key, sweep_task, (name, spec, digest, width, height, n, label, knob, value, setting,
                                                repeats, bool(timing)), timing=bool(timing), label=f"{name} {label}"))
    return tasks


def sweep_task(name, spec, digest, width, height, n, label, knob, value, setting, repeats, timing) -> dict:
    """One setting on one scene's frames 0..n-1 (the truth of those frames included, computed
    once per process): ``{"row": {...}}``, its time and errors."""
    from .. import interrupt
    from ..frame import FrameDriver

    scene = task_scene(spec, width, height)
    truths = task_truths(scene, range(n), digest)
    opts = _options(setting, width, height)

    def run():
        if opts is None:
            from ..truth.raytrace import TruthRenderer

            d = TruthRenderer(scene)
        else:
            d = FrameDriver(scene, opts)
        out = []
        for f in range(n):
            interrupt.check()
            out.append(d.render_frame(f))
        return out

    row = {"scene": name, "setting": label, "knob": knob, "value": value}
    if timing:
        run()  # compile and warm up outside the timing
        t, done = median_time(run, repeats)
        row.update(time_ms=t / n, threads=numba_threads())
    else:
        done = run()
        row.update(time_ms=None, threads=None)
    row.update(_errors(done, truths))
    return {"row": row}


def sweep(scenes=("sphere", "quad", "kitchen"), out=None, width=320, height=240, frames=3, repeats=3, knobs=None,
          progress_bar=False, *, timing=True, scheduler="serial", workers=None, fresh=False,
          connect_timeout=None, run_info=None) -> list:
    """Run the sweep; returns the rows (also written to ``out``: ``sweep.csv``, ``sweep.md``,
    ``tasks.csv``, ``report.html`` and, with matplotlib, ``pareto.png``).

    ``timing=False``: error figures only (``time_ms`` and ``pareto`` empty). ``scheduler``,
    ``workers``, ``fresh``, ``connect_timeout``: as :func:`refsoft.bench.tasks.run_tasks`; the
    results are stored in ``out/tasks`` and reused by a later run. ``run_info``: a dict, given
    the runner's :class:`~refsoft.bench.tasks.RunReport` as ``"run"``."""
    scenes = list(scenes)
    tasks = plan(scenes, width, height, frames, repeats, knobs, timing)
    run = run_bench(tasks, out, "sweep", progress_bar, scheduler, workers, fresh, connect_timeout)
    if run_info is not None:
        run_info["run"] = run
    rows = [r["row"] for r in run.results]
    for name in scenes:
        sel = [r for r in rows if r["scene"] == name]
        if timing:
            front = pareto_front([r["time_ms"] for r in sel], [r["disagreement"] for r in sel])
        for i, r in enumerate(sel):
            r["pareto"] = bool(front[i]) if timing else None
    if out is not None:
        _write(out, rows, scenes, width, height, frames, repeats, timing, run)
    return rows


def _write(out, rows, scenes, width, height, frames, repeats, timing, run):
    from .report import write_report, write_tasks_csv

    os.makedirs(out, exist_ok=True)
    write_csv(os.path.join(out, "sweep.csv"), rows, COLUMNS)
    write_tasks_csv(out, run)
    m = machine()
    how = (f"median of {repeats} runs per setting" if timing else "errors only (no timing)")
    intro = (f"{width}x{height}, frames 0-{frames - 1} (coherent), {how}; {m['cpu']}, {m['cores']} cores, numpy "
             f"{m['numpy']}, numba {m['numba']}.")
    legend = ("Every row is the paper preset (the sweep's baseline; refsoft render's default is the accurate preset) "
              "with at most the one knob its name gives changed (the rows method=ldt, envmap and truth read no preset). Time is per frame; agreement is the share (%) of "
              "reflector pixels whose reflected object is the ray-traced truth's, as in refsoft bench accuracy "
              "(sweep.csv keeps the disagreement, 1 - agreement, as a fraction); * marks the Pareto front (no "
              "setting is both faster and closer).")
    text = [f"# Sweep: run time against error\n\n{intro}\n{legend}\n"]
    cols = ["setting", "time_ms", "agreement", "interior_agreement", "color_error_mean", "virtual_distance_mean",
            "iterations_mean"]
    headers = ["setting", "ms/frame", "agreement %", "interior %", "colour error", "V' distance", "iterations"]
    blocks = [("p", intro), ("p", legend)]
    for name in scenes:
        sel = [dict(r, setting=("* " if r["pareto"] else "") + r["setting"], agreement=100 * (1 - r["disagreement"]),
                    interior_agreement=100 * (1 - r["interior_disagreement"])) for r in rows if r["scene"] == name]
        text.append(f"\n## {name}\n\n" + markdown_table(sel, cols, headers))
        blocks += [("h2", name), ("table", sel, cols, headers)]
    write_text(os.path.join(out, "sweep.md"), "".join(text))
    plt = plt_or_none()
    if plt is not None and timing:
        _plot(plt, out, rows, scenes)
        blocks.insert(2, ("image", os.path.join(out, "pareto.png"), "agreement against time per setting"))
    elif not timing:
        blocks.insert(2, ("p", "No Pareto plot: the run took no times (--no-timing)."))
    write_report(out, "Sweep: run time against error", blocks, run, plots=plt is not None)


def _plot(plt, out, rows, scenes):
    fig, axes = plt.subplots(1, len(scenes), figsize=(6.0 * len(scenes), 5.0), squeeze=False)
    for ax, name in zip(axes[0], scenes):
        sel = [r for r in rows if r["scene"] == name]
        t = np.array([r["time_ms"] for r in sel])
        e = np.array([100 * (1 - r["disagreement"]) for r in sel])
        f = np.array([r["pareto"] for r in sel])
        ax.scatter(t[~f], e[~f], c="0.6", s=18)
        order = np.argsort(t[f])
        ax.plot(t[f][order], e[f][order], "o-", c="tab:red", ms=4)
        for r, x, y in zip(sel, t, e):
            ax.annotate(r["setting"], (x, y), fontsize=8, xytext=(3, 2), textcoords="offset points")
        ax.set_title(name, fontsize=12)
        ax.set_xlabel("ms per frame", fontsize=11)
        ax.set_ylabel("agreement with the truth (%)", fontsize=11)
        ax.tick_params(labelsize=10)
    fig.tight_layout()
    from ..io import atomic_path

    with atomic_path(os.path.join(out, "pareto.png"), ".png") as tmp:  # "tight": no label clipped at an edge
        fig.savefig(tmp, dpi=110, format="png", bbox_inches="tight")
    plt.close(fig)
