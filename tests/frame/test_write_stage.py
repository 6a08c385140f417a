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


def test_stats_file_is_the_stats_as_json(tmp_path):
    """The stats.json rewritten after each frame (each frame's entry encoded once) is, at every
    length of the run and with or without options, what json.dump writes of frame_stats; a list
    whose earlier frames are other objects is encoded again."""
    from refsoft.frame import Frame, RenderOptions
    from refsoft.frame.outputs import StatsFile, frame_stats
    from refsoft.io import write_json

    def frame(i):
        return Frame(i, {}, {"total": 10.0 + i / 3, "search": 1.0 / (i + 1), "write": 2.5, "write_cpu": 2.0 + i},
                     {"iterations": {"1": {"mean": 3.0 + i, "max": 7}}, "skips": ["a", i]})

    frames = [frame(i) for i in range(5)]
    for options in (None, RenderOptions(preset="paper")):
        stats = StatsFile(options)
        for n in range(len(frames) + 1):
            stats.write(tmp_path / "a.json", frames[:n])
            write_json(tmp_path / "b.json", frame_stats(frames[:n], options))
            assert (tmp_path / "a.json").read_text() == (tmp_path / "b.json").read_text(), (options, n)
        other = [frames[0], frame(1)]
        assert stats.text(other) == json.dumps(frame_stats(other, options), indent=1) + "\n"
