"""Running golden cases: read each case's inputs, render its frames in order, write the
candidate layout of spec section 7 (``CANDIDATE/CASE/frame_NNNN.npz`` and ``stats.json``)."""

from __future__ import annotations

import json
import os
import re
import tempfile

import numpy as np

from .inputs import read_case


def gl_versions(gl) -> dict:
    """The renderer's strings and the Mesa and LLVM versions in them."""
    mesa = re.search(r"Mesa ([0-9][0-9.]*\S*)", gl.version)
    llvm = re.search(r"LLVM ([0-9][0-9.]*)", gl.renderer)
    return {"GL_RENDERER": gl.renderer, "GL_VERSION": gl.version, "GL_VENDOR": gl.vendor,
            "mesa": mesa.group(1) if mesa else None, "llvm": llvm.group(1) if llvm else None}


def _atomic_write(path, write):
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(path) + ".", suffix=".tmp", dir=folder)
    os.close(fd)
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def write_npz(path, arrays):
    def write(tmp):
        with open(tmp, "wb") as fh:
            np.savez_compressed(fh, **arrays)
    _atomic_write(path, write)


def write_json(path, data):
    def write(tmp):
        with open(tmp, "w") as fh:
            json.dump(data, fh, indent=1)
            fh.write("\n")
    _atomic_write(path, write)


def case_options(golden) -> dict:
    """Each case of a golden set (manifest order) -> its options. A folder without
    ``manifest.json`` is read as cases exported by ``refsoft export`` into
    ``FOLDER/CASE/inputs/`` (name order)."""
    path = os.path.join(golden, "manifest.json")
    if not os.path.exists(path):
        names = sorted(n for n in os.listdir(golden) if os.path.isfile(os.path.join(golden, n, "inputs", "case.json")))
        if not names:
            raise ValueError("neither a manifest.json nor CASE/inputs/case.json folders")
        return {n: read_case_options(os.path.join(golden, n, "inputs")) for n in names}
    with open(path) as fh:
        manifest = json.load(fh)
    return {c["name"]: c["options"] for c in manifest["cases"]}


def read_case_options(folder) -> dict:
    """The ``options`` of ``folder/case.json``."""
    with open(os.path.join(folder, "case.json")) as fh:
        return json.load(fh)["options"]


def run_case(gl, golden, name, out, plain=False, log=None) -> dict:
    """Render one case into ``out/NAME``; returns its ``stats.json`` content."""
    from .pipeline import Pipeline

    case = read_case(os.path.join(golden, name, "inputs"))
    if case.options.get("method") == "ldt":
        from .ldt import LdtPipeline, PlainLdtPipeline

        cls = PlainLdtPipeline if plain else LdtPipeline
    elif case.options.get("method") == "envmap":
        from .envmap import EnvmapPipeline, PlainEnvmapPipeline

        cls = PlainEnvmapPipeline if plain else EnvmapPipeline
    elif plain:
        from .plain import PlainPipeline as cls
    else:
        cls = Pipeline
    pipe = cls(gl, case)
    frames = []
    folder = os.path.join(out, name)
    for fr in case.frames:
        arrays, times, iterations = pipe.render(fr)
        write_npz(os.path.join(folder, f"frame_{fr.index:04d}.npz"), arrays)
        frames.append({"frame": fr.index, "time_ms": {k: round(v, 3) for k, v in times.items()},
                       "iterations": iterations})
        if log:
            log(f"{name} frame {fr.index}: {times['total']:.1f} ms")
    for file, arrays in getattr(pipe, "run_files", dict)().items():
        write_npz(os.path.join(folder, f"{file}.npz"), arrays)
    means = [np.mean([v["mean"] for v in f["iterations"].values()]) for f in frames if f["iterations"]]
    stats = {"port": "glsl", "variant": "plain" if plain else "exact", "gl": gl_versions(gl),
             "options": case.options, "frames": frames,
             "summary": {"max_frame_mean_iterations": float(max(means)) if means else 0.0,
                         "total_mean_iterations": float(np.mean(means)) if means else 0.0,
                         "frames": len(frames),
                         "median_total_ms": float(np.median([f["time_ms"]["total"] for f in frames]))}}
    write_json(os.path.join(folder, "stats.json"), stats)
    return stats


#: What the port does not port (refsoft's ``ported.json``, format ``refsoft-ported-1``): every
#: image of every vertex (kind ``images``: the per-image arrays and the flag SEVERAL), several
#: bounces (kind ``bounces``: it draws the first, and writes no ``bounce_depth``) and the exact
#: drawing of the virtual triangles (option ``draw="exact"``: it rasterizes them). A case of a
#: method or an option value listed here is skipped by ``refsoft-glsl run``.
NOT_PORTED = {"options": {"draw": ["exact"]}, "kinds": ["images", "bounces"]}


def declared(options) -> str | None:
    """Why a case with these options is declared not ported (``NOT_PORTED``), or None."""
    method = options.get("method", "walk")
    if method in NOT_PORTED.get("methods", ()):
        return f"method {method!r}"
    for name, values in NOT_PORTED.get("options", {}).items():
        if options.get(name) in values:
            return f"option {name}={options[name]!r}"
    return None


def write_ported(out):
    """``out/ported.json``: the outputs the port declares it does not write."""
    write_json(os.path.join(out, "ported.json"), {"format": "refsoft-ported-1", "not_ported": NOT_PORTED})
