"""``refsoft-glsl run GOLDEN --out CANDIDATE [--case NAME ...] [--plain]``: the GLSL port of
the main method and of both comparison methods (the layered depth textures, the environment map)
on Mesa llvmpipe, run on a golden set's inputs.
``refsoft-glsl info``: the renderer, Mesa and LLVM versions it runs on (exit 2 when no llvmpipe
EGL context can be made).

``run`` declares what the port does not port in ``CANDIDATE/ported.json`` (refsoft's format
``refsoft-ported-1``) and skips the cases of the methods and option values it declares, one line
each; it exits 0
when every case it rendered succeeded."""

from __future__ import annotations

import argparse
import os
import sys
import time


def main(argv=None) -> int:
    # the docstring's RST literals (``x``) read as plain text in --help
    parser = argparse.ArgumentParser(prog="refsoft-glsl", description=__doc__.split("\n\n")[0].replace("``", ""))
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="render golden cases from their inputs into a candidate folder")
    run.add_argument("golden", help="a golden set (refsoft golden --out GOLDEN), or a folder of cases exported by "
                     "refsoft export --out GOLDEN/CASE/inputs: each CASE/inputs/ is read")
    run.add_argument("--out", required=True, help="the candidate folder (CASE/frame_NNNN.npz, CASE/stats.json)")
    run.add_argument("--case", action="append", dest="cases", metavar="NAME",
                     help="render only this case (repeatable; default every case of the set)")
    run.add_argument("--plain", action="store_true",
                     help="the plain variant: GL's own interpolation, built-in normalize/dot, no precise")
    run.add_argument("--quiet", action="store_true", help="no progress lines")
    sub.add_parser("info", help="the renderer, Mesa and LLVM versions (exit 2 without an llvmpipe EGL context)")
    args = parser.parse_args(argv)
    from .context import GLUnavailable, context
    from .inputs import InputError
    from .run import case_options, declared, gl_versions, run_case, write_ported

    if args.command == "info":
        try:
            v = gl_versions(context())
        except GLUnavailable as exc:
            print(f"refsoft-glsl: error: {exc}", file=sys.stderr)
            return 2
        for key in ("GL_RENDERER", "GL_VERSION", "GL_VENDOR", "mesa", "llvm"):
            print(f"{key}: {v[key]}")
        return 0

    try:
        options = case_options(args.golden)
    except (OSError, ValueError, KeyError) as exc:
        print(f"refsoft-glsl: error: {args.golden} is not a golden set ({exc})", file=sys.stderr)
        return 2
    chosen = args.cases or list(options)
    unknown = [c for c in chosen if c not in options]
    if unknown:
        print(f"refsoft-glsl: error: unknown case {unknown[0]!r} (cases: {', '.join(options)})", file=sys.stderr)
        return 2
    try:
        gl = context()
    except GLUnavailable as exc:
        print(f"refsoft-glsl: error: {exc}", file=sys.stderr)
        return 2
    log = None if args.quiet else (lambda s: print(s, file=sys.stderr, flush=True))
    v = gl_versions(gl)
    if log:
        log(f"{v['GL_RENDERER']}; {v['GL_VERSION']}")
    t0 = time.perf_counter()
    failed = []
    write_ported(args.out)
    skipped = 0
    for name in chosen:
        why = declared(options[name])
        if why:
            # declared, so refsoft check reports the case as not ported, not missing
            print(f"case {name}: {why} not ported (declared in ported.json)", file=sys.stderr)
            skipped += 1
            continue
        try:
            run_case(gl, args.golden, name, args.out, plain=args.plain, log=log)
        except NotImplementedError as exc:
            print(f"refsoft-glsl: {exc}", file=sys.stderr)
            failed.append(name)
        except InputError as exc:
            print(f"refsoft-glsl: error: {exc}", file=sys.stderr)
            return 2
    if log:
        done = len(chosen) - len(failed) - skipped
        log(f"{done} cases in {time.perf_counter() - t0:.1f} s into {os.fspath(args.out)}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
