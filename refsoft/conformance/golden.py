"""The golden set for ports (spec section 8): ``refsoft golden --out DIR``.

Layout (a port writes its outputs in the same layout for ``refsoft check``)::

    DIR/manifest.json                 versions, the options of each case, SHA-256 of every file
    DIR/CASE/frame_NNNN.npz           the spec section 7 arrays (plus score_k and margin_k, and
                                      the oracle's gbuffer_depth_margin_k)
    DIR/CASE/traces_NNNN.json         search traces of a sample of vertices per reflector (vertex
                                      search cases)
    DIR/CASE/ldt_J.npz                the layered depth texture of reflected object J (method
                                      "ldt" cases; :meth:`refsoft.ldt.LDT.arrays`)
    DIR/CASE/inputs/                  the case's inputs: case.json and world meshes as PLY
                                      (:mod:`refsoft.conformance.export`)

Traces (``format: refsoft-traces-1``): ``{"reflectors": {"K": [{"vertex": i, "start": [r, c],
"path": [[r, c], ...], "phases": [0, ..., 1, ...], "pixel": [r, c], "iterations": n, "flags": f,
"stop": "converged" | "capped"}, ...]}}``, where ``path`` lists the current pixel of every
iteration (``phases``: 0 standard, 1 inverse search). A port may write the same file for any
vertices it likes; ``check`` then names the first step at which the two walks part.

Everything is deterministic: regenerating gives byte-identical files (no time stamps).
"""

from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass, field

import numpy as np

from .. import keys
from ..errors import InputFileError, RefsoftError

GOLDEN_FORMAT = "refsoft-golden-1"
TRACE_FORMAT = "refsoft-traces-1"
#: Image size of every case (small: the set stays a few tens of MB).
GOLDEN_SIZE = (128, 96)
#: Vertices traced per reflector and frame (evenly spaced vertex indices).
TRACED_VERTICES = 8
#: (H, W) float32 per reflector, written by the oracle only: at each G-buffer pixel, the window
#: depth of the nearest fragment behind the winning one minus the winner's (+inf where fewer
#: than two fragments cover the pixel; :func:`refsoft.raster.gbuffer_layers`). ``refsoft check``
#: accepts either fragment where it is within ``DEPTH_TIE_K * TIE_EPS``.
DEPTH_MARGIN = keys.PerReflector("gbuffer_depth_margin")


@dataclass(frozen=True)
class Case:
    """One golden case: a scene, the frames rendered (coherently, in order) and the options."""

    name: str
    scene: str
    frames: tuple
    options: dict = field(default_factory=dict)

    def load(self):
        if self.scene in CONFORMANCE_SCENES:
            return CONFORMANCE_SCENES[self.scene]()
        from ..scene.builtin import load_scene

        return load_scene(self.scene, width=GOLDEN_SIZE[0], height=GOLDEN_SIZE[1])

    @property
    def per_pixel(self) -> bool:
        """The case renders with a per-pixel comparison method (``ldt``, ``envmap``): no vertex
        search, so no traces and no G-buffer depth margins."""
        return self.options.get("method") in PER_PIXEL_METHODS


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


def cube_edge_scene():
    """A conformance scene for the tie rules of the comparison methods: an orthographic camera
    looking straight down -y (the view direction exactly ``(0, -1, 0)``) at a mirror gutter whose
    vertex normals have equal x and z components, so that every reflected direction has
    ``r_x == r_z`` exactly, the largest component: each pixel's environment-map lookup falls on
    the cube's +X/+Z edge, where only the face order (z over y over x) decides, and each ray's
    LDT faces tie in ``|u_x| == |u_z|`` for the axis-aligned objects (ties to the smaller axis).
    A box, a ball and a cube stand along that edge's direction, above one another."""
    from ..scene.camera import Camera
    from ..scene.mesh import Mesh
    from ..scene.primitives import box, icosphere
    from ..scene.model import Scene, SceneObject, Transform

    w, h = GOLDEN_SIZE
    radius, length, n_theta, n_len = 20.0, 60.0, 12, 8
    verts, normals = [], []
    for along in np.linspace(-0.5 * length, 0.5 * length, n_len + 1):
        a = along / np.sqrt(2.0)  # along the axis (1, 0, -1) / sqrt(2)
        for theta in np.radians(np.linspace(30.0, 60.0, n_theta + 1)):  # r_x = r_z > |r_y| throughout
            c = np.cos(theta) / np.sqrt(2.0)
            n = np.array([c, np.sin(theta), c])  # one value for x and z: equal bit for bit
            verts.append(np.array([a, 0.0, -a]) + radius * n)
            normals.append(n)
    m = n_theta + 1
    faces = [t for i in range(n_len) for j in range(n_theta) for p in [i * m + j]
             for t in ([p, p + m, p + 1], [p + 1, p + m, p + m + 1])]
    gutter = Mesh(np.array(verts), np.array(faces), np.array(normals), name="gutter")
    centre = 0.5 * (gutter.vertices.min(axis=0) + gutter.vertices.max(axis=0))
    edge = centre + 25.0 * np.array([1.0, 0.0, 1.0]) / np.sqrt(2.0)
    objects = (
        SceneObject("gutter", gutter, (0.85, 0.85, 0.9), Transform(), reflector=True, open=True),
        SceneObject("pillar", box((8.0, 16.0, 8.0), 2), (0.9, 0.3, 0.1), Transform(tuple(edge))),
        SceneObject("ball", icosphere(3, 7.0), (0.2, 0.4, 0.9), Transform(tuple(edge + [0.0, 15.0, 0.0]))),
        SceneObject("block", box((6.0, 6.0, 6.0), 1), (0.3, 0.8, 0.3), Transform(tuple(edge + [0.0, -13.0, 0.0]))),
    )
    cam = Camera(eye=(centre[0], 60.0, centre[2]), target=(centre[0], 0.0, centre[2]), up=(0.0, 0.0, -1.0), width=w,
                 height=h, near=1.0, far=200.0, projection="orthographic", ortho_height=40.0)
    return Scene(objects, cam, None, "cube_edge")


#: The scenes made for the rules (beside the built-in ones), by name.
CONFORMANCE_SCENES = {"pixel_grid": pixel_grid_scene, "cube_edge": cube_edge_scene}
#: The per-pixel comparison methods (refsoft.ldt, refsoft.envmap).
PER_PIXEL_METHODS = ("ldt", "envmap")


#: The canonical cases: every built-in scene with the paper preset (three coherent frames of
#: each animation), both neighbourhoods, every hidden-vertex mode, the wider frustum, float64,
#: cold searches, the pixel-grid conformance scene, Szabo's hierarchy search, and the accurate
#: preset (its virtual triangles rasterized, and drawn exactly; on the mirrors that are not
#: convex with every image of every vertex; three mirror balls with three bounces); then the comparison methods at a small resolution R = 64: the layered depth textures
#: (two coherent frames, a hollow object's two layers, float64, the tie scene, open sheets) and the
#: environment map (an object touching the mirror, the tie scene). Each case names its preset,
#: so a change of the default preset never changes a case.
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
    Case("sphere_accurate", "sphere", (0,), {"preset": "accurate", "draw": "raster"}),
    Case("kitchen_accurate", "kitchen", (0, 1, 2), {"preset": "accurate", "draw": "raster"}),
    Case("kitchen_exact", "kitchen", (0, 1), {"preset": "accurate"}),
    Case("concave_accurate", "concave", (0, 1), {"preset": "accurate", "images": "all", "draw": "raster"}),
    Case("torus_accurate", "torus", (0, 1), {"preset": "accurate", "images": "all", "draw": "raster"}),
    Case("mirrors_bounces", "mirrors", (0, 1), {"preset": "accurate", "bounces": 3, "draw": "raster"}),
    Case("balls_ldt", "balls", (0, 1), {"preset": "paper", "method": "ldt", "ldt_resolution": 64}),
    Case("hollow_box_ldt", "hollow_box", (0,), {"preset": "paper", "method": "ldt", "ldt_resolution": 64,
                                                "ldt_layers": "all"}),
    Case("genus3_ldt_float64", "genus3", (0,), {"preset": "paper", "method": "ldt", "ldt_resolution": 64,
                                                "precision": "float64"}),
    Case("cube_edge_ldt", "cube_edge", (0,), {"preset": "paper", "method": "ldt", "ldt_resolution": 64}),
    Case("quad_ldt", "quad", (0,), {"preset": "paper", "method": "ldt", "ldt_resolution": 64}),
    Case("touching_envmap", "touching", (0,), {"preset": "paper", "method": "envmap", "envmap_resolution": 64}),
    Case("cube_edge_envmap", "cube_edge", (0,), {"preset": "paper", "method": "envmap", "envmap_resolution": 64}),
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
    """HEAD of the git work tree the package itself was loaded from, or None.

    Only a work tree of refsoft counts: its top level must hold this package as ``refsoft/`` and
    a ``pyproject.toml`` naming ``refsoft``. An installed package (site-packages inside some other
    repository, or no repository at all) gives None rather than another project's hash.
    """
    import subprocess

    package = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

    def git(*args):
        try:
            r = subprocess.run(["git", *args], cwd=package, capture_output=True, text=True, timeout=10)
        except (OSError, subprocess.SubprocessError):
            return None
        return r.stdout.strip() if r.returncode == 0 else None

    top = git("rev-parse", "--show-toplevel")
    if not top or os.path.realpath(os.path.join(top, "refsoft")) != os.path.realpath(package):
        return None
    if _project_name(os.path.join(top, "pyproject.toml")) != "refsoft":
        return None
    return git("rev-parse", "HEAD")


def _project_name(path):
    """``[project] name`` of a pyproject.toml, or None when it has none or cannot be read."""
    try:
        import tomllib
    except ImportError:  # Python 3.10
        import tomli as tomllib
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh).get("project", {}).get("name")
    except (OSError, ValueError, AttributeError):
        return None


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


def depth_margin(scene, k: int, frame: int, gb) -> np.ndarray:
    """:data:`DEPTH_MARGIN` of reflector ``k`` for the G-buffer ``gb`` the search ran on, whose
    winning fragments :func:`refsoft.raster.gbuffer_layers` must reproduce bit for bit."""
    from ..raster import gbuffer_layers

    h, w = gb.mask.shape
    sec = gbuffer_layers(scene.world_mesh(k, frame, proxy=True), gb.view_proj, w, h, gb.position.dtype.name,
                         gb.origin)
    if not np.array_equal(sec.first_triangle, gb.triangle):
        raise RefsoftError(f"reflector {k} frame {frame}: the depth layers' nearest fragments are not the G-buffer's "
                           "(an internal error: please report it)")
    return sec.margin


def render_case(case: Case, scene=None, run_files=None):
    """Yield ``(frame index, arrays, traces)`` for each frame of a case (``scene``: the case's
    scene, already loaded): the arrays of the golden frame, those of a render and the oracle's
    :data:`DEPTH_MARGIN` of each reflector. A per-pixel method's case (:attr:`Case.per_pixel`)
    has neither traces (None) nor depth margins; ``run_files``, a dict, then receives the files
    its method writes once per run, after the first frame (``{"ldt_J": arrays}``)."""
    from ..frame import FrameDriver
    from ..options import RenderOptions
    from ..scene import scene_vertices
    from ..search import CULLED, trace_search

    scene = case.load() if scene is None else scene
    opts = RenderOptions(**case.options)
    driver = FrameDriver(scene, opts)
    previous = {}
    for f in case.frames:
        frame = driver.render_frame(f)
        if case.per_pixel:
            once = getattr(driver.method, "run_files", None)
            if run_files is not None and once is not None and f == case.frames[0]:
                run_files.update(once())
            yield f, dict(frame.arrays), None
            continue
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
        arrays = dict(frame.arrays)
        for k in scene.reflector_ids:
            arrays[DEPTH_MARGIN(k)] = depth_margin(scene, k, f, frame.reflectors[k].state.gbuffer)
        yield f, arrays, {"format": TRACE_FORMAT, "reflectors": traces}


def golden_case_task(name: str) -> dict:
    """One case rendered, as a task of :mod:`refsoft.bench.tasks` (a Dask worker imports it by
    name): ``{"frames": [...], "F/names": [...], "F/NAME": array, "F/traces": {...}}`` for each
    frame F, its arrays' names in output order."""
    case = case_by_name(name)
    out = {"frames": [int(f) for f in case.frames]}
    for f, arrays, traces, once in _frames_here(case, case.load(), None):
        out[f"{f}/names"] = list(arrays)
        out.update({f"{f}/{k}": np.asarray(v) for k, v in arrays.items()})
        out[f"{f}/traces"] = traces
        out[f"{f}/once"] = {run: list(a) for run, a in once.items()}  # the files written once per run
        out.update({f"{f}/once/{run}/{k}": np.asarray(v) for run, a in once.items() for k, v in a.items()})
    return out


def _rendered_cases(chosen, scheduler, workers, connect_timeout, on_frame):
    """``(case, scene, [(f, arrays, traces)])`` for each chosen case, in order: rendered here one
    frame at a time (``scheduler="serial"``), or one task per case on Dask (every task done
    before the first case is yielded, so that a refused or failed run writes nothing)."""
    if scheduler == "serial":
        for case in chosen:
            scene = case.load()
            yield case, scene, _frames_here(case, scene, on_frame)
        return
    from ..bench.tasks import CONNECT_TIMEOUT, Task, run_tasks

    tasks = [Task({"golden": c.name}, golden_case_task, (c.name,), label=c.name) for c in chosen]
    run = run_tasks(tasks, scheduler=scheduler, workers=workers, store=None, progress=on_frame is not None,
                    desc="golden", connect_timeout=CONNECT_TIMEOUT if connect_timeout is None else connect_timeout)
    for case, res in zip(chosen, run.results):
        yield case, case.load(), [(f, {k: res[f"{f}/{k}"] for k in res[f"{f}/names"]}, res[f"{f}/traces"],
                                   {run: {k: res[f"{f}/once/{run}/{k}"] for k in names}
                                    for run, names in res[f"{f}/once"].items()})
                                  for f in res["frames"]]


def _frames_here(case, scene, on_frame):
    """``(f, arrays, traces, files written once per run after this frame)`` of each frame."""
    once = {}
    for f, arrays, traces in render_case(case, scene, once):
        yield f, arrays, traces, dict(once)
        once.clear()
        if on_frame is not None:
            on_frame()


def write_golden(out, cases=None, progress=False, mode=None, scheduler="serial", workers=None,
                 connect_timeout=None) -> dict:
    """Write the golden set into ``out`` and return the manifest.

    Parameters
    ----------
    out : str or PathLike
    cases : list of str, optional
        Case names (default: all of :data:`CASES`).
    progress : bool
        A tqdm bar over the frames.
    mode : {None, "add", "replace"}
        What to do when ``out`` already holds a golden set (a ``manifest.json``): None refuses
        (so that a set never silently shrinks to the cases named); ``"add"`` writes the named
        cases (new or regenerated) and keeps every other case with its manifest entry, after
        checking their files against their SHA-256; ``"replace"`` starts the set anew and, once
        it is written, removes the files the old manifest lists that it did not rewrite. A new
        folder is written the same in every mode.
    scheduler : {"serial", "local"} or str
        Where the cases are rendered: here, frame by frame (default), or one task per case on a
        local Dask cluster of ``workers`` processes or ``"tcp://HOST:PORT"``
        (:func:`refsoft.bench.tasks.run_tasks`). The files are the same, bit for bit.
    """
    import numba

    from .. import __version__
    from ..io import write_json, write_npz
    from .export import INPUTS_FOLDER, write_inputs

    if mode not in (None, "add", "replace"):
        raise RefsoftError(f"mode must be None, 'add' or 'replace', got {mode!r}")
    chosen = list(CASES) if cases is None else [case_by_name(c) for c in cases]
    out = os.fspath(out)
    versions = {"format": GOLDEN_FORMAT, "refsoft": __version__, "numpy": np.__version__, "numba": numba.__version__,
                "size": list(GOLDEN_SIZE), "traced_vertices": TRACED_VERTICES}
    kept_entries, kept_files, old_files = _existing_set(out, mode, {c.name for c in chosen}, versions)
    total = sum(len(c.frames) for c in chosen)
    bar = None
    if progress and total > 1 and scheduler == "serial":
        from tqdm import tqdm

        bar = tqdm(total=total, desc="golden", unit="frame", disable=None)
    on_frame = None if not progress else (bar.update if bar is not None else (lambda: None))
    files = dict(kept_files)
    entries = {e["name"]: e for e in kept_entries}
    from ..options import RenderOptions

    for case, scene, rendered in _rendered_cases(chosen, scheduler, workers, connect_timeout, on_frame):
        entries[case.name] = {"name": case.name, "scene": case.scene, "frames": list(case.frames),
                              "width": GOLDEN_SIZE[0], "height": GOLDEN_SIZE[1],
                              "options": RenderOptions(**case.options).as_dict()}
        base = os.path.join(out, case.name)
        for name in write_inputs(os.path.join(base, INPUTS_FOLDER), scene, case.frames, case.options, case.name):
            rel = f"{case.name}/{INPUTS_FOLDER}/{name}"
            files[rel] = sha256(os.path.join(out, *rel.split("/")))
        for f, arrays, traces, once in rendered:
            npz = os.path.join(base, f"frame_{f:04d}.npz")
            write_npz(npz, **arrays)
            written = [npz]
            if traces is not None:
                written.append(os.path.join(base, f"traces_{f:04d}.json"))
                write_json(written[-1], traces)
            for name, run_arrays in sorted(once.items()):  # the LDTs, once per case
                written.append(os.path.join(base, name + ".npz"))
                write_npz(written[-1], **run_arrays)
            for p in written:
                files[os.path.relpath(p, out).replace(os.sep, "/")] = sha256(p)
    if bar is not None:
        bar.close()
    order = {c.name: i for i, c in enumerate(CASES)}  # canonical order; cases no longer canonical last
    names = sorted(entries, key=lambda n: (order.get(n, len(order)), list(entries).index(n)))
    manifest = {"format": GOLDEN_FORMAT, "refsoft": __version__, "git": _git_hash(), "numpy": np.__version__,
                "numba": numba.__version__, "size": list(GOLDEN_SIZE), "traced_vertices": TRACED_VERTICES,
                "cases": [entries[n] for n in names], "files": dict(sorted(files.items()))}
    write_json(os.path.join(out, "manifest.json"), manifest)
    _remove_listed(out, set(old_files) - set(files))  # --replace: the old set's files not rewritten
    return manifest


def _existing_set(out, mode, chosen, versions):
    """What an existing golden set in ``out`` keeps: ``(case entries, {file: SHA-256}, old
    files)``: with ``mode="add"`` the entries and files of the cases not in ``chosen``; with
    ``"replace"`` only the old manifest's file list (removed once the new set is written).
    Refuses, before anything is written, an existing set without a mode, and ``"add"`` to a set
    of other versions or with altered files."""
    path = os.path.join(out, "manifest.json")
    if not os.path.exists(path):
        return [], {}, []
    if mode is None:
        raise RefsoftError(f"{out} already holds a golden set (manifest.json): give --add to add or regenerate the "
                           "named cases and keep the others, or --replace to start the set anew")
    if mode == "replace":
        try:
            return [], {}, list(read_manifest(out)["files"])
        except RefsoftError:
            return [], {}, []  # an unreadable manifest lists nothing to remove; it is overwritten
    old = read_manifest(out)
    for key in ("refsoft", "numpy", "numba", "size", "traced_vertices"):
        if old.get(key) != versions[key]:
            raise RefsoftError(f"{path}: made with {key} {old.get(key)!r}, this is {versions[key]!r}: --add would mix "
                               "them in one set; regenerate it with --replace")
    entries = [e for e in old["cases"] if e["name"] not in chosen]
    keep = {e["name"] for e in entries}
    files = {rel: h for rel, h in old["files"].items() if rel.split("/")[0] in keep}
    for rel, h in files.items():
        p = os.path.join(out, *rel.split("/"))
        if not os.path.isfile(p) or sha256(p) != h:
            raise RefsoftError(f"{p}: missing or altered since {path} was written (SHA-256): regenerate its case "
                               f"with --add --case {rel.split('/')[0]}, or the set with --replace")
    return entries, files, []


def _remove_listed(out, files):
    """Remove the files a manifest lists (only those, inside ``out``) and case folders left empty."""
    root = os.path.realpath(out)
    for rel in files:
        p = os.path.realpath(os.path.join(out, *rel.split("/")))
        if os.path.commonpath([root, p]) == root and p != root and os.path.isfile(p):
            os.unlink(p)
            folder = os.path.dirname(p)
            while folder != root and os.path.commonpath([root, folder]) == root and not os.listdir(folder):
                os.rmdir(folder)  # an emptied inputs/ folder, then its emptied case folder
                folder = os.path.dirname(folder)


def read_manifest(golden) -> dict:
    """The manifest of a golden folder, checked to be one: its format, and the fields ``check``
    reads (each case's name, built-in scene, frames and options; every file's SHA-256).

    Raises
    ------
    RefsoftError
        No ``manifest.json`` in ``golden``.
    InputFileError
        The manifest cannot be read or lacks or mangles a field (the message names the field).
    """
    from ..io import read_json

    path = os.path.join(os.fspath(golden), "manifest.json")
    if not os.path.isfile(path):
        raise RefsoftError(f"{golden} is not a golden set: no manifest.json")
    m = read_json(path, format=GOLDEN_FORMAT, required=("cases", "files"))
    files = m["files"]
    if not isinstance(files, dict) or not all(isinstance(v, str) for v in files.values()):
        raise InputFileError(f"{path}: 'files' must map each file to its SHA-256")
    if not isinstance(m["cases"], list):
        raise InputFileError(f"{path}: 'cases' must be a list")
    for i, e in enumerate(m["cases"]):
        _check_entry(path, i, e)
    return m


_JSON_NAMES = {str: "string", list: "list", dict: "object"}


def _check_entry(path, i, e):
    from ..options import RenderOptions
    from ..scene.builtin import BUILTIN_SCENES

    where = f"{path}: cases[{i}]"
    if not isinstance(e, dict):
        raise InputFileError(f"{where} is not an object")
    for key, kind in (("name", str), ("scene", str), ("frames", list), ("options", dict)):
        if key not in e:
            raise InputFileError(f"{where} lacks {key!r}")
        if not isinstance(e[key], kind):
            raise InputFileError(f"{where}.{key} must be a JSON {_JSON_NAMES[kind]}")
    if not e["frames"] or not all(isinstance(f, int) and not isinstance(f, bool) and f >= 0 for f in e["frames"]):
        raise InputFileError(f"{where}.frames must be a non-empty list of frame indices")
    if e["scene"] not in CONFORMANCE_SCENES and e["scene"] not in BUILTIN_SCENES:
        raise InputFileError(f"{where}.scene: unknown scene {e['scene']!r}")
    try:
        RenderOptions(**{k: (tuple(v) if isinstance(v, list) else v) for k, v in e["options"].items()})
    except (RefsoftError, TypeError, ValueError) as exc:
        raise InputFileError(f"{where}.options: {exc}") from None
