"""The ``refsoft`` command line.

Every bad input ends in one line on stderr (``refsoft: error: ...``) and exit status 2, with
no traceback; outputs are written atomically.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np


def _scene_from_args(args):
    from ..scene.builtin import load_scene

    return load_scene(args.scene, width=args.width, height=args.height)


def cmd_scenes(args) -> int:
    from ..scene.builtin import BUILTIN_SCENES, load_scene

    print(f"{'name':<10} {'vertices':>9} {'triangles':>10} {'reflectors':>10} {'frames':>6}  description")
    for name, (_, desc) in BUILTIN_SCENES.items():
        c = load_scene(name).counts()
        print(f"{name:<10} {c['vertices']:>9} {c['triangles']:>10} {c['reflectors']:>10} {c['frames']:>6}  {desc}")
    return 0


def cmd_gbuffer(args) -> int:
    from .. import raster
    from ..errors import RefsoftError
    from ..io import write_npz, write_png
    from ..visualize import normal_colors, position_colors, side_by_side

    scene = _scene_from_args(args)
    if args.frame < 0 or args.frame >= scene.n_frames:
        raise RefsoftError(f"--frame must be in [0, {scene.n_frames - 1}], got {args.frame}")
    ids = scene.reflector_ids if args.reflector is None else [args.reflector]
    if not ids:
        raise RefsoftError(f"scene {scene.name!r} has no reflector")
    for k in ids:
        if k not in scene.reflector_ids:
            raise RefsoftError(f"object {k} of scene {scene.name!r} is not a reflector (reflectors: {scene.reflector_ids})")
    camera = scene.camera_at(args.frame)
    if args.widen != 1.0:
        camera = camera.widened(args.widen)
    from ..limits import check_frame_memory
    from ..frame.driver import RenderOptions

    check_frame_memory(scene, RenderOptions(widen=args.widen, precision=args.precision), 1, args.memory_limit)
    os.makedirs(args.out, exist_ok=True)
    t0 = time.perf_counter()
    pictures = []
    for k in ids:
        gb = raster.gbuffer(scene.world_mesh(k, args.frame, proxy=True), camera, args.precision)
        write_npz(os.path.join(args.out, f"gbuffer_{k}.npz"), gbuffer_position=gb.position,
                  gbuffer_normal=gb.normal, gbuffer_mask=gb.mask, gbuffer_depth=gb.depth,
                  gbuffer_triangle=gb.triangle, gbuffer_view_proj=gb.view_proj)
        pictures.append(side_by_side(position_colors(gb.position, gb.mask), normal_colors(gb.normal, gb.mask)))
        print(f"reflector {k} ({scene.object_by_id(k).name}): {int(gb.mask.sum())} covered pixels "
              f"of {gb.mask.size} at {camera.width}x{camera.height}")
    view = raster.color_pass([scene.world_mesh(i + 1, args.frame) for i in range(len(scene.objects))],
                             [o.color for o in scene.objects], scene.camera_at(args.frame))
    write_png(os.path.join(args.out, "view.png"), view.image)
    write_png(os.path.join(args.out, "gbuffer.png"), np.concatenate(pictures, axis=0))
    print(f"wrote {args.out}/gbuffer.png (positions | normals), view.png and gbuffer_K.npz "
          f"in {1000 * (time.perf_counter() - t0):.0f} ms")
    return 0


def cmd_trace(args) -> int:
    from .. import search as search_mod
    from ..errors import RefsoftError
    from ..io import atomic_path, write_json, write_png
    from ..search.reflect import reflector_gbuffer, scene_vertices
    from ..search.pictures import trace_frames, trace_picture, write_trace_gif

    scene = _scene_from_args(args)
    if args.frame < 0 or args.frame >= scene.n_frames:
        raise RefsoftError(f"--frame must be in [0, {scene.n_frames - 1}], got {args.frame}")
    if not scene.reflector_ids:
        raise RefsoftError(f"scene {scene.name!r} has no reflector")
    k = scene.reflector_ids[0] if args.reflector is None else args.reflector
    if k not in scene.reflector_ids:
        raise RefsoftError(f"object {k} of scene {scene.name!r} is not a reflector (reflectors: {scene.reflector_ids})")
    verts, owner = scene_vertices(scene, args.frame)
    if not 0 <= args.vertex < len(verts):
        raise RefsoftError(f"--vertex must be in [0, {len(verts) - 1}] (vertices of the non-reflector objects), "
                           f"got {args.vertex}")
    if args.search == "hierarchy":
        return _trace_hierarchy(args, scene, k, verts, owner)
    opts = dict(neighbourhood=args.search, inverse=args.inverse)
    previous = None
    if not args.no_coherence:  # replay this vertex's searches of the earlier frames
        for f in range(args.frame):
            gb = reflector_gbuffer(scene, k, f, args.widen, None, args.precision)
            v_f, _ = scene_vertices(scene, f)
            res = search_mod.search(gb, scene.camera_at(f).eye, v_f[args.vertex:args.vertex + 1],
                                    previous=None if previous is None else previous[None], **opts)
            previous = res.pixel[0]
    gb = reflector_gbuffer(scene, k, args.frame, args.widen, None, args.precision)
    tr = search_mod.trace_search(gb, scene.camera_at(args.frame).eye, verts[args.vertex], previous=previous, **opts)
    obj = scene.object_by_id(int(owner[args.vertex]))
    first = int(np.argmax(owner == owner[args.vertex]))
    print(f"vertex {args.vertex} (object {int(owner[args.vertex])} {obj.name!r}, its vertex {args.vertex - first}) "
          f"in reflector {k} ({scene.object_by_id(k).name!r}), frame {args.frame}, {args.search}, start "
          f"({tr.start[0]}, {tr.start[1]}){' after a restart' if tr.restarted else ''}")
    print(tr.table())
    os.makedirs(args.out, exist_ok=True)
    data = tr.to_dict()
    data.update(scene=scene.name, reflector=k, frame=args.frame, vertex_index=args.vertex,
                vertex_object=int(owner[args.vertex]))
    write_json(os.path.join(args.out, "trace.json"), data)
    write_png(os.path.join(args.out, "trace.png"), trace_picture(tr, gb.mask))
    write_trace_gif(os.path.join(args.out, "trace.gif"), trace_frames(tr, gb.mask))
    print(f"wrote {args.out}/trace.json, trace.png (score field -log10(1 - s), path, start green, end red) "
          f"and trace.gif ({len(tr.steps)} steps)")
    return 0


def _trace_hierarchy(args, scene, k, verts, owner):
    """``refsoft trace --search hierarchy``: the texels the traversal popped and tested, a table,
    trace.json and trace.png (the footprints of the popped texels, finer levels brighter; the
    chosen pixel red)."""
    from ..io import write_json, write_png
    from ..search.reflect import reflector_gbuffer
    from ..search import trace_hierarchy

    gb = reflector_gbuffer(scene, k, args.frame, args.widen, None, args.precision)
    tr = trace_hierarchy(gb, scene.camera_at(args.frame).eye, verts[args.vertex])
    print(f"vertex {args.vertex} in reflector {k} ({scene.object_by_id(k).name!r}), frame {args.frame}, ray-cone "
          f"hierarchy of {tr['levels']} levels over {tr['base_size']}x{tr['base_size']} pixels at {tuple(tr['origin'])}")
    print(f"{'#':>4} {'attempt':>7} {'level':>5} {'texel':>12}  event")
    for n, st in enumerate(tr["steps"]):
        if st["event"] in ("popped", "chosen"):
            print(f"{n:>4} {st['attempt']:>7} {st['level']:>5} {str(tuple(st['texel'])):>12}  {st['event']}")
    print(f"result: pixel {tr['pixel']} after {tr['tests']} texel tests")
    os.makedirs(args.out, exist_ok=True)
    tr.update(scene=scene.name, reflector=k, frame=args.frame, vertex_index=args.vertex,
              vertex_object=int(owner[args.vertex]), method="hierarchy")
    write_json(os.path.join(args.out, "trace.json"), tr)
    img = np.where(gb.mask[..., None], 70, 0).astype(np.uint8) * np.ones(3, np.uint8)
    r0, c0 = tr["origin"]
    for st in tr["steps"]:
        if st["event"] != "popped":
            continue
        lv, (i, j) = st["level"], st["texel"]
        side = 1 << lv
        shade = int(90 + 150 * (1 - lv / max(tr["levels"] - 1, 1)))
        rs, cs = r0 + i * side, c0 + j * side
        region = img[rs:rs + side, cs:cs + side]
        region[gb.mask[rs:rs + side, cs:cs + side]] = (0, shade, shade)
    if tr["pixel"] is not None:
        img[tr["pixel"][0], tr["pixel"][1]] = (255, 0, 0)
    write_png(os.path.join(args.out, "trace.png"), np.repeat(np.repeat(img, 2, axis=0), 2, axis=1))
    print(f"wrote {args.out}/trace.json and trace.png")
    return 0


def cmd_render(args) -> int:
    from ..errors import RefsoftError
    from ..frame.driver import render

    scene = _scene_from_args(args)
    if args.frame is not None and args.frames is not None:
        raise RefsoftError("give --frames N or --frame K, not both")
    if args.frame is not None:
        if args.frame < 0 or (scene.animation is not None and args.frame >= scene.n_frames):
            raise RefsoftError(f"--frame must be in [0, {scene.n_frames - 1}], got {args.frame}")
        frames = list(range(args.frame + 1)) if not args.no_coherence else [args.frame]
    else:
        frames = args.frames
    t0 = time.perf_counter()
    from ..frame.driver import SKIPS

    off = set(SKIPS) if args.no_skips else {n.replace("-", "_") for n in args.no_skip or ()}
    # every frame is written as soon as it is rendered, then dropped (one frame in memory)
    done, stats = render(scene, frames=frames, out=args.out, progress=True, memory_limit=args.memory_limit,
                         keep=False, write=None if args.frame is None else {args.frame},
                         neighbourhood=args.search, inverse=args.inverse, widen=args.widen,
                         precision=args.precision, coherence=not args.no_coherence,
                         adaptive_widen=args.adaptive_widen, tessellate=args.tessellate, max_level=args.max_level,
                         refine=args.refine, **{name: name not in off for name in SKIPS})
    keep = done if args.frame is None else [f for f in done if f.index == args.frame]
    summ = stats["summary"]
    median_ms = np.median([f.time_ms["total"] for f in keep])
    print(f"{scene.name}: {len(keep)} frame(s) written to {args.out} in {time.perf_counter() - t0:.1f} s "
          f"(median {median_ms:.0f} ms per frame; the first includes compiling on a first run); search iterations: "
          f"max frame mean {summ['max_frame_mean_iterations']:.1f}, total mean {summ['total_mean_iterations']:.1f}")
    return 0


def cmd_truth(args) -> int:
    from ..errors import RefsoftError
    from ..frame.driver import frame_indices
    from ..truth.raytrace import render_truth as truth

    scene = _scene_from_args(args)
    if args.frame is not None and args.frames is not None:
        raise RefsoftError("give --frames N or --frame K, not both")
    frames = [args.frame] if args.frame is not None else args.frames
    frame_indices(scene, frames)  # checks the range before any work
    t0 = time.perf_counter()
    done, stats = truth(scene, frames=frames, out=args.out, progress=True, exact=not args.no_exact,
                        memory_limit=args.memory_limit)
    median_ms = stats["summary"]["median_total_ms"]
    rays = sum(f.counts["reflector_pixels"] for f in done)
    print(f"{scene.name}: {len(done)} truth frame(s) written to {args.out} in {time.perf_counter() - t0:.1f} s "
          f"(median {median_ms:.0f} ms per frame; {rays} reflected rays)")
    return 0


def cmd_golden(args) -> int:
    from ..conformance.golden import CASES, GOLDEN_SIZE, write_golden

    if args.list:
        for c in CASES:
            opts = ", ".join(f"{k}={v}" for k, v in c.options.items()) or "defaults"
            print(f"{c.name:<24} {c.scene:<10} frames {list(c.frames)}  {opts}")
        return 0
    t0 = time.perf_counter()
    m = write_golden(args.out, args.case, progress=True)
    print(f"golden set: {len(m['cases'])} cases, {len(m['files'])} files at {GOLDEN_SIZE[0]}x{GOLDEN_SIZE[1]} "
          f"written to {args.out} in {time.perf_counter() - t0:.1f} s (manifest.json lists their SHA-256)")
    return 0


def cmd_check(args) -> int:
    from ..conformance.check import check

    out = args.out or os.path.join(args.candidate, "check")
    summary = check(args.golden, args.candidate, loose=args.loose, out=out, cases=args.case, progress=True)
    findings = summary.pop("_findings")
    shown = [f for f in findings if f.status != "pass" or args.verbose]
    for f in shown:
        print(f.line())
        for d in f.details[:5]:
            print(f"           {d}")
    c = summary["counts"]
    verdict = "PASSED" if summary["passed"] else "FAILED"
    print(f"{verdict}: {c['pass']} pass, {c['accepted']} accepted (yellow), {c['fail']} fail, {c['missing']} missing; "
          f"error masks, difference images and summary.json in {out}")
    return 0 if summary["passed"] else 1


def cmd_bench(args) -> int:
    from .. import bench
    from ..errors import RefsoftError

    out = args.out or os.path.join("out", "bench", args.what)
    t0 = time.perf_counter()
    if args.what == "sweep":
        scenes = args.scenes or ["sphere", "quad", "kitchen"]
        rows = bench.sweep(scenes, out, args.width or 320, args.height or 240, args.frames or 3, args.repeats,
                           args.knob, progress_bar=True)
        plot = "pareto.png" if os.path.exists(os.path.join(out, "pareto.png")) else \
            "no plot (pip install '.[plot]' for matplotlib)"
        print(f"sweep: {len(rows)} settings over {len(scenes)} scenes in {time.perf_counter() - t0:.0f} s; "
              f"{out}/sweep.csv, sweep.md, {plot}")
    elif args.what == "scaling":
        if args.scenes or args.knob:
            raise RefsoftError("bench scaling takes no --scenes or --knob")
        r = bench.scaling(out, args.width or 1024, args.height or 768, args.max_vertices, args.max_subdivisions,
                          args.max_width, args.repeats, progress_bar=True)
        slopes = ", ".join(f"{k} {v:.2f}" for k, v in r["slopes"].items())
        plot = ".png" if os.path.exists(os.path.join(out, "scaling.png")) else \
            " (no plot: pip install '.[plot]' for matplotlib)"
        print(f"scaling in {time.perf_counter() - t0:.0f} s; fitted slopes: {slopes}; {out}/scaling.csv, .md{plot}")
    else:
        if args.knob:
            raise RefsoftError("bench table1 takes no --knob")
        rows = bench.table1(args.scenes or ["kitchen", "ufo", "ants"], out, args.width or 1024, args.height or 768,
                            args.frames, progress_bar=True)
        for r in rows:
            print(f"{r['scene']:<8} max frame mean {r['max_frame_mean']:6.2f} (paper {r['paper_max_frame_mean']}), "
                  f"total mean {r['total_mean']:5.2f} (paper {r['paper_total_mean']}), {r['ms_per_frame']} ms/frame "
                  f"(paper {r['paper_ms_per_frame']})")
        print(f"{out}/table1.csv, table1.md")
    return 0


def _frame_files(folder):
    import glob

    from ..errors import RefsoftError

    if not os.path.isdir(folder):
        raise RefsoftError(f"{folder} is not a folder")
    files = sorted(glob.glob(os.path.join(folder, "frame_[0-9][0-9][0-9][0-9].npz")))
    return {os.path.basename(f)[6:10]: f for f in files}


def cmd_compare(args) -> int:
    from ..errors import RefsoftError
    from ..io import write_json, write_png
    from ..truth.metrics import frame_metrics
    from ..visualize import agreement_map, difference_image, side_by_side

    render_files, truth_files = _frame_files(args.render_dir), _frame_files(args.truth_dir)
    common = sorted(set(render_files) & set(truth_files))
    if not common:
        raise RefsoftError(f"no frame_NNNN.npz common to {args.render_dir} ({len(render_files)} frames) and "
                           f"{args.truth_dir} ({len(truth_files)} frames)")
    out = args.out or os.path.join(args.render_dir, "compare")
    os.makedirs(out, exist_ok=True)
    report = {"render": os.path.abspath(args.render_dir), "truth": os.path.abspath(args.truth_dir), "frames": []}
    print(f"{'frame':>5} {'refl px':>8} {'id disagree':>11} {'interior':>9} {'colour mean':>11} {'colour p99':>10}"
          f"  per-vertex (reflector: px mean/max, |V'-V'*| mean)")
    for key in common:
        with np.load(render_files[key]) as r, np.load(truth_files[key]) as t:
            ra, ta = dict(r), dict(t)
        if ra["reflected_id"].shape != ta["reflected_id"].shape:
            raise RefsoftError(f"frame {key}: render is {ra['reflected_id'].shape[::-1]} pixels, truth "
                               f"{ta['reflected_id'].shape[::-1]} (render both at the same --width/--height)")
        m = frame_metrics(ra, ta)
        m["frame"] = int(key)
        report["frames"].append(m)
        verts = "; ".join(f"{k}: {v['pixel_distance_mean']:.3f}/{v['pixel_distance_max']:.3f} px, "
                          f"{v['virtual_distance_mean']:.2e}" for k, v in m.get("vertices", {}).items()
                          if "pixel_distance_mean" in v)
        print(f"{int(key):>5} {m['reflector_pixels']:>8} {100 * m['reflected_id_disagreement']:>10.2f}% "
              f"{100 * m['interior_disagreement']:>8.2f}% {m['color_error']['mean']:>11.4f} "
              f"{m['color_error']['p99']:>10.4f}  {verts}")
        write_png(os.path.join(out, f"agreement_{key}.png"),
                  agreement_map(ra["reflected_id"], ta["reflected_id"], ta["image"]))
        write_png(os.path.join(out, f"side_{key}.png"),
                  side_by_side(ra["image"], ta["image"], difference_image(ra["image"], ta["image"])))
    frames = report["frames"]
    px = np.array([f["reflector_pixels"] for f in frames], dtype=np.float64)
    dis = np.array([f["reflected_id_disagreement"] for f in frames])
    report["summary"] = {"frames": len(frames),
                         "reflected_id_disagreement": float((dis * px).sum() / px.sum()) if px.sum() else 0.0,
                         "only_in_render": sorted(set(render_files) - set(truth_files)),
                         "only_in_truth": sorted(set(truth_files) - set(render_files))}
    write_json(os.path.join(out, "metrics.json"), report)
    s = report["summary"]
    extra = ""
    if s["only_in_render"] or s["only_in_truth"]:
        extra = f" (not compared: {len(s['only_in_render'])} render-only, {len(s['only_in_truth'])} truth-only frames)"
    print(f"{len(frames)} frame(s): reflected_id differs on {100 * s['reflected_id_disagreement']:.2f}% of reflector "
          f"pixels{extra}; wrote {out}/metrics.json, agreement_NNNN.png (green agree, red differ) and side_NNNN.png "
          f"(render | truth | 4x difference)")
    return 0


def build_parser() -> argparse.ArgumentParser:
    from .. import __version__

    p = argparse.ArgumentParser(prog="refsoft", description=__doc__.splitlines()[0])
    p.add_argument("--version", action="version", version=f"refsoft {__version__}")
    sub = p.add_subparsers(dest="command", required=True)

    s = sub.add_parser("scenes", help="list the built-in scenes")
    s.set_defaults(func=cmd_scenes)

    g = sub.add_parser("gbuffer", help="render the reflectors' G-buffers (positions and normals) as pictures")
    g.add_argument("scene", help="built-in scene name or TOML file")
    g.add_argument("--reflector", type=int, default=None, help="object id of one reflector (default: all)")
    g.add_argument("--frame", type=int, default=0)
    g.add_argument("--width", type=int, default=None)
    g.add_argument("--height", type=int, default=None)
    g.add_argument("--widen", type=float, default=1.0, help="wider-frustum factor (Estalella 5.2)")
    g.add_argument("--precision", choices=["float32", "float64"], default="float32")
    g.add_argument("--out", default="out", help="output folder (default: out)")
    g.add_argument("--memory-limit", default=None, metavar="SIZE", help="refuse above this estimate (e.g. 4G)")
    g.set_defaults(func=cmd_gbuffer)

    t = sub.add_parser("trace", help="replay one vertex's reflection-point search step by step")
    t.add_argument("scene", help="built-in scene name or TOML file")
    t.add_argument("--vertex", type=int, required=True,
                   help="index into the vertices of the non-reflector objects, in scene order")
    t.add_argument("--reflector", type=int, default=None, help="object id of the reflector (default: the first)")
    t.add_argument("--frame", type=int, default=0)
    t.add_argument("--search", choices=["cross", "box", "hierarchy"], default="cross")
    t.add_argument("--inverse", choices=["plane", "search", "discard"], default="plane")
    t.add_argument("--widen", type=float, default=1.0)
    t.add_argument("--precision", choices=["float32", "float64"], default="float32")
    t.add_argument("--no-coherence", action="store_true", help="start cold even at frame > 0")
    t.add_argument("--width", type=int, default=None)
    t.add_argument("--height", type=int, default=None)
    t.add_argument("--out", default="out/trace", help="output folder (default: out/trace)")
    t.set_defaults(func=cmd_trace)

    r = sub.add_parser("render", help="render frames with curved reflections (DESIGN section 7 outputs)")
    r.add_argument("scene", help="built-in scene name or TOML file")
    r.add_argument("--frames", type=int, default=None, help="render frames 0..N-1 (default: the whole animation)")
    r.add_argument("--frame", type=int, default=None, help="render only frame K (coherent from frame 0)")
    r.add_argument("--width", type=int, default=None)
    r.add_argument("--height", type=int, default=None)
    r.add_argument("--out", default="out/render", help="output folder (default: out/render)")
    r.add_argument("--search", choices=["cross", "box", "hierarchy"], default="cross",
                   help="crosshair or 3x3 walk (the paper), or Szabo's ray-cone hierarchy")
    r.add_argument("--inverse", choices=["plane", "search", "discard"], default="plane")
    r.add_argument("--widen", type=float, default=1.0)
    r.add_argument("--precision", choices=["float32", "float64"], default="float32")
    r.add_argument("--no-coherence", action="store_true", help="start every search cold")
    r.add_argument("--no-skip", action="append", metavar="NAME",
                   choices=["cull-reflectors", "reuse", "cull-virtual", "crop-virtual"],
                   help="turn one exact skip off (repeatable): cull-reflectors, reuse, cull-virtual, crop-virtual; "
                        "outputs are identical either way, only the time changes")
    r.add_argument("--no-skips", action="store_true", help="turn every exact skip off")
    r.add_argument("--memory-limit", default=None, metavar="SIZE",
                   help="refuse a render estimated to need more memory (e.g. 4G; default $REFSOFT_MEMORY_LIMIT or 4G)")
    r.add_argument("--tessellate", type=float, default=None, metavar="THRESHOLD",
                   help="Szabo's adaptive tessellation of reflected triangles whose edge error exceeds THRESHOLD "
                        "(e.g. 1e-3; 0 = full tessellation), crack-free")
    r.add_argument("--max-level", type=int, default=3, help="tessellation levels at most (default 3)")
    r.add_argument("--refine", action="store_true",
                   help="beyond the paper: sub-texel reflection points (one Gauss-Newton step from the texel found); "
                        "with --tessellate, edge errors between refined points")
    r.add_argument("--adaptive-widen", action="store_true",
                   help="approximation: use --widen only on frames where a reflector is cut by the image border")
    r.set_defaults(func=cmd_render)

    go = sub.add_parser("golden", help="write the golden set for ports (DESIGN section 8)")
    go.add_argument("--out", default="golden", help="output folder (default: golden)")
    go.add_argument("--case", action="append", default=None, help="only this case (repeatable; --list shows them)")
    go.add_argument("--list", action="store_true", help="list the canonical cases and exit")
    go.set_defaults(func=cmd_golden)

    ck = sub.add_parser("check", help="compare a port's outputs with a golden set; exit 1 on failure")
    ck.add_argument("golden", help="golden folder (from refsoft golden)")
    ck.add_argument("candidate", help="the port's outputs in the same layout")
    ck.add_argument("--loose", action="store_true", help="images: 4 per channel, 1-pixel window, 0.1%% may fail")
    ck.add_argument("--out", default=None, help="report folder (default: CANDIDATE/check)")
    ck.add_argument("--case", action="append", default=None, help="only this case (repeatable)")
    ck.add_argument("--verbose", action="store_true", help="also print the outputs that pass")
    ck.set_defaults(func=cmd_check)

    b = sub.add_parser("bench", help="run time against error: sweep, scaling, table1 (docs/benchmarks.md)")
    b.add_argument("what", choices=["sweep", "scaling", "table1"])
    b.add_argument("--scenes", nargs="+", default=None, help="built-in scenes (sweep: sphere quad kitchen; "
                   "table1: kitchen ufo ants)")
    b.add_argument("--out", default=None, help="output folder (default: out/bench/WHAT)")
    b.add_argument("--width", type=int, default=None)
    b.add_argument("--height", type=int, default=None)
    b.add_argument("--frames", type=int, default=None, help="frames per scene (sweep: 3; table1: all)")
    b.add_argument("--repeats", type=int, default=3, help="timed runs per setting (median)")
    b.add_argument("--knob", action="append", default=None, help="sweep only these knobs (repeatable): "
                   "gbuffer_scale, widen, neighbourhood, precision, inverse, tessellate, refine")
    b.add_argument("--max-vertices", type=int, default=1 << 20, help="scaling: largest vertex count")
    b.add_argument("--max-subdivisions", type=int, default=7, help="scaling: largest icosphere subdivision")
    b.add_argument("--max-width", type=int, default=2048, help="scaling: largest image width")
    b.set_defaults(func=cmd_bench)

    tr = sub.add_parser("truth", help="ray-trace the reflections (Embree) as the reference for compare")
    tr.add_argument("scene", help="built-in scene name or TOML file")
    tr.add_argument("--frames", type=int, default=None, help="frames 0..N-1 (default: the whole animation)")
    tr.add_argument("--frame", type=int, default=None, help="only frame K")
    tr.add_argument("--width", type=int, default=None)
    tr.add_argument("--height", type=int, default=None)
    tr.add_argument("--out", default="out/truth", help="output folder (default: out/truth)")
    tr.add_argument("--memory-limit", default=None, metavar="SIZE", help="refuse above this estimate (e.g. 4G)")
    tr.add_argument("--no-exact", action="store_true",
                    help="skip the exact reflection points of spherical reflectors (per-vertex truth)")
    tr.set_defaults(func=cmd_truth)

    c = sub.add_parser("compare", help="metrics of a render against its truth, agreement maps, side-by-side pictures")
    c.add_argument("render_dir", help="folder written by refsoft render")
    c.add_argument("truth_dir", help="folder written by refsoft truth")
    c.add_argument("--out", default=None, help="output folder (default: RENDER_DIR/compare)")
    c.set_defaults(func=cmd_compare)
    return p


def main(argv=None) -> int:
    from ..errors import RefsoftError

    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except RefsoftError as exc:
        print(f"refsoft: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # output piped into head and closed: not an error
        return 0
    except OSError as exc:
        print(f"refsoft: error: {exc.strerror or exc}: {exc.filename or ''}".rstrip(": "), file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("refsoft: interrupted", file=sys.stderr)
        return 130

