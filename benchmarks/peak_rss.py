"""Peak resident memory of ``refsoft render`` processes, beside the memory guard's estimate.

Two processes per case, both fresh interpreters with Numba's cache warm:

- the render: ``python -m refsoft render SCENE --width W --height H --frames N --out DIR
  --overwrite [OPTIONS]``; its peak resident set is the ``ru_maxrss`` that ``os.wait4`` returns
  for that process alone (the kernel's high-water mark of its resident pages, VmHWM);
- the baseline: this file run as ``python peak_rss.py baseline SCENE [OPTIONS]``, which imports
  refsoft, Numba and the command line, renders the same frames of the same scene with the same
  options at 64x48 (loading every kernel the render loads, and the scene's meshes), collects
  garbage and reports its resident set then (``VmRSS``): what the guard does not count.

The guard's estimate is :func:`refsoft.limits.frame_bytes` for the options the command line
builds, with two frames kept, as the command line checks a run of several frames (it writes
each frame while the next one renders, then drops it).

Run by hand: ``PYTHONPATH=. python benchmarks/peak_rss.py SCENE [OPTIONS]`` prints one JSON line.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import tempfile

BASELINE_SIZE = (64, 48)


def _status(field: str) -> int:
    """A ``/proc/self/status`` memory field in bytes."""
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith(field + ":"):
                return int(line.split()[1]) * 1024
    raise RuntimeError(f"no {field} in /proc/self/status")


def _run(argv, env) -> tuple[int, str, str, int]:
    """Run ``argv``; return (status, stdout, stderr, peak RSS in bytes of that process alone)."""
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        p = subprocess.Popen(argv, stdout=out, stderr=err, env=env)
        _, status, usage = os.wait4(p.pid, 0)
        p.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        return p.returncode, out.read(), err.read(), usage.ru_maxrss * 1024  # ru_maxrss: KiB on Linux


def _cli_args(scene, size, frames, out, options):
    return ["render", scene, "--width", str(size[0]), "--height", str(size[1]), "--frames", str(frames),
            "--out", out, "--overwrite", *options]


def _kernels(stderr: str) -> tuple[int | None, int | None]:
    """(specialisations compiled, loaded from the cache) from ``REFSOFT_COMPILE_REPORT``'s line."""
    m = re.search(r"compiled (\d+) specialisations.*loaded (\d+) from the cache", stderr)
    return (int(m.group(1)), int(m.group(2))) if m else (None, None)


def estimate(scene: str, size, options, frames: int = 2) -> dict:
    """The guard's estimate (bytes, :func:`refsoft.limits.frame_bytes`) of the render of
    ``frames`` frames the command line runs with ``options`` (command-line words), as its
    ``render`` checks it."""
    from refsoft import cli
    from refsoft.cli.options import render_kwargs
    from refsoft.frame import RenderOptions
    from refsoft.limits import frame_bytes
    from refsoft.scene import load_scene

    args = cli.build_parser().parse_args(_cli_args(scene, size, frames, "unused", options))
    kw = render_kwargs(args)
    opts = RenderOptions(preset=kw.pop("preset", "accurate"), **kw)
    return frame_bytes(load_scene(scene, width=size[0], height=size[1]), opts, min(frames, 2))


def measure(scene: str, options=(), size=(1024, 768), frames: int = 2) -> dict:
    """One render and one baseline process (see the module docstring); bytes."""
    env = dict(os.environ, REFSOFT_COMPILE_REPORT="1")
    with tempfile.TemporaryDirectory() as tmp:
        code, _, err, peak = _run([sys.executable, "-m", "refsoft", *_cli_args(scene, size, frames,
                                                                               os.path.join(tmp, "r"), options)], env)
        if code != 0:
            raise RuntimeError(f"render {scene} {options} failed ({code}): {err.strip()[-400:]}")
        code, base_out, err2, _ = _run([sys.executable, os.path.abspath(__file__), "baseline", scene,
                                        str(frames), os.path.join(tmp, "b"), *options], env)
        if code != 0:
            raise RuntimeError(f"baseline {scene} {options} failed ({code}): {err2.strip()[-400:]}")
    base = json.loads(base_out.strip().splitlines()[-1])
    est = estimate(scene, size, list(options), frames)
    return {"scene": scene, "options": " ".join(options), "width": size[0], "height": size[1], "frames": frames,
            "peak_rss": peak, "baseline_rss": base["rss"], "baseline_peak_rss": base["peak_rss"],
            "over_baseline": peak - base["rss"], "estimate": est["total"],
            "estimate_parts": {k: v for k, v in est.items() if k != "total"},
            "kernels_compiled": _kernels(err)[0], "kernels_loaded": _kernels(err)[1],
            "baseline_kernels_loaded": base["kernels_loaded"]}


def _baseline(scene: str, frames: str, out: str, options) -> None:
    import contextlib
    import gc
    import io

    import numba  # noqa: F401  (imported as the render imports it)

    from refsoft import _numba, cli

    with contextlib.redirect_stdout(io.StringIO()):
        code = cli.main(_cli_args(scene, BASELINE_SIZE, int(frames), out, options))
    if code != 0:
        sys.exit(code)
    gc.collect()
    loaded = sum(v == "loaded" for sigs in _numba.specialisations().values() for v in sigs.values())
    print(json.dumps({"rss": _status("VmRSS"), "peak_rss": _status("VmHWM"), "kernels_loaded": loaded}))


if __name__ == "__main__":
    if sys.argv[1] == "baseline":
        _baseline(sys.argv[2], sys.argv[3], sys.argv[4], sys.argv[5:])
    else:
        print(json.dumps(measure(sys.argv[1], sys.argv[2:])))
