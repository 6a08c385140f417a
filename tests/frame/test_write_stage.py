"""The background writer's time is a stage of its own in ``stats.json``: wall and thread CPU
milliseconds of writing each frame's files, beside the render's stages (which it does not enter)."""

import json

import numpy as np

import refsoft


def test_stats_record_each_frames_write(tmp_path):
    frames, stats = refsoft.render("sphere", frames=2, width=64, height=48, out=tmp_path)
    on_disk = json.loads((tmp_path / "stats.json").read_text())
    for st in (stats, on_disk):
        for f in st["frames"]:
            t = f["time_ms"]
            assert t["write"] > 0 and 0 <= t["write_cpu"] <= t["write"] + 1.0  # one thread: CPU within wall
            # the render's total is its stages', not the write's
            assert t["total"] >= max(v for k, v in t.items() if k not in ("total", "write", "write_cpu"))
        s = st["summary"]
        # the per-frame figures are rounded to the microsecond in stats
        assert abs(s["median_write_ms"] - np.median([f["time_ms"]["write"] for f in st["frames"]])) < 1e-3
    assert on_disk["summary"]["median_write_cpu_ms"] > 0


def test_no_write_stage_without_files():
    frames, stats = refsoft.render("sphere", frames=1, width=32, height=24)
    assert "write" not in frames[0].time_ms and "median_write_ms" not in stats["summary"]
