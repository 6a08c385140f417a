"""``refsoft bench accuracy``: every built-in scene against its ray-traced truth, for both presets
and the accurate preset with one of its parts taken back (which says what each part buys).

For each scene, size and setting: frames spread evenly over the animation (rendered in order, each
coherent with the previous one rendered), and per frame the share of reflector pixels whose
reflected object agrees with the truth (all, interior, within :data:`RIM` pixels of a reflector's
rim), the mean colour error, the specks and holes (one-pixel defects of colour and of reflected
object, :func:`refsoft.truth.metrics.defect_counts`), for spherical reflectors the mean pixel
distance of the reflection points from the exact ones, and the frame time (the frames after the first, warm). Writes
``accuracy.csv`` (a row per scene, size, setting and frame), ``accuracy.md`` (median and worst
frame per scene, size and setting), ``agreement_SCENE_WxH.png`` (the accurate preset's worst
frame: render | truth | agreement map), ``tasks.csv``, ``report.html`` and, with matplotlib,
``accuracy.png`` (agreement against time per scene).

Each scene, size and setting is one task (:mod:`refsoft.bench.tasks`), its result stored in
``OUT/tasks`` and reused by a later run with the same inputs.
"""

from __future__ import annotations

import os
import time

import numpy as np

from .. import keys
from ..constants import RIM_PIXELS as RIM
from ..errors import RefsoftError
from ._common import (machine, markdown_table, plan_scene, plt_or_none, run_bench, scene_digest, task_scene,
                      task_truths, write_csv, write_text)

#: The settings: the two presets, then the accurate preset with one part changed.
SETTINGS = {
    "paper": {"preset": "paper"},
    "accurate": {"preset": "accurate"},
    "accurate, cross": {"preset": "accurate", "neighbourhood": "cross"},
    "accurate, mirror": {"preset": "accurate", "virtual": "mirror"},
    "accurate, no clip": {"preset": "accurate", "silhouette": "texel"},
    "accurate, no refine": {"preset": "accurate", "refine": False},
    "accurate, no tessellation": {"preset": "accurate", "tessellate": None},
    "accurate, tessellate 1e-4, 3 levels": {"preset": "accurate", "tessellate": 1e-4, "max_level": 3},
    "accurate, raster": {"preset": "accurate", "draw": "raster"},
    "accurate, raster, tessellate 1e-4, 3 levels": {"preset": "accurate", "draw": "raster", "tessellate": 1e-4,
                                                    "max_level": 3},
    "accurate, no restart": {"preset": "accurate", "border_restart": False},
    "accurate, hierarchy": {"preset": "accurate", "method": "hierarchy"},
}
COLUMNS = ["scene", "size", "setting", "frame", "agreement", "interior", "rim", "color_error", "specks",
           "speck_fraction", "holes", "hole_fraction", "pixel_distance", "ms"]
SUMMARY = ["scene", "size", "setting", "frames", "median", "worst", "interior", "rim", "color_error", "specks",
           "holes", "ms"]


def frames_of(scene, n: int) -> list:
    """``n`` frames spread evenly over the animation, first and last included (frame 0 of a
    static scene)."""
    if scene.animation is None:
        return [0]
    return sorted({int(round(x)) for x in np.linspace(0, scene.n_frames - 1, max(1, n))})


def plan(scenes=None, sizes=((640, 480), (1024, 768)), frames: int = 5, settings=None, timing=True) -> list:
    """The benchmark's tasks (:class:`refsoft.bench.tasks.Task`), one per scene, size and
    setting, in the order of the rows; every input checked here, before any work."""
    from ..options import RenderOptions
    from ..scene import builtin_names
    from .tasks import Task

    scenes = list(builtin_names() if scenes is None else scenes)
    names = list(SETTINGS) if settings is None else list(settings)
    unknown = [s for s in names if s not in SETTINGS]
    if unknown:
        raise RefsoftError(f"unknown setting {unknown[0]!r} (settings: {', '.join(SETTINGS)})")
    if frames < 1:
        raise RefsoftError(f"frames must be at least 1, got {frames}")
    tasks = []
    for name in scenes:
        for w, h in sizes:
            if w < 1 or h < 1:
                raise RefsoftError(f"sizes must be at least 1x1, got {w}x{h}")
            scene, spec = plan_scene(name, w, h)
            picks = frames_of(scene, frames)
            digest = scene_digest(scene)
            for label in names:
                key = {"bench": "accuracy", "scene": name, "scene_digest": digest, "size": [w, h], "frames": picks,
                       "setting": label, "options": RenderOptions(**SETTINGS[label]).as_dict(),
                       "timing": bool(timing), "picture": label == "accurate"}
                tasks.append(Task(key, accuracy_task, (name, spec, digest, w, h, picks, label, bool(timing)),
                                  timing=bool(timing), label=f"{name} {w}x{h} {label}"))
    return tasks


def accuracy_task(name, spec, digest, w, h, picks, label, timing) -> dict:
    """One setting on one scene's frames at one size, against the truth of those frames
    (computed once per process): ``{"rows": [...]}``, and for the accurate preset its worst
    frame as render | truth | agreement map (``picture``, uint8 (H, 3W, 3))."""
    from .. import interrupt
    from ..frame import FrameDriver
    from ..options import RenderOptions
    from ..visualize import agreement_map, side_by_side

    scene = task_scene(spec, w, h)
    truths = {f: t.arrays for f, t in zip(picks, task_truths(scene, picks, digest))}
    opts = RenderOptions(**SETTINGS[label])
    if timing:
        FrameDriver(scene, opts).render_frame(picks[0])  # compile outside the timing
    driver = FrameDriver(scene, opts)
    rows, worst = [], None
    for i, f in enumerate(picks):
        interrupt.check()
        t0 = time.perf_counter()
        fr = driver.render_frame(f)
        ms = 1000 * (time.perf_counter() - t0)
        row = {"scene": name, "size": f"{w}x{h}", "setting": label, "frame": f,
               "ms": ms if timing and (i > 0 or len(picks) == 1) else None}
        row.update(_frame_errors(fr.arrays, truths[f]))
        rows.append(row)
        if label == "accurate" and (worst is None or row["agreement"] < worst[0]):
            worst = (row["agreement"], f, fr.arrays)
    out = {"rows": rows}
    if worst is not None:
        a, f, render = worst
        t = truths[f]
        out["picture"] = side_by_side(render["image"], t["image"],
                                      agreement_map(render["reflected_id"], t["reflected_id"], t["image"]))
        out["picture_frame"] = f
    return out


def accuracy(scenes=None, out=None, sizes=((640, 480), (1024, 768)), frames: int = 5, settings=None,
             progress_bar=False, *, timing=True, scheduler="serial", workers=None, fresh=False, connect_timeout=None,
             run_info=None) -> list:
    """Run the accuracy benchmark; returns the per-frame rows (also written to ``out``).

    Parameters
    ----------
    scenes : list of str, optional
        Built-in scenes (default all).
    out : str or PathLike, optional
    sizes : list of (width, height)
    frames : int
        Frames per animation, spread evenly.
    settings : list of str, optional
        Names from :data:`SETTINGS` (default all).
    progress_bar : bool
    timing : bool
        False: agreement figures only (``ms`` empty).
    scheduler, workers, fresh, connect_timeout
        As :func:`refsoft.bench.tasks.run_tasks`; results are stored in ``out/tasks`` and reused.
    run_info : dict, optional
        Given the runner's :class:`~refsoft.bench.tasks.RunReport` as ``"run"``.
    """
    scenes = list(scenes) if scenes is not None else None
    tasks = plan(scenes, [tuple(z) for z in sizes], frames, settings, timing)
    run = run_bench(tasks, out, "accuracy", progress_bar, scheduler, workers, fresh, connect_timeout)
    if run_info is not None:
        run_info["run"] = run
    rows, worst_pictures = [], {}
    for task, result in zip(tasks, run.results):
        rows += result["rows"]
        if "picture" in result:
            k = task.key
            worst_pictures[(k["scene"], f"{k['size'][0]}x{k['size'][1]}")] = result["picture"]
    if out is not None:
        _write(out, rows, worst_pictures, frames, timing, run)
    return rows


def _frame_errors(render, truth) -> dict:
    from ..truth.metrics import color_error, defect_counts, disagreement, pixel_distance, reflector_pixels, rim

    rid, tid, obj = render["reflected_id"], truth["reflected_id"], truth["object_id"]
    edge = np.zeros(tid.shape, dtype=bool)
    for k in np.unique(obj[tid >= 0]):
        edge |= rim(obj == k, RIM)
    out = {"agreement": 1.0 - disagreement(rid, tid), "interior": 1.0 - disagreement(rid, tid, ~edge),
           "rim": 1.0 - disagreement(rid, tid, edge),
           "color_error": color_error(render["image"], truth["image"], reflector_pixels(tid))["mean"],
           **defect_counts(render, truth)}
    dists = []
    for key in truth:
        if key.startswith("exact_reflection_point_"):
            k = key.rsplit("_", 1)[1]
            exact = truth[key]
            ok = np.all(np.isfinite(exact), axis=1) & ((render[keys.FLAGS(k)] & 1) == 0)
            d = pixel_distance(render[keys.REFLECTION_PIXEL(k)], exact, render[keys.GBUFFER_VIEW_PROJ(k)],
                               render[keys.GBUFFER_MASK(k)].shape)[ok]
            dists.append(d)
    if dists and sum(len(d) for d in dists):
        out["pixel_distance"] = float(np.concatenate(dists).mean())
    return out


def summarize(rows) -> list:
    """Per scene, size and setting: the median and worst frame's agreement, the median interior
    and rim agreement, colour error, specks and holes per frame, and warm ms per frame."""
    out = []
    keys = sorted({(r["scene"], r["size"], r["setting"]) for r in rows},
                  key=lambda k: ([r["scene"] for r in rows].index(k[0]), k[1], list(SETTINGS).index(k[2])))
    for scene, size, setting in keys:
        sel = [r for r in rows if (r["scene"], r["size"], r["setting"]) == (scene, size, setting)]
        a = np.array([r["agreement"] for r in sel])
        ms = [r["ms"] for r in sel if r["ms"] is not None]
        out.append({"scene": scene, "size": size, "setting": setting, "frames": len(sel),
                    "median": float(np.median(a)), "worst": float(a.min()),
                    "interior": float(np.median([r["interior"] for r in sel])),
                    "rim": float(np.median([r["rim"] for r in sel])),
                    "color_error": float(np.median([r["color_error"] for r in sel])),
                    "specks": float(np.median([r["specks"] for r in sel])),
                    "holes": float(np.median([r["holes"] for r in sel])),
                    "ms": float(np.median(ms)) if ms else None})
    return out


def _write(out, rows, worst_pictures, frames, timing, run):
    from ..io import write_png
    from .report import write_report, write_tasks_csv

    os.makedirs(out, exist_ok=True)
    write_csv(os.path.join(out, "accuracy.csv"), rows, COLUMNS)
    write_tasks_csv(out, run)
    summary = summarize(rows)
    m = machine()
    pct = [dict(r, **{k: 100 * r[k] for k in ("median", "worst", "interior", "rim")}) for r in summary]
    intro = (f"Up to {frames} frames spread over each animation; agreement is the share (%) of reflector pixels whose "
             f"reflected object is the truth's (median and worst frame; interior and rim: more and less than {RIM} "
             f"pixels from a reflector's rim, median); specks and holes: one-pixel defects of colour and of "
             f"reflected object per frame (median); "
             + ("ms per warm frame" if timing else "no timing (--no-timing)")
             + f"; {m['cpu']}, {m['cores']} cores, numpy {m['numpy']}, numba {m['numba']}.")
    headers = ["scene", "size", "setting", "frames", "median %", "worst %", "interior %", "rim %", "colour error",
               "specks", "holes", "ms/frame"]
    write_text(os.path.join(out, "accuracy.md"), f"# Accuracy against the ray-traced truth\n\n{intro}\n\n"
               + markdown_table(pct, SUMMARY, headers))
    blocks = [("p", intro), ("table", pct, SUMMARY, headers)]
    pictures = []
    for (scene, size), picture in worst_pictures.items():
        path = os.path.join(out, f"agreement_{scene}_{size}.png")
        write_png(path, picture)
        pictures.append(("image", path, f"{scene} {size}: render | truth | agreement"))
    plt = plt_or_none()
    if plt is not None and timing:
        _plot(plt, out, summary)
        blocks.insert(1, ("image", os.path.join(out, "accuracy.png"), "agreement against time per scene"))
    if pictures:
        blocks += [("h2", "The accurate preset's worst frame: render | truth | agreement (green agrees, red "
                          "differs)")] + pictures
    write_report(out, "Accuracy against the ray-traced truth", blocks, run, plots=plt is not None)


def _plot(plt, out, summary):
    from ..io import atomic_path

    scenes = list(dict.fromkeys(r["scene"] for r in summary))
    fig, axes = plt.subplots(1, len(scenes), figsize=(5.0 * len(scenes), 4.4), squeeze=False)
    for ax, name in zip(axes[0], scenes):
        for size, marker in zip(sorted({r["size"] for r in summary}), "os^"):
            sel = [r for r in summary if r["scene"] == name and r["size"] == size and r["ms"] is not None]
            ax.scatter([r["ms"] for r in sel], [100 * r["median"] for r in sel], marker=marker, s=16, label=size)
            for r in sel:
                if r["setting"] in ("paper", "accurate"):
                    ax.annotate(r["setting"], (r["ms"], 100 * r["median"]), fontsize=9, xytext=(3, 2),
                                textcoords="offset points")
        ax.set_title(name, fontsize=12)
        ax.set_xlabel("ms per frame", fontsize=11)
        ax.set_ylabel("agreement with the truth (%)", fontsize=11)
        ax.tick_params(labelsize=10)
        ax.legend(fontsize=9)
    fig.tight_layout()
    with atomic_path(os.path.join(out, "accuracy.png"), ".png") as tmp:  # "tight": no label clipped at an edge
        fig.savefig(tmp, dpi=110, format="png", bbox_inches="tight")
    plt.close(fig)
