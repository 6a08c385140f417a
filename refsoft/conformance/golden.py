"""The golden set for ports (spec section 8): ``refsoft golden --out DIR``.

Layout (a port writes its outputs in the same layout for ``refsoft check``)::

    DIR/manifest.json                 versions, the options of each case, SHA-256 of every file
    DIR/CASE/frame_NNNN.npz           the spec section 7 arrays (plus score_k and margin_k)
    DIR/CASE/traces_NNNN.json         search traces of a sample of vertices per reflector

Traces (``format: refsoft-traces-1``): ``{"reflectors": {"K": [{"vertex": i, "start": [r, c],
"path": [[r, c], ...], "phases": [0, ..., 1, ...], "pixel": [r, c], "iterations": n, "flags": f,
"stop": "converged" | "capped"}, ...]}}``, where ``path`` lists the current pixel of every
iteration (``phases``: 0 standard, 1 inverse search). A port may write the same file for any
vertices it likes; ``check`` then names the first step at which the two walks part.

Everything is deterministic: regenerating gives byte-identical files (no time stamps).
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass, field

import numpy as np

from .. import keys
from ..errors import RefsoftError

GOLDEN_FORMAT = "refsoft-golden-1"
TRACE_FORMAT = "refsoft-traces-1"
#: Image size of every case (small: the set stays a few tens of MB).
GOLDEN_SIZE = (128, 96)
#: Vertices traced per reflector and frame (evenly spaced vertex indices).
TRACED_VERTICES = 8


@dataclass(frozen=True)
class Case:
    """One golden case: a scene, the frames rendered (coherently, in order) and the options."""

    name: str
    scene: str
    frames: tuple
    options: dict = field(default_factory=dict)

    def load(self):
        if self.scene == "pixel_grid":
            return pixel_grid_scene()
        from ..scene.builtin import load_scene

        return load_scene(self.scene, width=GOLDEN_SIZE[0], height=GOLDEN_SIZE[1])


def pixel_grid_scene():
    """A conformance scene for the rasterization and search rules: an orthographic camera with
    one world unit per pixel, a square flat mirror whose edges and diagonal pass exactly through
    pixel centres (so the fill rule decides them), a box and a ball in front of it, and a strip of
    triangles on the plane x = y, which the whole setup is symmetric about: walks toward those
    vertices meet exact ties between two moves, which only the fixed visiting order decides."""
    from ..scene.camera import Camera
    from ..scene.mesh import Mesh
    from ..scene.primitives import box, icosphere
    from ..scene.model import Scene, SceneObject, Transform

    w, h = GOLDEN_SIZE
    # pixel centres at x = -w/2 + c + 0.5, y = h/2 - r - 0.5: corners on half-integers
    v = np.array([[-20.5, -20.5, 0.0], [20.5, -20.5, 0.0], [20.5, 20.5, 0.0], [-20.5, 20.5, 0.0]])
    mirror = Mesh(v, [[0, 1, 2], [0, 2, 3]], np.tile([0.0, 0.0, 1.0], (4, 1)), name="mirror")
    a = np.arange(-15.0, 16.0, 3.0)
    strip_v = np.concatenate([np.c_[a, a, np.full_like(a, z)] for z in (8.0, 14.0)])
    n = len(a)
    strip_f = [[i, i + 1, n + i] for i in range(n - 1)] + [[i + 1, n + i + 1, n + i] for i in range(n - 1)]
    strip = Mesh(strip_v, strip_f, name="diagonal_strip")
    objects = (
        SceneObject("mirror", mirror, (0.85, 0.85, 0.9), Transform((0.0, 0.0, -4.0)), reflector=True, open=True),
        SceneObject("box", box((9.0, 7.0, 5.0), 2), (0.9, 0.3, 0.1), Transform((-26.0, 6.0, 9.0), (20.0, 30.0, 0.0))),
        SceneObject("ball", icosphere(3, 6.0), (0.2, 0.4, 0.9), Transform((24.0, -9.0, 12.0))),
        SceneObject("strip", strip, (0.3, 0.8, 0.3)),
    )
    cam = Camera(eye=(0.0, 0.0, 40.0), target=(0.0, 0.0, 0.0), width=w, height=h, near=1.0, far=100.0,
                 projection="orthographic", ortho_height=float(h))
    return Scene(objects, cam, None, "pixel_grid")


#: The canonical cases: every built-in scene with the paper preset (three coherent frames of
#: each animation), both neighbourhoods, every hidden-vertex mode, the wider frustum, float64,
#: cold searches, the pixel-grid conformance scene, Szabo's hierarchy search, and the accurate
#: preset. Each case names its preset, so a change of the default preset never changes a case.
CASES = (
    Case("sphere", "sphere", (0,), {"preset": "paper"}),
    Case("ellipsoid", "ellipsoid", (0, 1, 2), {"preset": "paper"}),
    Case("planar", "planar", (0, 1, 2), {"preset": "paper"}),
    Case("concave", "concave", (0, 1, 2), {"preset": "paper"}),
    Case("torus", "torus", (0, 1, 2), {"preset": "paper"}),
    Case("quad", "quad", (0, 1, 2), {"preset": "paper"}),
    Case("kitchen", "kitchen", (0, 1, 2), {"preset": "paper"}),
    Case("ufo", "ufo", (0, 1), {"preset": "paper"}),
    Case("ants", "ants", (0, 1), {"preset": "paper"}),
    Case("pixel_grid", "pixel_grid", (0,), {"preset": "paper"}),
    Case("sphere_box", "sphere", (0,), {"preset": "paper", "neighbourhood": "box"}),
    Case("sphere_search", "sphere", (0,), {"preset": "paper", "inverse": "search"}),
    Case("sphere_discard", "sphere", (0,), {"preset": "paper", "inverse": "discard"}),
    Case("sphere_float64", "sphere", (0,), {"preset": "paper", "precision": "float64"}),
    Case("ellipsoid_box_float64", "ellipsoid", (0, 1), {"preset": "paper", "neighbourhood": "box", "precision": "float64"}),
    Case("torus_search_box", "torus", (0, 1), {"preset": "paper", "inverse": "search", "neighbourhood": "box"}),
    Case("kitchen_widen", "kitchen", (20, 21), {"preset": "paper", "widen": 1.3}),
    Case("planar_cold", "planar", (0, 1), {"preset": "paper", "coherence": False}),
    Case("sphere_hierarchy", "sphere", (0,), {"preset": "paper", "method": "hierarchy"}),
    Case("sphere_accurate", "sphere", (0,), {"preset": "accurate"}),
    Case("kitchen_accurate", "kitchen", (0, 1, 2), {"preset": "accurate"}),
)


def case_by_name(name: str) -> Case:
    for c in CASES:
        if c.name == name:
            return c
    raise RefsoftError(f"unknown golden case {name!r} (cases: {', '.join(c.name for c in CASES)})")


def sha256(path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _git_hash():
    import subprocess

    here = os.path.dirname(os.path.abspath(__file__))
    try:
        r = subprocess.run(["git", "rev-parse", "HEAD"], cwd=here, capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return None
    return r.stdout.strip() if r.returncode == 0 else None


def trace_record(trace, vertex_index: int) -> dict:
    """One vertex's search in the trace format of this module."""
    return {"vertex": int(vertex_index), "start": [int(x) for x in trace.start],
            "path": [[int(x) for x in s["pixel"]] for s in trace.steps],
            "phases": [0 if s["phase"] == "standard" else 1 for s in trace.steps],
            "pixel": [int(x) for x in trace.pixel], "iterations": int(trace.iterations), "flags": int(trace.flags),
            "stop": trace.stop}


def hierarchy_record(gbuffer, eye, vertex, index, cap=None) -> dict:
    """One vertex's hierarchy search in the trace format: ``path`` lists ``[level, row, col]``
    of every texel popped, then the chosen base pixel ``[0, row, col]`` (level-0 entries in
    G-buffer pixels; higher levels in the pyramid over the mirror's cropped box, whose ``origin``
    the record gives)."""
    from ..search import trace_hierarchy

    tr = trace_hierarchy(gbuffer, eye, vertex, cap=cap)
    return {"vertex": int(index), "path": tr.path(), "pixel": tr.pixel, "iterations": tr.tests, "origin": tr.origin}


def traced_vertices(n: int) -> np.ndarray:
    """The vertex indices traced among ``n``: evenly spaced, first and last included."""
    return np.unique(np.linspace(0, n - 1, min(TRACED_VERTICES, n)).astype(np.int64)) if n else np.zeros(0, int)


def render_case(case: Case):
    """Yield ``(frame index, arrays, traces)`` for each frame of a case."""
    from ..frame import FrameDriver
    from ..options import RenderOptions
    from ..scene import scene_vertices
    from ..search import CULLED, trace_search

    scene = case.load()
    opts = RenderOptions(**case.options)
    driver = FrameDriver(scene, opts)
    previous = {}
    for f in case.frames:
        frame = driver.render_frame(f)
        verts, _ = scene_vertices(scene, f)
        eye = scene.camera_at(f).eye
        traces = {}
        for k in scene.reflector_ids:
            gb = frame.reflectors[k].state.gbuffer  # the G-buffer the search ran on
            pixels = frame.arrays[keys.REFLECTION_PIXEL(k)]
            records = []
            flags = frame.arrays[keys.FLAGS(k)]
            for i in traced_vertices(len(verts)):
                if flags[i] & CULLED:
                    continue
                prev = previous.get(k)
                start = None if (prev is None or not opts.coherence) else prev[i]
                if opts.method == "hierarchy":
                    records.append(hierarchy_record(gb, eye, verts[i], i, opts.cap))
                    continue
                tr = trace_search(gb, eye, verts[i], opts.neighbourhood, opts.inverse, start, opts.cap)
                if list(tr.pixel) != [int(x) for x in pixels[i]]:
                    raise RefsoftError(f"case {case.name}: the trace of vertex {i} disagrees with the kernel "
                                       "(an internal error: please report it)")
                records.append(trace_record(tr, i))
            traces[str(k)] = records
            previous[k] = pixels
        yield f, frame.arrays, {"format": TRACE_FORMAT, "reflectors": traces}


def write_golden(out, cases=None, progress=False) -> dict:
    """Write the golden set into ``out`` and return the manifest.

    Parameters
    ----------
    out : str or PathLike
    cases : list of str, optional
        Case names (default: all of :data:`CASES`).
    progress : bool
        A tqdm bar over the frames.
    """
    import numba

    from .. import __version__
    from ..io import write_json, write_npz

    chosen = list(CASES) if cases is None else [case_by_name(c) for c in cases]
    out = os.fspath(out)
    total = sum(len(c.frames) for c in chosen)
    bar = None
    if progress and total > 1:
        from tqdm import tqdm

        bar = tqdm(total=total, desc="golden", unit="frame", disable=None)
    files = {}
    entries = []
    for case in chosen:
        from ..options import RenderOptions

        entries.append({"name": case.name, "scene": case.scene, "frames": list(case.frames),
                        "width": GOLDEN_SIZE[0], "height": GOLDEN_SIZE[1],
                        "options": RenderOptions(**case.options).as_dict()})
        for f, arrays, traces in render_case(case):
            base = os.path.join(out, case.name)
            npz = os.path.join(base, f"frame_{f:04d}.npz")
            write_npz(npz, **arrays)
            tj = os.path.join(base, f"traces_{f:04d}.json")
            write_json(tj, traces)
            for p in (npz, tj):
                files[os.path.relpath(p, out).replace(os.sep, "/")] = sha256(p)
            if bar is not None:
                bar.update(1)
    if bar is not None:
        bar.close()
    manifest = {"format": GOLDEN_FORMAT, "refsoft": __version__, "git": _git_hash(), "numpy": np.__version__,
                "numba": numba.__version__, "size": list(GOLDEN_SIZE), "traced_vertices": TRACED_VERTICES,
                "cases": entries, "files": dict(sorted(files.items()))}
    write_json(os.path.join(out, "manifest.json"), manifest)
    return manifest


def read_manifest(golden) -> dict:
    """The manifest of a golden folder (checked to be one)."""
    path = os.path.join(os.fspath(golden), "manifest.json")
    if not os.path.isfile(path):
        raise RefsoftError(f"{golden} is not a golden set: no manifest.json")
    try:
        with open(path) as fh:
            m = json.load(fh)
    except (OSError, json.JSONDecodeError) as exc:
        raise RefsoftError(f"{path}: cannot read: {exc}") from None
    if m.get("format") != GOLDEN_FORMAT:
        raise RefsoftError(f"{path}: not a {GOLDEN_FORMAT} manifest (format {m.get('format')!r})")
    return m
