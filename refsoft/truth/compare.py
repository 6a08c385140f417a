"""A render's folder against its truth's (``refsoft compare``): the metrics of
:mod:`refsoft.truth.metrics` per frame, agreement maps and render | truth | difference pictures.

Before anything is written the two sides are checked to be what they are given as and to show
the same scene: the render side's frames hold ``reflection_pixel_K`` (the vertex search) or
``ldt_face`` / ``envmap_face`` (the per-pixel methods) and no ``reflected_hit``,
the truth side's hold ``reflected_hit``; both are the same size, the truth's reflectors are the
render's with as many vertices each (``vertex_object_K``), and where a folder has a ``run.json``
(format ``refsoft-run-1``) its kind, scene and size agree.
"""

from __future__ import annotations

import glob
import os

import numpy as np

from .. import keys
from ..errors import InputFileError, RefsoftError
from ..frame.outputs import RUN_FORMAT
_NUMERIC = "biuf"


def frame_files(folder) -> dict:
    """``{"NNNN": path}`` of the ``frame_NNNN.npz`` files in ``folder``."""
    if not os.path.isdir(folder):
        raise RefsoftError(f"{folder} is not a folder")
    files = sorted(glob.glob(os.path.join(folder, "frame_[0-9][0-9][0-9][0-9].npz")))
    return {os.path.basename(f)[6:10]: f for f in files}


def read_run(folder):
    """A folder's ``run.json`` (checked: format, kind, scene, size), or None when it has none."""
    from ..io import read_json

    path = os.path.join(os.fspath(folder), "run.json")
    if not os.path.exists(path):
        return None
    run = read_json(path, format=RUN_FORMAT, required=("kind", "scene", "width", "height"))
    if run["kind"] not in ("render", "truth"):
        raise InputFileError(f"{path}: kind must be 'render' or 'truth', got {run['kind']!r}")
    if not isinstance(run["scene"], str):
        raise InputFileError(f"{path}: scene must be a name")
    for k in ("width", "height"):
        if not isinstance(run[k], int) or isinstance(run[k], bool) or run[k] < 1:
            raise InputFileError(f"{path}: {k} must be a positive integer, got {run[k]!r}")
    return run


def _check_runs(render_dir, truth_dir, runs):
    """The kinds, scenes and sizes of the two ``run.json`` (where there are any)."""
    r, t = runs
    if r is not None and t is not None and r["kind"] == "truth" and t["kind"] == "render":
        raise RefsoftError(f"the folders are swapped: {render_dir}, given as the render, is a truth and {truth_dir}, "
                           "given as the truth, a render (run.json): give the render folder first")
    for run, folder, side in ((r, render_dir, "render"), (t, truth_dir, "truth")):
        if run is not None and run["kind"] != side:
            raise RefsoftError(f"{folder}, given as the {side}, is a {run['kind']} (run.json kind): compare takes a "
                               "render folder, then its truth")
    if r is None or t is None:
        return
    if r["scene"] != t["scene"]:
        raise RefsoftError(f"not the same scene: the render {render_dir} is {r['scene']!r}, the truth {truth_dir} "
                           f"{t['scene']!r} (run.json)")
    if (r["width"], r["height"]) != (t["width"], t["height"]):
        raise RefsoftError(f"the render {render_dir} is {r['width']}x{r['height']} pixels, the truth {truth_dir} "
                           f"{t['width']}x{t['height']} (run.json): render both at the same --width/--height")


def _array(arrays, path, key, *dims):
    """``arrays[key]``, checked to be numeric with the shape ``dims`` (None: any length)."""
    a = arrays.get(key)
    if a is None:
        raise InputFileError(f"{path}: lacks {key}")
    if a.dtype.kind not in _NUMERIC or a.ndim != len(dims) or any(d is not None and d != n
                                                                   for d, n in zip(dims, a.shape)):
        want = "[" + ", ".join("?" if d is None else str(d) for d in dims) + "]"
        raise InputFileError(f"{path}: {key} is {a.dtype}{list(a.shape)}, expected a numeric array of shape {want}")
    return a


def _image_size(arrays, path):
    """(height, width) of a frame, its image, object_id and reflected_id checked to agree."""
    h, w = _array(arrays, path, keys.REFLECTED_ID, None, None).shape
    _array(arrays, path, keys.OBJECT_ID, h, w)
    _array(arrays, path, keys.IMAGE, h, w, 3)
    return h, w


def _vertex_count(arrays, path, k, required, optional=None):
    """The vertex count of reflector ``k``: ``vertex_object_K`` and every array of ``required``
    (and of ``optional`` that is present) have that many rows; ``{name: trailing dims}``."""
    n = len(_array(arrays, path, keys.VERTEX_OBJECT(k), None))
    present = {m: c for m, c in (optional or {}).items() if m(k) in arrays}
    for name, cols in {**required, **present}.items():
        _array(arrays, path, name(k), n, *cols)
    return n


_RENDER_ROWS = {keys.REFLECTION_PIXEL: (2,), keys.VIRTUAL_VERTEX: (3,), keys.FLAGS: ()}
_RENDER_OPTIONAL = {keys.ITERATIONS: (), keys.SCORE: (), keys.MARGIN: ()}
_TRUTH_ROWS = {keys.EXACT_REFLECTION_POINT: (3,), keys.EXACT_VIRTUAL_VERTEX: (3,)}


#: The per-pixel arrays by which a frame of a per-pixel method (``ldt``, ``envmap``) is known.
PIXEL_METHOD_KEYS = ("ldt_face", "envmap_face")


def check_sides(render_path, ra, truth_path, ta):
    """Refuse a frame pair that is not a render and its truth of the same scene (the message
    names each side's file); also each file's own consistency."""
    r_truth, t_truth = keys.REFLECTED_HIT in ra, keys.REFLECTED_HIT in ta
    per_pixel = any(name in ra for name in PIXEL_METHOD_KEYS)
    r_render, t_render = bool(keys.reflectors(ra)) or per_pixel, bool(keys.reflectors(ta))
    if r_truth and t_render and not t_truth:
        raise RefsoftError(f"the folders are swapped: the render side {render_path} is a truth frame (reflected_hit) "
                           f"and the truth side {truth_path} a render frame (reflection_pixel_K): give the render "
                           "folder first")
    if r_truth or not r_render:
        raise RefsoftError(f"the render side {render_path} is not a render frame ("
                           + ("it is a truth: reflected_hit" if r_truth else "no reflection_pixel_K")
                           + "): give a folder written by refsoft render first")
    if not t_truth:
        raise RefsoftError(f"the truth side {truth_path} is not a truth frame (no reflected_hit"
                           + ("; it is a render: reflection_pixel_K" if t_render else "")
                           + "): give a folder written by refsoft truth second")
    (rh, rw), (th, tw) = _image_size(ra, render_path), _image_size(ta, truth_path)
    _array(ta, truth_path, keys.REFLECTED_HIT, th, tw, 3)
    if (rh, rw) != (th, tw):
        raise RefsoftError(f"the render side {render_path} is {rw}x{rh} pixels, the truth side {truth_path} {tw}x{th}: "
                           "render both at the same --width/--height")
    if per_pixel:  # no per-vertex outputs to match
        return
    rk = keys.reflectors(ra)
    tk = sorted(set(keys.reflectors(ta, keys.VERTEX_OBJECT)) | set(keys.reflectors(ta, keys.EXACT_REFLECTION_POINT)))
    if not set(tk) <= set(rk):
        raise RefsoftError(f"not the same scene: the render side {render_path} has reflectors {rk}, the truth side "
                           f"{truth_path} {tk} (keys reflection_pixel_K, vertex_object_K)")
    for k in rk:
        n = _vertex_count(ra, render_path, k, _RENDER_ROWS, _RENDER_OPTIONAL)
        _array(ra, render_path, keys.GBUFFER_MASK(k), None, None)
        _array(ra, render_path, keys.GBUFFER_VIEW_PROJ(k), 4, 4)
        if k not in tk:
            continue
        m = _vertex_count(ta, truth_path, k, _TRUTH_ROWS)
        if m != n:
            raise RefsoftError(f"not the same scene: reflector {k} has {n} vertices on the render side {render_path} "
                               f"and {m} on the truth side {truth_path} (vertex_object_{k})")


def compare_runs(render_dir, truth_dir, out, on_frame=None) -> dict:
    """Compare every frame the two folders share; write ``metrics.json``, ``agreement_NNNN.png``
    (green agree, red differ) and ``side_NNNN.png`` (render | truth | 4x difference) into
    ``out``.

    Parameters
    ----------
    render_dir, truth_dir : str or PathLike
        Folders written by ``refsoft render`` and ``refsoft truth``.
    out : str or PathLike
        The report folder, outside both.
    on_frame : callable, optional
        Called with each frame's metrics (dict) as it is done (the CLI prints a row).

    Returns
    -------
    dict
        ``{"render", "truth", "frames": [metrics per frame], "summary"}`` (``metrics.json``); the
        summary adds up the frames' specks and holes (:func:`refsoft.truth.metrics.defect_counts`),
        their fractions of all the frames' mirror pixels.

    Raises
    ------
    RefsoftError
        No common frame; ``out`` inside either folder; the sides swapped, not a render and a
        truth, or not of the same scene and size (checked on the first common frame before
        anything is written, then on each frame as it is read).
    InputFileError
        A frame's ``.npz`` or a ``run.json`` is unreadable or malformed.
    """
    from ..io import inside, read_npz, write_json, write_png
    from ..visualize import agreement_map, difference_image, side_by_side
    from .metrics import frame_metrics

    render_dir, truth_dir, out = os.fspath(render_dir), os.fspath(truth_dir), os.fspath(out)
    render_files, truth_files = frame_files(render_dir), frame_files(truth_dir)
    for folder, side in ((render_dir, "render"), (truth_dir, "truth")):
        if inside(out, folder):
            raise RefsoftError(f"report folder {out} is inside the {side} folder {folder}: give --out a folder outside "
                               "both (default out/compare)")
    runs = read_run(render_dir), read_run(truth_dir)
    _check_runs(render_dir, truth_dir, runs)
    common = sorted(set(render_files) & set(truth_files))
    if not common:
        raise RefsoftError(f"no frame_NNNN.npz common to {render_dir} ({len(render_files)} frames) and "
                           f"{truth_dir} ({len(truth_files)} frames)")
    report = {"render": os.path.abspath(render_dir), "truth": os.path.abspath(truth_dir), "frames": []}
    for key in common:
        ra, ta = read_npz(render_files[key]), read_npz(truth_files[key])
        check_sides(render_files[key], ra, truth_files[key], ta)
        for run, folder, path in zip(runs, (render_dir, truth_dir), (render_files[key], truth_files[key])):
            h, w = ra[keys.REFLECTED_ID].shape
            if run is not None and (run["width"], run["height"]) != (w, h):
                raise InputFileError(f"{os.path.join(folder, 'run.json')}: says {run['width']}x{run['height']} pixels "
                                     f"but {path} is {w}x{h}")
        os.makedirs(out, exist_ok=True)
        m = frame_metrics(ra, ta)
        m["frame"] = int(key)
        report["frames"].append(m)
        if on_frame is not None:
            on_frame(m)
        write_png(os.path.join(out, f"agreement_{key}.png"),
                  agreement_map(ra[keys.REFLECTED_ID], ta[keys.REFLECTED_ID], ta[keys.IMAGE]))
        write_png(os.path.join(out, f"side_{key}.png"),
                  side_by_side(ra[keys.IMAGE], ta[keys.IMAGE], difference_image(ra[keys.IMAGE], ta[keys.IMAGE])))
    frames = report["frames"]
    px = np.array([f["reflector_pixels"] for f in frames], dtype=np.float64)
    dis = np.array([f["reflected_id_disagreement"] for f in frames])
    n_specks = sum(f["specks"] for f in frames)
    n_holes = sum(f["holes"] for f in frames)
    report["summary"] = {"frames": len(frames),
                         "reflected_id_disagreement": float((dis * px).sum() / px.sum()) if px.sum() else 0.0,
                         "specks": n_specks, "speck_fraction": float(n_specks / px.sum()) if px.sum() else 0.0,
                         "holes": n_holes, "hole_fraction": float(n_holes / px.sum()) if px.sum() else 0.0,
                         "only_in_render": sorted(set(render_files) - set(truth_files)),
                         "only_in_truth": sorted(set(truth_files) - set(render_files))}
    write_json(os.path.join(out, "metrics.json"), report)
    return report
