"""A render's folder against its truth's (``refsoft compare``): the metrics of
:mod:`refsoft.truth.metrics` per frame, agreement maps and render | truth | difference pictures."""

from __future__ import annotations

import glob
import os

import numpy as np

from .. import keys
from ..errors import RefsoftError


def frame_files(folder) -> dict:
    """``{"NNNN": path}`` of the ``frame_NNNN.npz`` files in ``folder``."""
    if not os.path.isdir(folder):
        raise RefsoftError(f"{folder} is not a folder")
    files = sorted(glob.glob(os.path.join(folder, "frame_[0-9][0-9][0-9][0-9].npz")))
    return {os.path.basename(f)[6:10]: f for f in files}


def compare_runs(render_dir, truth_dir, out, on_frame=None) -> dict:
    """Compare every frame the two folders share; write ``metrics.json``, ``agreement_NNNN.png``
    (green agree, red differ) and ``side_NNNN.png`` (render | truth | 4x difference) into
    ``out``.

    Parameters
    ----------
    render_dir, truth_dir : str or PathLike
        Folders written by ``refsoft render`` and ``refsoft truth``.
    out : str or PathLike
    on_frame : callable, optional
        Called with each frame's metrics (dict) as it is done (the CLI prints a row).

    Returns
    -------
    dict
        ``{"render", "truth", "frames": [metrics per frame], "summary"}`` (``metrics.json``).
    """
    from ..io import write_json, write_png
    from ..visualize import agreement_map, difference_image, side_by_side
    from .metrics import frame_metrics

    render_files, truth_files = frame_files(render_dir), frame_files(truth_dir)
    common = sorted(set(render_files) & set(truth_files))
    if not common:
        raise RefsoftError(f"no frame_NNNN.npz common to {render_dir} ({len(render_files)} frames) and "
                           f"{truth_dir} ({len(truth_files)} frames)")
    os.makedirs(out, exist_ok=True)
    report = {"render": os.path.abspath(render_dir), "truth": os.path.abspath(truth_dir), "frames": []}
    for key in common:
        with np.load(render_files[key]) as r, np.load(truth_files[key]) as t:
            ra, ta = dict(r), dict(t)
        if ra[keys.REFLECTED_ID].shape != ta[keys.REFLECTED_ID].shape:
            raise RefsoftError(f"frame {key}: render is {ra[keys.REFLECTED_ID].shape[::-1]} pixels, truth "
                               f"{ta[keys.REFLECTED_ID].shape[::-1]} (render both at the same --width/--height)")
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
    report["summary"] = {"frames": len(frames),
                         "reflected_id_disagreement": float((dis * px).sum() / px.sum()) if px.sum() else 0.0,
                         "only_in_render": sorted(set(render_files) - set(truth_files)),
                         "only_in_truth": sorted(set(truth_files) - set(render_files))}
    write_json(os.path.join(out, "metrics.json"), report)
    return report
