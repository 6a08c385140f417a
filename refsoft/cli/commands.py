"""The subcommands: each reads its arguments, calls the library and prints a short summary."""

from __future__ import annotations

import os
import time

import numpy as np

from ..errors import RefsoftError
from .options import ldt_kwargs, render_kwargs, search_kwargs


def _scene(args):
    from ..scene import load_scene

    return load_scene(args.scene, subdivide=args.subdivide, width=args.width, height=args.height)


def _one_of(args):
    """--frames N or --frame K (not both), as the library's ``frames`` argument."""
    if args.frame is not None and args.frames is not None:
        raise RefsoftError("give --frames N or --frame K, not both")
    return args.frames


def cmd_scenes(args) -> int:
    from ..scene import BUILTIN_SCENES, counts_before_after, load_scene
    from ..scene.builtin.counts import BUILTIN_COUNTS

    print(f"{'name':<10} {'vertices (built -> subdivided)':>30} {'triangles (built -> subdivided)':>31} "
          f"{'reflectors':>10} {'frames':>6}  description")
    for name, (_, desc) in BUILTIN_SCENES.items():
        if args.subdivide is None:  # the scenes as they load: a table checked by the tests, nothing built
            vb, va, tb, ta, reflectors, frames = BUILTIN_COUNTS[name]
        else:
            scene = load_scene(name, subdivide=args.subdivide)
            c, ba = scene.counts(), counts_before_after(scene)
            (vb, va), (tb, ta), reflectors, frames = ba["vertices"], ba["triangles"], c["reflectors"], c["frames"]
        print(f"{name:<10} {f'{vb} -> {va}':>30} {f'{tb} -> {ta}':>31} {reflectors:>10} {frames:>6}  {desc}")
    return 0


def cmd_gbuffer(args) -> int:
    from ..frame.outputs import write_gbuffers

    scene = _scene(args)
    t0 = time.perf_counter()
    done = write_gbuffers(scene, args.out, args.frame, None if args.reflector is None else [args.reflector],
                          args.widen, args.precision, args.memory_limit)
    for k, covered, w, h in done:
        print(f"reflector {k} ({scene.object_by_id(k).name}): {covered} covered pixels of {w * h} at {w}x{h}")
    print(f"wrote {args.out}/gbuffer.png (positions | normals), view.png and gbuffer_K.npz "
          f"in {1000 * (time.perf_counter() - t0):.0f} ms")
    return 0


def _trace_ldt_pixel(args, scene) -> int:
    from ..ldt.trace import trace_pixel, write_pixel_trace
    from ..options import RenderOptions
    from ..viewer import write_trace_page

    given = [flag for flag, v in (("--vertex", args.vertex), ("--reflector", args.reflector),
                                  ("--neighbourhood", args.neighbourhood), ("--inverse", args.inverse),
                                  ("--widen", args.widen), ("--no-coherence", args.no_coherence or None))
             if v is not None]
    if given:
        raise RefsoftError(f"{given[0]} is an option of the vertex search's trace; --method ldt traces --pixel ROW COL")
    if args.pixel is None:
        raise RefsoftError("--method ldt traces one reflector pixel: give --pixel ROW COL")
    kwargs = {"method": "ldt", **ldt_kwargs(args)}
    if args.precision is not None:
        kwargs["precision"] = args.precision
    tr = trace_pixel(scene, args.pixel[0], args.pixel[1], args.frame, options=RenderOptions(**kwargs))
    print(tr.describe())
    print(tr.table(bisection=args.bisection))
    written = write_pixel_trace(args.out, tr) + [write_trace_page(args.out, tr)]
    print(f"wrote {args.out}/" + ", ".join(written) + " (open trace.html in a browser to step through the search)"
          + ("" if "trace.png" in written else " (no picture: pip install '.[plot]' for matplotlib)"))
    return 0


def _suggest_vertices(args, scene) -> int:
    """``refsoft trace SCENE`` without ``--vertex``: list vertices worth tracing."""
    import shlex

    from ..search import flag_names
    from ..search.suggest import interesting_vertices

    opts = search_kwargs(args)
    opts.pop("coherence", None)
    found = interesting_vertices(scene, args.reflector, args.frame, **opts)
    k = args.reflector or scene.reflector_ids[0]
    print(f"no --vertex given: vertices worth tracing in reflector {k} ({scene.object_by_id(k).name!r}), frame "
          f"{args.frame} (each searched from the reflector's centre, without coherence):")
    print(f"{'what':<34} {'vertex':>7} {'iterations':>10}  {'pixel':<12} flags")
    for f in found:
        pix = f"({f['pixel'][0]}, {f['pixel'][1]})"
        print(f"{f['kind']:<34} {f['vertex']:>7} {f['iterations']:>10}  {pix:<12} "
              f"{', '.join(flag_names(f['flags'])) or 'none'}")
    if found:
        extra = [] if args.frame == 0 else ["--frame", str(args.frame), "--no-coherence"]
        for flag, v in (("--width", args.width), ("--height", args.height), ("--subdivide", args.subdivide),
                        ("--reflector", args.reflector)):
            extra += [] if v is None else [flag, str(v)]
        preset = None if args.preset == "accurate" else args.preset  # the default needs no saying
        for flag, v in (("--preset", preset), ("--method", args.method), ("--neighbourhood", args.neighbourhood),
                        ("--inverse", args.inverse), ("--widen", args.widen), ("--precision", args.precision)):
            extra += [] if v is None else [flag, str(v)]
        print("trace one with: refsoft trace " + shlex.join([args.scene, "--vertex", str(found[0]["vertex"]), *extra])
              + "; the LDT: --method ldt --pixel ROW COL")
    return 0


def cmd_trace(args) -> int:
    from ..search.pictures import write_trace
    from ..search.trace import trace_vertex
    from ..viewer import write_trace_page

    scene = _scene(args)
    from ..options import RenderOptions

    if args.method == "ldt":
        return _trace_ldt_pixel(args, scene)
    if args.method == "envmap":
        raise RefsoftError("the environment map has no search to trace (a texel per direction): trace the vertex "
                           "search (--vertex I) or the LDT (--method ldt --pixel ROW COL)")
    if args.pixel is not None or args.bisection or ldt_kwargs(args):
        raise RefsoftError("--pixel, --bisection and the --ldt-* options trace the LDT search: add --method ldt")
    if args.vertex is None:
        return _suggest_vertices(args, scene)

    opts = search_kwargs(args)
    coherence = opts.pop("coherence", True)
    neighbourhood = RenderOptions(**opts).neighbourhood
    if args.through is not None:
        return _trace_bounce(args, scene, opts, coherence)
    rp = trace_vertex(scene, args.vertex, args.reflector, args.frame, coherence, **opts)
    name = lambda k: scene.object_by_id(k).name  # noqa: E731
    tr = rp.trace
    if rp.method == "hierarchy":
        print(f"vertex {rp.vertex} in reflector {rp.reflector} ({name(rp.reflector)!r}), frame {rp.frame}, ray-cone "
              f"hierarchy of {tr.levels} levels over {tr.base_size}x{tr.base_size} pixels at {tuple(tr.origin)}")
        print("attempt: the traversal's pass (0 the first; each further pass restarts with the cones and spheres "
              "enlarged, after a pass reached no base pixel); #: the event's index in trace.json's steps")
        print(f"{'#':>4} {'attempt':>7} {'level':>5} {'texel':>12}  event")
        for n, st in enumerate(tr.steps):
            if st["event"] in ("popped", "chosen"):
                print(f"{n:>4} {st['attempt']:>7} {st['level']:>5} {str(tuple(st['texel'])):>12}  {st['event']}")
        pix = "none" if tr.pixel is None else f"({tr.pixel[0]}, {tr.pixel[1]})"
        print(f"result: pixel {pix} after {tr.tests} texel tests")
        written = write_trace(args.out, rp) + [write_trace_page(args.out, rp)]
        print(f"wrote {args.out}/{', '.join(written)} (open trace.html in a browser to step through the traversal)")
        return 0
    print(f"vertex {rp.vertex} (object {rp.vertex_object} {name(rp.vertex_object)!r}, its vertex {rp.local_index}) "
          f"in reflector {rp.reflector} ({name(rp.reflector)!r}), frame {rp.frame}, {neighbourhood}, start "
          f"({tr.start[0]}, {tr.start[1]}){' after a restart' if tr.restarted else ''}")
    print(tr.table())
    os.makedirs(args.out, exist_ok=True)
    found = _trace_images(args, scene, rp, RenderOptions(**opts).images)
    write_trace(args.out, rp, () if found is None else found.images)
    write_trace_page(args.out, rp, None if found is None else found.images)
    beside = ", the inverse score field beside it" if tr.inverse_map is not None else ""
    print(f"wrote {args.out}/trace.json, trace.png (score field -log10(1 - s), path, start green, end red{beside}), "
          f"trace.gif ({len(tr.steps)} steps) and trace.html (open it in a browser to step through the search"
          + ("" if found is None else "; every image circled") + ")")
    return 0


def _trace_bounce(args, scene, opts, coherence) -> int:
    """``refsoft trace --vertex I --through A,B[,C...]``: a later bounce's search."""
    from ..search.pictures import write_trace
    from ..search.trace import trace_vertex_bounce
    from ..viewer import write_trace_page

    if args.reflector is not None:
        raise RefsoftError("--through names the reflectors of the path; leave out --reflector")
    try:
        through = [int(x) for x in args.through.split(",")]
    except ValueError:
        raise RefsoftError(f"--through must be reflector ids separated by commas, got {args.through!r}") from None
    rp = trace_vertex_bounce(scene, args.vertex, through, args.frame, coherence, **opts)
    name = lambda k: scene.object_by_id(k).name  # noqa: E731
    tr = rp.trace
    r0, r1, c0, c1 = rp.gbuffer_box
    print(f"vertex {rp.vertex} (object {rp.vertex_object} {name(rp.vertex_object)!r}, its vertex {rp.local_index}), "
          f"frame {rp.frame}, bounce {len(through)}: reflector {through[-1]} ({name(through[-1])!r}) as seen via "
          f"{' -> '.join(f'{k} ({name(k)!r})' for k in through[:-1])}; its G-buffer covers view rows {r0}..{r1 - 1}, "
          f"columns {c0}..{c1 - 1} (pixels below are relative to ({r0}, {c0})); each pixel's eye is the previous "
          f"bounce point; start ({tr.start[0]}, {tr.start[1]}): the best of up to 64 covered pixels")
    print(tr.table())
    os.makedirs(args.out, exist_ok=True)
    write_trace(args.out, rp)
    write_trace_page(args.out, rp)
    print(f"wrote {args.out}/trace.json, trace.png, trace.gif ({len(tr.steps)} steps) and trace.html")
    return 0


def _trace_images(args, scene, rp, mode):
    """With ``images="all"``, print how every image of the vertex was found and write images.json;
    returns the :class:`~refsoft.search.images.ImagesTrace` (None otherwise or on a convex reflector)."""
    from ..io import write_json
    from ..search.trace import trace_vertex_images

    if mode != "all":
        return None
    it = trace_vertex_images(scene, rp)
    if it is None:
        print(f"every image: reflector {rp.reflector} is convex (at most one reflection point): nothing enumerated")
        return None
    print(it.table())
    write_json(os.path.join(args.out, "images.json"), it.to_dict())
    print(f"wrote {args.out}/images.json")
    return it


class _FirstRunNotice:
    """Called just before the first frame (every input checked by then): prints one line when
    this run will compile the kernels, and remembers whether it did (``compiling``). With
    ``warm`` (a render's RenderOptions keyword arguments) it also starts the warm-up process
    (:mod:`refsoft._warmup`), at the latest then, or earlier with :meth:`start`; :meth:`close`
    ends it."""

    def __init__(self, what: str, seconds: int, warm=None):
        self.what, self.seconds, self.compiling, self.warm, self.process = what, seconds, False, warm, None
        self._first = None

    def _first_run(self) -> bool:
        if self._first is None:
            from .._numba import kernels_cached

            self._first = not kernels_cached()
        return self._first

    def start(self):
        """On a first run, start the warm-up process now (it then imports and prepares while the
        command loads the scene; :meth:`close` ends it, also when the inputs turn out wrong)."""
        if self.warm is not None and self.process is None and self._first_run():
            from .. import _warmup

            self.process = _warmup.start(self.warm)

    def __call__(self):
        import sys

        if not self._first_run():
            return
        self.compiling = True
        print(f"refsoft: first run: compiling the {self.what} kernels (about {self.seconds} s on 2 cores; cached "
              "for later runs)", file=sys.stderr, flush=True)
        self.start()

    def close(self):
        if self.process is not None:
            from .. import _warmup

            _warmup.stop(self.process)


def _timing(frames, compiling: bool) -> str:
    """The closing figures: the median frame time, the first frame apart when it compiled."""
    ms = [f.time_ms["total"] for f in frames]
    if compiling and len(ms) > 1:
        return f"first frame {ms[0] / 1000:.1f} s (compiling), then median {np.median(ms[1:]):.0f} ms per frame"
    if compiling:
        return f"{ms[0] / 1000:.1f} s for the frame, compiling included"
    return f"median {np.median(ms):.0f} ms per frame"


def cmd_render(args) -> int:
    from ..frame import render

    options = render_kwargs(args)
    notice = _FirstRunNotice("render", 20, warm=options)
    notice.start()  # a first run's warm-up process starts before the scene is loaded
    try:
        scene = _scene(args)
        frames = _one_of(args)
        write = None
        if args.frame is not None:
            if args.frame < 0 or (scene.animation is not None and args.frame >= scene.n_frames):
                raise RefsoftError(f"--frame must be in [0, {scene.n_frames - 1}], got {args.frame}")
            if args.no_coherence or args.frame == 0:
                frames = [args.frame]
            elif scene.animation is None:  # every frame of a static scene is frame 1: its coherent start is frame 0's
                frames = [0, args.frame]
            else:
                frames = list(range(args.frame + 1))
            write = {args.frame}
        out = args.out or os.path.join("out", scene.name)
        t0 = time.perf_counter()
        # each frame is written while the next one renders, then dropped (at most two frames in memory)
        done, stats = render(scene, frames=frames, out=out, progress=True, memory_limit=args.memory_limit,
                             keep=False, write=write, overwrite=args.overwrite, on_start=notice, **options)
    finally:
        notice.close()
    keep = done if write is None else [f for f in done if f.index in write]
    summ = stats["summary"]
    if "ldt_linear_samples" in summ:
        what = (f"method ldt, written to {out} in {time.perf_counter() - t0:.1f} s ({_timing(done, notice.compiling)}"
                f"); linear samples per reflector pixel: mean {summ['ldt_linear_samples']['mean']:.1f}, max "
                f"{summ['ldt_linear_samples']['max']}")
    elif "envmap_hits" in summ:
        what = (f"method envmap, written to {out} in {time.perf_counter() - t0:.1f} s "
                f"({_timing(done, notice.compiling)}); reflector pixels showing an object: {summ['envmap_hits']}")
    else:
        what = (f"preset {args.preset}, written to {out} in {time.perf_counter() - t0:.1f} s "
                f"({_timing(done, notice.compiling)}); search iterations: max frame mean "
                f"{summ['max_frame_mean_iterations']:.1f}, total mean {summ['total_mean_iterations']:.1f}")
    print(f"{scene.name}: {len(keep)} frame(s), {what}")
    for line in several_lines(stats["frames"], lambda k: scene.object_by_id(k).name):
        print(line)
    return 0


def several_lines(frames, name=None) -> list[str]:
    """One line per reflector that showed vertices with several images in ``frames`` (the
    ``stats.json`` frame records): how many, in the frame with the most (``name(k)``, optional,
    names reflector k)."""
    most = {}
    for f in frames:
        for k, c in (f.get("images") or {}).items():
            n = c["2"] + c["3+"]
            if n and (k not in most or n > most[k][0]):
                most[k] = (n, c, f["frame"])
    lines = []
    for k in sorted(most, key=int):
        n, c, frame = most[k]
        who = f"reflector {k}" + (f" ({name(int(k))})" if name is not None else "")
        when = f", frame {frame}" if len(frames) > 1 else ""
        lines.append(f"{who}: {n} vertices with several images ({c['2']} two, {c['3+']} three or more){when}")
    return lines


def _bounces(text) -> int:
    """``--bounces``: read here rather than by argparse, so that a bad value is one line."""
    from ..constants import MAX_BOUNCES

    value = text.strip()
    if not (value.isascii() and value.isdigit() and 1 <= int(value) <= MAX_BOUNCES):
        raise RefsoftError(f"--bounces must be an integer from 1 to {MAX_BOUNCES}, got {text!r}")
    return int(value)


def cmd_truth(args) -> int:
    from ..frame import frame_indices
    from ..truth import render_truth

    bounces = _bounces(args.bounces)
    scene = _scene(args)
    frames = _one_of(args)
    if args.frame is not None:
        frames = [args.frame]
    frame_indices(scene, frames)  # checks the range before any work
    out = args.out or os.path.join("out", f"{scene.name}-truth")
    notice = _FirstRunNotice("truth", 15)
    t0 = time.perf_counter()
    done, stats = render_truth(scene, frames=frames, out=out, progress=True, exact=not args.no_exact,
                               memory_limit=args.memory_limit, overwrite=args.overwrite, on_start=notice,
                               bounces=bounces)
    rays = sum(f.report["reflector_pixels"] for f in done)
    print(f"{scene.name}: {len(done)} truth frame(s) written to {out} in {time.perf_counter() - t0:.1f} s "
          f"({_timing(done, notice.compiling)}; {rays} reflected rays)")
    if bounces > 1:
        depth = {j: sum(f.report["bounce_depth"][str(j)] for f in done) for j in range(1, bounces + 1)}
        print("reflector pixels by reflections taken: "
              + ", ".join(f"{j}: {n} ({100 * n / max(rays, 1):.1f}%)" for j, n in depth.items()))
    return 0


def cmd_golden(args) -> int:
    from ..conformance.golden import CASES, GOLDEN_SIZE, write_golden

    if args.list:
        for c in CASES:
            opts = ", ".join(f"{k}={v}" for k, v in c.options.items()) or "defaults"
            print(f"{c.name:<24} {c.scene:<10} frames {list(c.frames)}  {opts}")
        return 0
    from ..bench.tasks import resolve

    mode = "add" if args.add else "replace" if args.replace else None
    where = resolve(args.scheduler, args.workers, False, args.connect_timeout)
    t0 = time.perf_counter()
    m = write_golden(args.out, args.case, progress=True, mode=mode, scheduler=where["scheduler"],
                     workers=where["workers"], connect_timeout=where["connect_timeout"])
    written = len(args.case) if args.case else len(CASES)
    print(f"golden set: {len(m['cases'])} cases ({written} written), {len(m['files'])} files at "
          f"{GOLDEN_SIZE[0]}x{GOLDEN_SIZE[1]} in {args.out} in {time.perf_counter() - t0:.1f} s "
          f"(manifest.json lists their SHA-256)")
    return 0


def cmd_check(args) -> int:
    from ..conformance.check import MAGNIFY, STATUSES, check

    summary = check(args.golden, args.candidate, loose=args.loose, out=args.out, cases=args.case, progress=True,
                    kinds=args.kinds, profile=args.profile)
    findings = summary.pop("_findings")
    if summary["versions"]["note"]:
        print(f"note: {summary['versions']['note']}")
    for f in findings:
        if f.status not in ("pass", "not_ported") or args.verbose:
            print(f.line())
            for d in f.details[:5]:
                print(f"           {d}")
    print(f"{'kind':<16}" + "".join(f"{s:>11}" for s in STATUSES))
    for kind, n in summary["by_kind"].items():
        print(f"{kind:<16}" + "".join(f"{n[s]:>11}" for s in STATUSES))
    c, n_pics = summary["counts"], len(summary["pictures"])
    gaps = summary["not_ported"]
    if gaps["cases"]:
        print(f"not ported: {len(gaps['cases'])} case(s), declared in {os.path.join(args.candidate, 'ported.json')}:")
        for case, why in gaps["cases"].items():
            print(f"  {case}: {why.split(': ', 1)[-1]}")
    if gaps["outputs"]:
        print("not ported: " + ", ".join(f"{n} output(s) of kind {k}" for k, n in gaps["outputs"].items()))
    verdict = "PASSED" if summary["passed"] else "FAILED"
    if c["missing"]:
        print(f"{c['missing']} output(s) missing: a port providing a subset says so with --case and --kinds, or "
              "declares what it does not port in the candidate's ported.json (docs/ports.md)")
    print(f"{verdict}: {c['pass']} pass, {c['accepted']} accepted (yellow), {c['fail']} fail, {c['missing']} missing, "
          f"{c['not_ported']} not ported ({summary['profile']} profile); "
          f"summary.json and {n_pics} picture{'' if n_pics == 1 else 's'} ({MAGNIFY}x) of what did not pass in "
          f"{args.out}")
    return 0 if summary["passed"] else 1


def cmd_export(args) -> int:
    from ..conformance.export import export_frames, export_inputs
    from ..options import RenderOptions

    scene = _scene(args)
    frames = export_frames(scene, args.frames, args.frame)
    options = RenderOptions(**render_kwargs(args))
    files = export_inputs(args.out, scene, frames, options, overwrite=args.overwrite)
    size = sum(os.path.getsize(os.path.join(args.out, f)) for f in files)
    how = f"method {options.method}" if options.method in ("ldt", "envmap") else f"preset {options.preset}"
    print(f"{scene.name}: inputs of {len(frames)} frame(s) at {scene.camera.width}x{scene.camera.height}, {how}: "
          f"case.json and {len(files) - 1} PLY file(s), {size / 1e6:.1f} MB, in {args.out}")
    return 0


def cmd_bench(args) -> int:
    import shlex

    from .. import bench
    from ..bench.report import COMMAND, file_link

    token = COMMAND.set(shlex.join(["refsoft", *getattr(args, "argv", ["bench", args.what])]))
    try:
        return _bench(args, bench, file_link)
    finally:
        COMMAND.reset(token)


def _bench(args, bench, file_link) -> int:
    out = args.out or os.path.join("out", "bench", args.what)
    t0 = time.perf_counter()
    only_table1 = ("gbuffer_scales", "slowdowns")
    unused = {"accuracy": ("knob", "width", "height", "repeats", "max_vertices", "max_subdivisions", "max_width",
                           *only_table1),
              "sweep": ("sizes", "setting", "max_vertices", "max_subdivisions", "max_width", *only_table1),
              "scaling": ("scenes", "knob", "frames", "sizes", "setting", "no_timing", *only_table1),
              "table1": ("knob", "repeats", "sizes", "setting", "max_vertices", "max_subdivisions", "max_width")}
    given = [name for name in unused[args.what] if getattr(args, name) not in (None, False, [])
             and getattr(args, name) != BENCH_DEFAULTS.get(name)]
    if given:
        flags = ", ".join("--" + name.replace("_", "-") for name in given)
        raise RefsoftError(f"bench {args.what} takes no {flags}")
    run = bench.tasks.resolve(args.scheduler, args.workers, args.fresh, args.connect_timeout)
    info = {}
    repeats = 3 if args.repeats is None else args.repeats
    timing = {} if args.what == "scaling" else {"timing": not args.no_timing}
    if args.what == "accuracy":
        sizes = [_size(s) for s in args.sizes] if args.sizes else [(640, 480), (1024, 768)]
        rows = bench.accuracy(args.scenes, out, sizes, args.frames or 5, args.setting, progress_bar=True, run_info=info,
                              **timing, **run)
        for r in bench.accuracy_summary(rows):
            if r["setting"] in ("paper", "accurate"):
                ms = f", {r['ms']:7.1f} ms/frame" if r["ms"] is not None else ""
                print(f"{r['scene']:<10} {r['size']:>9} {r['setting']:<9} agreement median {100 * r['median']:6.2f}% "
                      f"worst {100 * r['worst']:6.2f}%{ms}")
        files = "accuracy.csv, accuracy.md, agreement_*.png" + (
            ", accuracy.png" if os.path.exists(os.path.join(out, "accuracy.png")) and not args.no_timing else "")
        print(f"accuracy: {len(rows)} frames in {time.perf_counter() - t0:.0f} s ({info['run'].line()}); {out}/{files}")
    elif args.what == "sweep":
        scenes = args.scenes or ["sphere", "quad", "kitchen"]
        rows = bench.sweep(scenes, out, args.width or 320, args.height or 240, args.frames or 3, repeats,
                           args.knob, progress_bar=True, run_info=info, **timing, **run)
        plot = "no plot (--no-timing)" if args.no_timing else "pareto.png" if os.path.exists(
            os.path.join(out, "pareto.png")) else "no plot (pip install '.[plot]' for matplotlib)"
        print(f"sweep: {len(rows)} settings over {len(scenes)} scenes in {time.perf_counter() - t0:.0f} s "
              f"({info['run'].line()}); {out}/sweep.csv, sweep.md, {plot}")
    elif args.what == "scaling":
        r = bench.scaling(out, args.width or 1024, args.height or 768, args.max_vertices, args.max_subdivisions,
                          args.max_width, repeats, progress_bar=True, run_info=info, **run)
        slopes = ", ".join(f"{k} {v:.2f}" for k, v in r["slopes"].items())
        plot = ".png" if os.path.exists(os.path.join(out, "scaling.png")) else \
            " (no plot: pip install '.[plot]' for matplotlib)"
        print(f"scaling in {time.perf_counter() - t0:.0f} s ({info['run'].line()}); fitted slopes: {slopes}; "
              f"{out}/scaling.csv, .md{plot}")
    else:
        rows = bench.table1(args.scenes or ["kitchen", "ufo", "ants"], out, args.width or 1024, args.height or 768,
                            args.frames, progress_bar=True, run_info=info, gbuffer_scales=args.gbuffer_scales or (1.0,),
                            slowdowns=args.slowdowns or (1,), **timing, **run)
        for r in rows:
            ms = f", {r['ms_per_frame']} ms/frame (paper {r['paper_ms_per_frame']})" if r["ms_per_frame"] is not None \
                else ""
            print(f"{r['scene']:<8} G-buffer {r['gbuffer']:>9} slowdown {r['slowdown']} ({r['frames']} frames): "
                  f"max frame mean {r['max_frame_mean']:6.2f} (paper {r['paper_max_frame_mean']}), "
                  f"total mean {r['total_mean']:5.2f} (paper {r['paper_total_mean']}){ms}")
        print(f"table1 in {time.perf_counter() - t0:.0f} s ({info['run'].line()}); {out}/table1.csv, table1.md")
    print(f"report: {file_link(os.path.join(out, 'report.html'))}")
    return 0


#: The bench options' defaults in the parser (an option at its default counts as not given).
BENCH_DEFAULTS = {"max_vertices": 1 << 20, "max_subdivisions": 8, "max_width": 2048}


def _size(text):
    try:
        w, h = (int(x) for x in text.lower().split("x"))
    except ValueError:
        raise RefsoftError(f"--sizes takes WxH like 640x480, got {text!r}") from None
    return w, h


def cmd_compare(args) -> int:
    from ..truth.compare import compare_runs

    header = [f"{'frame':>5} {'refl px':>8} {'id disagree':>11} {'interior':>9} {'colour mean':>11} {'colour p99':>10}"
              f" {'specks':>6} {'holes':>6}  per-vertex (reflector: px mean/max, |V'-V'*| mean) or per-pixel hit |X-X*| median/max"]

    def row(m):
        while header:  # printed with the first row: a refused comparison prints only its error
            print(header.pop())
        verts = "; ".join(f"{k}: {v['pixel_distance_mean']:.3f}/{v['pixel_distance_max']:.3f} px, "
                          f"{v['virtual_distance_mean']:.2e}" for k, v in m.get("vertices", {}).items()
                          if "pixel_distance_mean" in v)
        if "hit_distance" in m:
            verts = f"hit {m['hit_distance']['median']:.2e}/{m['hit_distance']['max']:.2e}"
        print(f"{m['frame']:>5} {m['reflector_pixels']:>8} {100 * m['reflected_id_disagreement']:>10.2f}% "
              f"{100 * m['interior_disagreement']:>8.2f}% {m['color_error']['mean']:>11.4f} "
              f"{m['color_error']['p99']:>10.4f} {m['specks']:>6} {m['holes']:>6}  {verts}")

    out = args.out
    report = compare_runs(args.render_dir, args.truth_dir, out, on_frame=row)
    s = report["summary"]
    extra = ""
    if s["only_in_render"] or s["only_in_truth"]:
        extra = f" (not compared: {len(s['only_in_render'])} render-only, {len(s['only_in_truth'])} truth-only frames)"
    print(f"{s['frames']} frame(s): reflected_id differs on {100 * s['reflected_id_disagreement']:.2f}% of reflector "
          f"pixels; {s['specks']} specks ({100 * s['speck_fraction']:.3f}%), {s['holes']} holes "
          f"({100 * s['hole_fraction']:.3f}%){extra}; wrote {out}/metrics.json, agreement_NNNN.png (green agree, red differ) and side_NNNN.png "
          f"(render | truth | 4x difference)")
    for line in several_lines(_render_stats(args.render_dir)):
        print(line)
    line = levels_line(report["frames"])
    if line:
        print(line)
    return 0


def levels_line(frames) -> str:
    """One line on the mirror paths of several bounces, from the frames' ``levels`` metrics:
    the reflector pixels and the disagreement per number of reflections, and the depth mismatch
    (or that the render follows one bounce where the truth follows more); "" when no frame has
    them."""
    rows = [f["levels"] for f in frames if "levels" in f]
    if not rows:
        return ""
    pixels, wrong = {}, {}
    for r in rows:
        for j, n in r["pixels"].items():
            pixels[j] = pixels.get(j, 0) + n
            wrong[j] = wrong.get(j, 0.0) + r["disagreement"][j] * n
    parts = [f"{j} reflection(s): {pixels[j]} px, {100 * wrong[j] / pixels[j]:.2f}% differ"
             for j in sorted(pixels, key=int)]
    mismatch = [r["depth_mismatch"] for r in rows]
    if any(m is None for m in mismatch):
        tail = "; the render records no bounce_depth (it follows one bounce: render with --bounces as the truth)"
    else:
        total = sum(pixels.values())
        share = sum(m * sum(r["pixels"].values()) for m, r in zip(mismatch, rows)) / total
        tail = f"; the number of reflections differs on {100 * share:.2f}% of reflector pixels"
    return "mirror paths: " + ", ".join(parts) + tail


def _render_stats(folder) -> list:
    """The frame records of a render folder's ``stats.json`` ([] when it has none)."""
    import json

    try:
        with open(os.path.join(folder, "stats.json"), encoding="utf-8") as fh:
            return list(json.load(fh).get("frames", []))
    except (OSError, ValueError):
        return []
