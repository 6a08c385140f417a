"""The accurate preset's price over the paper preset, per built-in convex scene: both presets
render the same frames alternately in one process (frame 0 once each first, outside the timing,
so the kernels are compiled and the searches coherent), and the script prints per scene and size
the median frame time of each preset, their ratio and the stages of each (the accurate frame's
tessellation and silhouette cut timed apart).

Run: ``python benchmarks/accurate_price.py [SCENE ...] [--sizes 1024x768 640x480] [--frames 3]`` (the
scenes first: ``--sizes`` takes every word after it).
With ``--cut``: instead, the silhouette cut of one accurate frame (frame 1 after frame 0), its
steps predicted (the preset's) against plain bisection, timed alternately in one process (median
of 7), with the searches each ran.
With ``--acceptance``: instead, the exact drawing's acceptance of one accurate frame (frame 1
after frame 0, every reflector), each pixel's ray walked through the candidates' hierarchy
against the candidates' own loop (the same bits), timed alternately in one process (median of 7),
with the candidates their bounds cover per valid pixel and the way the preset takes.
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import time

import numpy as np

import refsoft
from refsoft.frame import FrameDriver, RenderOptions
from refsoft.search import acceptance, exact, silhouette, virtual

SCENES = ["sphere", "ellipsoid", "quad", "kitchen", "ufo", "ants", "planar"]
_SPLIT = {"tessellate_only": 0.0, "clip": 0.0}


def _timed(fn, name):
    def wrapper(*args, **kwargs):
        t = time.perf_counter()
        try:
            return fn(*args, **kwargs)
        finally:
            _SPLIT[name] += 1000 * (time.perf_counter() - t)
    return wrapper


virtual.tessellate = _timed(virtual.tessellate, "tessellate_only")
silhouette.clip_at_silhouette = _timed(silhouette.clip_at_silhouette, "clip")


def measure(name, size, frames):
    """Median frame ms of each preset and the accurate frames' median stage times."""
    scene = refsoft.load_scene(name, width=size[0], height=size[1])
    drivers = {p: FrameDriver(scene, RenderOptions(preset=p)) for p in ("paper", "accurate")}
    for d in drivers.values():
        d.render_frame(0)
    totals = {p: [] for p in drivers}
    cpu = {p: [] for p in drivers}
    stages, paper_stages = [], []
    picks = [1 + (i % max(1, scene.n_frames - 1)) for i in range(frames)]
    for f in picks:
        for p, d in drivers.items():
            for key in _SPLIT:
                _SPLIT[key] = 0.0
            c = time.process_time()
            fr = d.render_frame(f)
            cpu[p].append(1000 * (time.process_time() - c))
            totals[p].append(fr.time_ms["total"])
            (stages if p == "accurate" else paper_stages).append({**fr.time_ms, **_SPLIT})
    med = {p: statistics.median(v) for p, v in totals.items()}
    st = {k: statistics.median(s.get(k, 0.0) for s in stages) for k in stages[0]}
    st["cpu_ratio"] = statistics.median(cpu["accurate"]) / statistics.median(cpu["paper"])
    pst = {k: statistics.median(s.get(k, 0.0) for s in paper_stages) for k in paper_stages[0]}
    return med, st, pst


def _owned(value):
    """``value`` with its arrays copied (in tuples and in dataclasses' fields too)."""
    if isinstance(value, np.ndarray):
        return value.copy()
    if isinstance(value, tuple):
        return tuple(_owned(v) for v in value)
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return dataclasses.replace(value, **{f.name: _owned(getattr(value, f.name)) for f in dataclasses.fields(value)
                                             if f.init})
    return value


def _frame_one_calls(module, function, name, size):
    """The arguments (args, kwargs) of every call of ``module.function`` while an accurate driver
    renders frame 1 of scene ``name`` at ``size`` (after frame 0, outside the record)."""
    calls = []
    real = getattr(module, function)

    def spy(*args, **kwargs):
        # copies: a stage may hand over views of memory it reuses for the next reflector
        calls.append((_owned(args), {k: _owned(v) for k, v in kwargs.items()}))
        return real(*args, **kwargs)

    setattr(module, function, spy)
    try:
        scene = refsoft.load_scene(name, width=size[0], height=size[1])
        driver = FrameDriver(scene, RenderOptions(preset="accurate"))
        driver.render_frame(0)
        calls.clear()
        driver.render_frame(min(1, scene.n_frames - 1))
    finally:
        setattr(module, function, real)
    return calls


def measure_cut(name, size, rounds=7):
    """Median ms of frame 1's silhouette cuts (every reflector) with predicted steps and with
    plain bisection, and the searches of each."""
    clip = silhouette.clip_at_silhouette
    calls = _frame_one_calls(silhouette, "clip_at_silhouette", name, size)
    times = {True: [], False: []}
    searched = {}
    for _ in range(rounds):
        for predict in (True, False):
            t = time.perf_counter()
            out = [clip(*a, **{**k, "predict": predict}) for a, k in calls]
            times[predict].append(1000 * (time.perf_counter() - t))
            searched[predict] = sum(c.searched for c in out)
    edges = sum(c.cut for c in out)
    return {p: statistics.median(v) for p, v in times.items()}, searched, edges


def measure_acceptance(name, size, rounds=7):
    """Frame 1's acceptances (every reflector): median ms walked and looped, the candidates per
    valid pixel their bounds cover, and whether the preset walks (per reflector, in order)."""
    nearest = exact.nearest  # the exact drawing's, as exact_pass calls it
    calls = [((cand, *args), kwargs) for (cand, *args), kwargs in _frame_one_calls(exact, "nearest", name, size)
             if not kwargs.get("runs", True) and cand.rays is None]
    times = {True: [], False: []}
    for _ in range(rounds):
        for traced in (True, False):
            t = time.perf_counter()
            for args, kwargs in calls:
                nearest(*args, **{**kwargs, "traced": traced})
            times[traced].append(1000 * (time.perf_counter() - t))
    cover, walks = [], []
    for (cand, *args), kwargs in calls:
        valid, bbox, box = kwargs["rays"][0], kwargs["screen"][1], args[2]
        h, c0, c1 = valid.shape[0], int(box[2]), int(box[3])
        rows = (bbox[:, 1].clip(0, h) - bbox[:, 0].clip(0, h)).clip(0)
        cols = (bbox[:, 3].clip(c0, c1) - bbox[:, 2].clip(c0, c1)).clip(0)
        cover.append(float((rows * cols).sum()) / max(int(valid.sum()), 1))
        walks.append(acceptance._trace_pays(valid, bbox, h, c0, c1, cand.real, None))
    return {t: statistics.median(v) for t, v in times.items()}, cover, walks


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", nargs="*", default=SCENES)
    ap.add_argument("--sizes", nargs="+", default=["1024x768", "640x480"])
    ap.add_argument("--frames", type=int, default=3)
    ap.add_argument("--cut", action="store_true", help="time the silhouette cut alone, predicted against bisection")
    ap.add_argument("--acceptance", action="store_true",
                    help="time the exact drawing's acceptance alone, walked against looped")
    args = ap.parse_args(argv)
    if args.acceptance:
        print("scene size | walked ms | looped ms | candidates covering a pixel (per reflector) | walked by the preset")
        for size in args.sizes:
            w, h = (int(x) for x in size.split("x"))
            for name in args.scenes:
                ms, cover, walks = measure_acceptance(name, (w, h))
                print(f"{name} {size} | {ms[True]:.1f} | {ms[False]:.1f} | {' '.join(f'{c:.0f}' for c in cover)} | "
                      f"{sum(walks)} of {len(walks)}", flush=True)
        return
    if args.cut:
        print("scene size edges | predicted: ms searches | bisection: ms searches")
        for size in args.sizes:
            w, h = (int(x) for x in size.split("x"))
            for name in args.scenes:
                ms, n, edges = measure_cut(name, (w, h))
                print(f"{name} {size} {edges} | {ms[True]:.1f} {n[True]} | {ms[False]:.1f} {n[False]}", flush=True)
        return
    print("scene size paper_ms accurate_ms ratio cpu_ratio | accurate stages (ms) | paper stages (ms)")
    for size in args.sizes:
        w, h = (int(x) for x in size.split("x"))
        for name in args.scenes:
            med, st, pst = measure(name, (w, h), args.frames)
            keys = ("gbuffer", "search", "tessellate_only", "clip", "virtual", "main")
            parts = " ".join(f"{k}={st.get(k, 0.0):.0f}" for k in keys)
            parts += " | paper: " + " ".join(f"{k}={pst.get(k, 0.0):.0f}" for k in ("gbuffer", "search", "virtual", "main"))
            ratio = med["accurate"] / med["paper"]
            print(f"{name} {size} {med['paper']:.0f} {med['accurate']:.0f} {ratio:.2f} {st['cpu_ratio']:.2f} | {parts}",
                  flush=True)


if __name__ == "__main__":
    main()
