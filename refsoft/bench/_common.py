"""Shared helpers of the benchmark commands: CSV and markdown writers, median timing, and what
the tasks share in a process (scenes, truths)."""

from __future__ import annotations

import csv
import io
import os
import threading
import time

import numpy as np


def write_csv(path, rows, columns):
    from ..io import atomic_path

    with atomic_path(path) as tmp:
        with open(tmp, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=columns, extrasaction="ignore")
            w.writeheader()
            for r in rows:
                w.writerow({k: _fmt(r.get(k)) for k in columns})


def _fmt(v):
    if isinstance(v, float):
        return f"{v:.6g}"
    return v


def _cell(v) -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def markdown_table(rows, columns, headers=None) -> str:
    headers = headers or columns
    out = io.StringIO()
    out.write("| " + " | ".join(headers) + " |\n")
    out.write("|" + "|".join("---" if i == 0 else "---:" for i in range(len(columns))) + "|\n")
    for r in rows:
        out.write("| " + " | ".join(_cell(r.get(c, "")) for c in columns) + " |\n")
    return out.getvalue()


def write_text(path, text):
    from ..io import atomic_path

    with atomic_path(path) as tmp:
        with open(tmp, "w") as fh:
            fh.write(text)


def median_time(fn, repeats: int) -> tuple[float, object]:
    """Median wall time (ms) of ``repeats`` calls of ``fn()`` and the last result."""
    times, result = [], None
    for _ in range(max(int(repeats), 1)):
        t = time.perf_counter()
        result = fn()
        times.append(1000 * (time.perf_counter() - t))
    return float(np.median(times)), result


def machine() -> dict:
    import platform

    import numba

    from .._parallel import thread_count

    return {"cpu": platform.processor() or platform.machine(), "cores": os.cpu_count(),
            "python": platform.python_version(), "numpy": np.__version__, "numba": numba.__version__,
            "threads": thread_count()}


def numba_threads() -> int:
    """The thread count of this thread's parallel loops (what a timed task ran with)."""
    from .._parallel import thread_count

    return int(thread_count())


def run_bench(tasks, out, desc, progress, scheduler, workers, fresh, connect_timeout):
    """:func:`refsoft.bench.tasks.run_tasks` with the results stored in ``out/tasks``."""
    from .tasks import CONNECT_TIMEOUT, run_tasks

    store = None if out is None else os.path.join(os.fspath(out), "tasks")
    return run_tasks(tasks, scheduler=scheduler, workers=workers, store=store, progress=progress, desc=desc,
                     fresh=fresh, connect_timeout=CONNECT_TIMEOUT if connect_timeout is None else connect_timeout)


def plt_or_none():
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return None
    return plt


def scene_digest(scene) -> str:
    """SHA-256 of what a loaded scene draws: camera, animation and every object's fields and
    mesh arrays (a task's key holds it, so an edited scene file is not served old results)."""
    import dataclasses
    import hashlib

    from ..scene.mesh import Mesh

    h = hashlib.sha256()
    h.update(repr((scene.name, scene.camera, scene.animation)).encode())
    for obj in scene.objects:
        for f in dataclasses.fields(obj):
            v = getattr(obj, f.name)
            if isinstance(v, Mesh):
                for a in (v.vertices, v.faces, v.normals):
                    h.update(b"-" if a is None else np.ascontiguousarray(a).tobytes())
            else:
                h.update(f"{f.name}={v!r};".encode())
    return h.hexdigest()


def plan_scene(name, width=None, height=None):
    """``(scene, spec)`` for a bench task: the scene loaded here (its name checked before any
    work) and what a task gets to load it again where it runs: the built-in's name, or the
    Scene itself for a scene file (a remote worker does not have the file)."""
    from ..scene import builtin_names, load_scene

    size = {k: v for k, v in (("width", width), ("height", height)) if v is not None}
    scene = load_scene(name, **size)
    return scene, (name if name in builtin_names() else scene)


_SCENES, _TRUTHS = {}, {}
#: A Dask worker of several threads runs tasks at once (--no-timing): one fills the caches at a time.
_CACHE_LOCK = threading.Lock()


def task_scene(spec, width=None, height=None):
    """The scene a task was planned with (:func:`plan_scene`), built-ins loaded once per process."""
    from dataclasses import replace

    from ..scene import load_scene

    if not isinstance(spec, str):
        return spec
    with _CACHE_LOCK:
        if spec not in _SCENES:
            _SCENES.clear()  # one built-in at a time: tasks come grouped by scene
            _SCENES[spec] = load_scene(spec)
        scene = _SCENES[spec]
    size = {k: v for k, v in (("width", width), ("height", height)) if v is not None}
    return replace(scene, camera=replace(scene.camera, **size)) if size else scene


def task_truths(scene, frames, digest) -> list:
    """The exact ray-traced truth of ``frames`` (a list of TruthFrame), computed once per process
    for the last two scenes asked (every setting of a scene shares it)."""
    from ..truth import TruthRenderer

    key = (digest, tuple(frames))
    with _CACHE_LOCK:
        if key not in _TRUTHS:
            while len(_TRUTHS) >= 2:
                _TRUTHS.pop(next(iter(_TRUTHS)))
            tr = TruthRenderer(scene, exact=True)
            _TRUTHS[key] = [tr.render_frame(f) for f in frames]
        return _TRUTHS[key]
