"""The ``refsoft`` command line.

Every bad input ends in one line on stderr (``refsoft: error: ...``) and exit status 2, with
no traceback; outputs are written atomically.
"""

from __future__ import annotations

import argparse
import sys

from . import commands
from .. import constants
from .options import (frame_range_options, ldt_options, memory_options, method_options, one_frame_options, out_option,
                      render_options, run_folder_options, scene_options)


def build_parser() -> argparse.ArgumentParser:
    from .. import __version__

    p = argparse.ArgumentParser(prog="refsoft", description="curved-mirror reflections by per-vertex "
                                "reflection-point search (Estalella et al. 2006): the CPU reference. Exit status: "
                                "0 done (check: passed), 1 check's verdict failed, 2 bad input (including a "
                                "missing, unreadable or inconsistent file; one line on stderr), 130 interrupted.")
    p.add_argument("--version", action="version", version=f"refsoft {__version__}")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    scene, memory, methods = scene_options(), memory_options(), method_options()

    s = sub.add_parser("scenes", help="list the built-in scenes, their vertex and triangle counts as loaded and "
                                      "after the loader's subdivision")
    s.add_argument("--subdivide", type=float, default=None, metavar="L",
                   help="count with this loader subdivision instead of the scenes' own (0 = off)")
    s.set_defaults(func=commands.cmd_scenes)

    g = sub.add_parser("gbuffer", parents=[scene, one_frame_options(), memory, out_option("out")],
                       help="render the reflectors' G-buffers (positions and normals) as arrays and pictures")
    g.add_argument("--reflector", type=int, default=None, metavar="ID", help="object id of one reflector (default: all)")
    g.add_argument("--widen", type=float, default=1.0, metavar="FACTOR", help="wider-frustum factor (Estalella 5.2)")
    g.add_argument("--precision", choices=("float32", "float64"), default="float32", help="G-buffer precision")
    g.set_defaults(func=commands.cmd_gbuffer)

    t = sub.add_parser("trace", parents=[scene, one_frame_options(), methods, ldt_options(), out_option("out/trace")],
                       help="replay one vertex's reflection-point search (or, --method ldt, one pixel's LDT "
                            "search) step by step")
    t.add_argument("--vertex", type=int, default=None, metavar="I",
                   help="the vertex search: index into the vertices of the non-reflector objects, in scene order")
    t.add_argument("--pixel", type=int, nargs=2, default=None, metavar=("ROW", "COL"),
                   help="--method ldt: the reflector pixel whose search is replayed (row 0 at the top)")
    t.add_argument("--bisection", action="store_true",
                   help="--method ldt: list the bisection steps too")
    t.add_argument("--reflector", type=int, default=None, metavar="ID",
                   help="object id of the reflector (default: the first)")
    t.add_argument("--through", default=None, metavar="A,B[,C...]",
                   help="a later bounce's search: the reflectors of the path, the first bounce's first (reflector B "
                        "as seen in A, ...; the render's --bounces is their count)")
    t.set_defaults(func=commands.cmd_trace)

    r = sub.add_parser("render", parents=[scene, frame_range_options(), methods, render_options(), ldt_options(), memory,
                                          run_folder_options("out/SCENE")],
                       help="render frames with curved reflections (frame_NNNN.npz/.png, stats.json)")
    r.set_defaults(func=commands.cmd_render)

    _port_commands(sub)
    _export_command(sub, scene, methods)
    _bench_command(sub)
    tr = sub.add_parser("truth", parents=[scene, frame_range_options(), memory, run_folder_options("out/SCENE-truth")],
                        help="ray-trace the reflections (Embree) as the reference for compare")
    tr.add_argument("--no-exact", action="store_true",
                    help="skip the exact reflection points of spherical reflectors (per-vertex truth)")
    tr.add_argument("--bounces", default="1", metavar="N",
                    help=f"most reflections per eye ray, 1 to {constants.MAX_BOUNCES} (default 1: each reflected "
                         "ray sees the non-reflectors only; N > 1: it may meet another reflector (or, leaving a "
                         "reflector that is not convex, that one again) and reflect again, up to N reflections in "
                         "all; the frames' bounce_depth holds the reflections taken)")
    tr.set_defaults(func=commands.cmd_truth)

    c = sub.add_parser("compare", help="metrics of a render against its truth, agreement maps, side-by-side pictures")
    c.add_argument("render_dir", help="folder written by refsoft render")
    c.add_argument("truth_dir", help="folder written by refsoft truth")
    c.add_argument("--out", default="out/compare", metavar="DIR",
                   help="report folder, outside both inputs (default: out/compare)")
    c.set_defaults(func=commands.cmd_compare)
    return p


def _port_commands(sub):
    """``golden`` and ``check``."""
    go = sub.add_parser("golden", parents=[out_option("golden")], help="write the golden set for ports")
    go.add_argument("--case", action="append", default=None, metavar="NAME",
                    help="only this case (repeatable; --list shows them)")
    mode = go.add_mutually_exclusive_group()
    mode.add_argument("--add", action="store_true",
                      help="into an existing set: add or regenerate the named cases, keep the others")
    mode.add_argument("--replace", action="store_true",
                      help="into an existing set: start it anew (its listed files are removed)")
    go.add_argument("--list", action="store_true", help="list the canonical cases and exit")
    go.add_argument("--scheduler", default=None, metavar="WHERE",
                    help="where the cases are rendered, one task each: 'local' (a Dask cluster on this machine; the "
                         "default when Dask is installed), 'serial' (one after another in this process) or "
                         "tcp://HOST:PORT (a running Dask scheduler); the set is the same, bit for bit")
    go.add_argument("--workers", type=int, default=None, metavar="N",
                    help="--scheduler local: worker processes (default: the cores)")
    go.add_argument("--connect-timeout", type=float, default=None, metavar="S",
                    help="--scheduler tcp://...: seconds to wait for the scheduler and its first worker (default 10)")
    go.set_defaults(func=commands.cmd_golden)

    ck = sub.add_parser("check", help="compare a port's outputs with a golden set; exit 1 on failure")
    ck.add_argument("golden", help="golden folder (from refsoft golden)")
    ck.add_argument("candidate", help="the port's outputs in the same layout")
    ck.add_argument("--loose", action="store_true", help="images: 4 per channel, 1-pixel window, 0.1%% may fail")
    ck.add_argument("--profile", choices=constants.CHECK_PROFILES, default="default",
                    help="the rules: 'default' (exact, for a port writing refsoft's arithmetic out) or 'gpu' (a port "
                         "using its GPU's interpolation and built-ins: tolerances derived per stage in "
                         "docs/precision.md; implies --loose)")
    ck.add_argument("--out", default="out/check", metavar="DIR",
                    help="report folder, outside the golden and candidate folders (default: out/check)")
    ck.add_argument("--case", action="append", default=None, metavar="NAME", help="only this case (repeatable)")
    ck.add_argument("--kinds", action="append", default=None, metavar="KIND[,KIND...]",
                    help="only these kinds of output, the others neither judged nor required (repeatable or "
                         "comma-separated): " + ", ".join(constants.CHECK_KINDS) + "; default all: a case or an "
                         "output the candidate lacks fails, unless its ported.json declares it not ported")
    ck.add_argument("--verbose", action="store_true", help="also print the outputs that pass")
    ck.set_defaults(func=commands.cmd_check)



def _export_command(sub, scene, methods):
    """``export``: a scene's inputs as a port reads them (PLY and JSON)."""
    e = sub.add_parser("export", parents=[scene, methods, render_options(), ldt_options()],
                       help="write a scene's inputs for a port: world meshes per frame as PLY (float64, with "
                            "normals), cameras, matrices and options as JSON (docs/ports.md)")
    which = e.add_mutually_exclusive_group()
    which.add_argument("--frames", default=None, metavar="N|A:B",
                       help="frames 0..N-1, or A..B-1 (default: the whole animation; frame 0 of a static scene)")
    which.add_argument("--frame", type=int, default=None, metavar="K", help="only frame K (a cold start)")
    e.add_argument("--out", required=True, metavar="DIR", help="output folder (case.json and the PLY files)")
    e.add_argument("--overwrite", action="store_true",
                   help="replace an earlier export in DIR (its mesh files not rewritten are removed)")
    e.set_defaults(func=commands.cmd_export)


#: ``bench``'s subcommands: a line of help and the benchmark's description.
_BENCH = {
    "accuracy": ("agreement with the ray-traced truth per scene, size and setting (docs/accuracy.md)",
                 "Render each scene with each setting (the paper and accurate presets, and the accurate preset with "
                 "one part changed) at each size, ray-trace the same frames, and report the agreement of the "
                 "reflected object per reflector pixel (in %) and the time per frame."),
    "sweep": ("run time against error, one knob at a time from the paper preset (docs/benchmarks.md)",
              "Time each setting (the paper preset, then the paper preset with one knob changed) on each scene and "
              "measure its agreement with the ray-traced truth (in %); the Pareto front marks the settings no other "
              "is both faster and closer than."),
    "scaling": ("run time against vertex count and image size, with fitted slopes (docs/benchmarks.md)",
                "Time the search and the frame on icospheres of growing vertex count and on growing image sizes, "
                "and fit the slopes of log time against log size."),
    "table1": ("the paper's Table 1: search iterations per animation (docs/benchmarks.md)",
               "Render each animation with the paper preset and count the search's iterations per vertex, as "
               "Estalella et al.'s Table 1 (mean of the worst frame, mean over all frames), beside the paper's."),
}
#: Which bench subcommands each option belongs to (shown in their --help; refused by the others).
#: A ``help`` given as a dict is per subcommand ("*": the rest), so that each --help shows only its
#: own defaults.
_BENCH_OPTIONS = [
    (("--scenes",), dict(nargs="+", default=None, metavar="SCENE",
                         help={"accuracy": "built-in scenes (default: all)",
                               "sweep": "built-in scenes (default: sphere quad kitchen)",
                               "table1": "built-in scenes (default: kitchen ufo ants)"}),
     ("accuracy", "sweep", "table1")),
    (("--sizes",), dict(nargs="+", default=None, metavar="WxH", help="image sizes (default 640x480 1024x768)"),
     ("accuracy",)),
    (("--setting",), dict(action="append", default=None, metavar="NAME",
                          help="only these settings (repeatable; default all: paper, accurate, and the accurate "
                               "preset with one part changed)"), ("accuracy",)),
    (("--out",), dict(default=None, metavar="DIR",
                      help={w: f"output folder (default: out/bench/{w})" for w in ("accuracy", "sweep", "scaling",
                                                                                   "table1")}),
     ("accuracy", "sweep", "scaling", "table1")),
    (("--width",), dict(type=int, default=None, help={"sweep": "image width (default 320)",
                                                       "*": "image width (default 1024)"}),
     ("sweep", "scaling", "table1")),
    (("--height",), dict(type=int, default=None, help={"sweep": "image height (default 240)",
                                                        "*": "image height (default 768)"}),
     ("sweep", "scaling", "table1")),
    (("--frames",), dict(type=int, default=None, metavar="N",
                         help={"accuracy": "frames per scene (default: 5 spread over each animation)",
                               "sweep": "frames per scene (default 3)",
                               "table1": "frames per scene (default: all)"}),
     ("accuracy", "sweep", "table1")),
    (("--repeats",), dict(type=int, default=None, metavar="N", help="timed runs per setting, the median kept "
                                                                    "(default 3)"), ("sweep", "scaling")),
    (("--knob",), dict(action="append", default=None, metavar="NAME",
                       help="sweep only these knobs (repeatable): preset, gbuffer_scale, widen, neighbourhood, method, "
                            "precision, inverse, tessellate, refine, virtual, silhouette"), ("sweep",)),
    (("--max-vertices",), dict(type=int, default=1 << 20, metavar="N", help="largest vertex count"), ("scaling",)),
    (("--max-subdivisions",), dict(type=int, default=8, metavar="N", help="largest icosphere subdivision"),
     ("scaling",)),
    (("--max-width",), dict(type=int, default=2048, metavar="W", help="largest image width"), ("scaling",)),
    (("--gbuffer-scales",), dict(nargs="+", type=float, default=None, metavar="S",
                                 help="G-buffer pixel densities against the view's, one table per value (default 1)"),
     ("table1",)),
    (("--slowdowns",), dict(nargs="+", type=int, default=None, metavar="M",
                            help="render each animation with M times the frames (each moving 1/M as far), one table "
                                 "per value (default 1)"), ("table1",)),
    (("--scheduler",), dict(default=None, metavar="WHERE",
                            help="where the tasks run: 'local' (a Dask cluster on this machine; the default when Dask "
                                 "is installed), 'serial' (one after another in this process) or tcp://HOST:PORT (a "
                                 "running Dask scheduler); docs/benchmarks.md, 'Sweeps on a cluster'"),
     ("accuracy", "sweep", "scaling", "table1")),
    (("--workers",), dict(type=int, default=None, metavar="N",
                          help="--scheduler local: worker processes (default: the cores; timed runs at most the "
                               "cores)"), ("accuracy", "sweep", "scaling", "table1")),
    (("--no-timing",), dict(action="store_true",
                            help="error figures only, no times (then workers may share cores)"),
     ("accuracy", "sweep", "table1")),
    (("--fresh",), dict(action="store_true", help="compute every task again instead of reusing the results stored "
                                                  "in the output folder's tasks/"),
     ("accuracy", "sweep", "scaling", "table1")),
    (("--connect-timeout",), dict(type=float, default=None, metavar="S",
                                  help="--scheduler tcp://...: seconds to wait for the scheduler and its first worker "
                                       "(default 10)"), ("accuracy", "sweep", "scaling", "table1")),
]


def _bench_command(sub):
    """``bench`` and its four subcommands, each with the help of its own options only (the
    others are accepted, hidden, so that ``cmd_bench`` names them in its refusal)."""
    b = sub.add_parser("bench", help="run time against error: accuracy, sweep, scaling, table1 (docs/benchmarks.md, "
                                     "docs/accuracy.md)",
                       description="Benchmarks of run time against error; each writes its tables, plots and a "
                                   "self-contained report.html. 'refsoft bench WHAT --help' for one's options.")
    what = b.add_subparsers(dest="what", required=True, metavar="WHAT", help="which benchmark")
    for name, (short, long) in _BENCH.items():
        w = what.add_parser(name, help=short, description=long)
        for flags, kw, owners in _BENCH_OPTIONS:
            text = kw["help"] if not isinstance(kw["help"], dict) else kw["help"].get(name, kw["help"].get("*"))
            w.add_argument(*flags, **dict(kw, help=text if name in owners else argparse.SUPPRESS))
        w.set_defaults(func=commands.cmd_bench)


def main(argv=None, installed=False) -> int:
    """Run the command line; returns the exit status (0 done, 1 a check failed, 2 bad input,
    130 interrupted). ``installed``: the interrupt handler is already in place
    (:mod:`refsoft._start`)."""
    from .. import interrupt
    from ..errors import RefsoftError

    if not installed:
        interrupt.install()
    try:
        parser = build_parser()
        args = parser.parse_args(argv)
        args.argv = list(sys.argv[1:] if argv is None else argv)  # what reports say made them
        code = args.func(args)
        interrupt.check()  # an interrupt a library swallowed
        return code
    except RefsoftError as exc:
        print(f"refsoft: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # output piped into head and closed: not an error
        return 0
    except OSError as exc:
        print(f"refsoft: error: {exc.strerror or exc}: {exc.filename or ''}".rstrip(": "), file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(interrupt.MESSAGE, file=sys.stderr)
        return 130
    except Exception:  # an interrupt inside a compiled call surfaces as "returned a result with an exception
        # set", one inside NumPy's import as an ImportError: Ctrl-C was pressed, whatever the exception says
        if not interrupt.seen():
            raise
        print(interrupt.MESSAGE, file=sys.stderr)
        return 130
    finally:
        if not installed:
            interrupt.restore()
