"""``refsoft bench table1``: the papers' table 1 for the ``kitchen``, ``ufo`` and ``ants``
animations (maximum over frames of the per-frame mean search iterations, and their mean over
the animation), beside the paper's numbers and its frame times (Estalella et al. 2006, table 1:
a 2006 GPU), with this machine's frame times.
"""

from __future__ import annotations

import os

import numpy as np

from ._common import machine, markdown_table, progress, write_csv, write_text

#: Estalella et al. 2006, table 1: (max frame mean iterations, total mean, ms per frame).
PAPER_TABLE1 = {"kitchen": (14.9, 4.7, 11.5), "ufo": (71.2, 4.2, 83.0), "ants": (7.5, 3.3, 83.0)}
COLUMNS = ["scene", "frames", "max_frame_mean", "paper_max_frame_mean", "total_mean", "paper_total_mean",
           "ms_per_frame", "paper_ms_per_frame"]


def table1(scenes=("kitchen", "ufo", "ants"), out=None, width=1024, height=768, frames=None, progress_bar=False) -> list:
    """Render each animation coherently with the paper preset (``frames``: the first N, default
    all) and tabulate."""
    from ..frame import FrameDriver, frame_stats
    from ..options import RenderOptions
    from ..scene.builtin import load_scene

    paper = RenderOptions(preset="paper")
    rows = []
    for name in scenes:
        scene = load_scene(name, width=width, height=height)
        n = scene.n_frames if frames is None else min(frames, scene.n_frames)
        FrameDriver(scene, paper).render_frame(0)  # compile outside the timing
        driver = FrameDriver(scene, paper)
        done = []
        for f in progress(list(range(n)), f"table 1 {name}", progress_bar):
            fr = driver.render_frame(f)
            fr.arrays = {}
            done.append(fr)
        s = frame_stats(done)["summary"]
        ref = PAPER_TABLE1.get(name, (None, None, None))
        rows.append({"scene": name, "frames": n, "max_frame_mean": round(s["max_frame_mean_iterations"], 2),
                     "paper_max_frame_mean": ref[0], "total_mean": round(s["total_mean_iterations"], 2),
                     "paper_total_mean": ref[1],
                     "ms_per_frame": round(float(np.median([f.time_ms["total"] for f in done[1:] or done])), 1),
                     "paper_ms_per_frame": ref[2]})
    if out is not None:
        os.makedirs(out, exist_ok=True)
        write_csv(os.path.join(out, "table1.csv"), rows, COLUMNS)
        m = machine()
        write_text(os.path.join(out, "table1.md"),
                   f"# Table 1: search iterations per animation\n\n{width}x{height}, coherent, default options; "
                   f"ms per frame: median of the coherent frames on {m['cpu']} ({m['cores']} cores); the paper's on "
                   "a 2006 GPU.\n\n" + markdown_table(rows, COLUMNS, [
                       "scene", "frames", "max frame mean", "paper", "total mean", "paper", "ms/frame", "paper ms"]))
    return rows
