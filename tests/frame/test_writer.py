"""run_frames writes each frame in a background thread while the next one renders: the files
are those of a write in the main thread, a frame counts as done only once written, and an error
or an interrupt still leaves the frame being written whole."""

import threading

import numpy as np
import pytest

from refsoft import keys
from refsoft.frame import Frame, driver, run_frames, write_frame


class Renderer:
    """Frames of random arrays; frame ``fail_at`` raises."""

    def __init__(self, fail_at=None):
        self.fail_at = fail_at

    def render_frame(self, f):
        if f == self.fail_at:
            raise RuntimeError(f"frame {f} failed")
        rng = np.random.default_rng(f)
        arrays = {keys.IMAGE: rng.integers(0, 256, (24, 32, 3), dtype=np.uint8),
                  keys.OBJECT_ID: rng.integers(0, 5, (24, 32), dtype=np.int32)}
        return Frame(f, arrays, {"total": 1.0})


def test_background_writes_equal_main_thread_writes(tmp_path):
    frames = run_frames(Renderer(), range(4), tmp_path / "bg")
    assert [f.index for f in frames] == [0, 1, 2, 3]
    for fr in frames:
        write_frame(tmp_path / "main", fr)
        name = f"frame_{fr.index:04d}"
        assert (tmp_path / "bg" / f"{name}.png").read_bytes() == (tmp_path / "main" / f"{name}.png").read_bytes()
        with np.load(tmp_path / "bg" / f"{name}.npz") as a, np.load(tmp_path / "main" / f"{name}.npz") as b:
            assert list(a.keys()) == list(b.keys())
            for k in a.keys():
                np.testing.assert_array_equal(a[k], b[k])


def test_writes_run_beside_the_next_render(tmp_path, monkeypatch):
    seen = []
    real = driver.write_frame

    def write(out, fr):
        seen.append(threading.current_thread() is threading.main_thread())
        real(out, fr)

    monkeypatch.setattr(driver, "write_frame", write)
    done = run_frames(Renderer(), range(3), tmp_path, keep=False)
    assert seen == [False, False, False]
    assert all(fr.arrays == {} for fr in done)  # keep=False: dropped once written


def test_an_error_keeps_the_frame_being_written(tmp_path):
    done = []
    with pytest.raises(RuntimeError, match="frame 2 failed"):
        run_frames(Renderer(fail_at=2), range(4), tmp_path, done=done)
    assert [f.index for f in done] == [0, 1]
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "frame_0000.npz", "frame_0000.png", "frame_0001.npz", "frame_0001.png"]


def test_a_failed_write_is_raised_and_its_frame_not_done(tmp_path, monkeypatch):
    real = driver.write_frame

    def write(out, fr):
        if fr.index == 1:
            raise OSError("disk full")
        real(out, fr)

    monkeypatch.setattr(driver, "write_frame", write)
    done, calls = [], []
    with pytest.raises(OSError, match="disk full"):
        run_frames(Renderer(), range(4), tmp_path, done=done, on_frame=lambda d: calls.append(len(d)))
    assert [f.index for f in done] == [0]
    assert calls == [1]
    assert not (tmp_path / "frame_0001.npz").exists()


def test_frame_files_hold_the_arrays_of_level_6(tmp_path):
    """The frame's npz (zlib level 1) holds the arrays np.savez_compressed (level 6, what the golden
    set writes) holds, bit for bit, in the same order, and its PNG decodes to the same pixels."""
    from PIL import Image

    import refsoft
    from refsoft.frame import outputs
    from refsoft.io import write_npz, write_png

    (fr,), _ = refsoft.render("kitchen", frames=[3], width=64, height=48)
    assert outputs.FRAME_LEVEL == 1
    write_frame(tmp_path, fr)
    write_npz(tmp_path / "six.npz", **fr.arrays)
    write_png(tmp_path / "six.png", fr.arrays[keys.IMAGE])
    with np.load(tmp_path / "frame_0003.npz") as a, np.load(tmp_path / "six.npz") as b:
        assert list(a.keys()) == list(b.keys()) == list(fr.arrays)
        for k in a.keys():
            x, y = a[k], b[k]
            assert x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes(), k
    assert (tmp_path / "frame_0003.npz").stat().st_size != (tmp_path / "six.npz").stat().st_size  # another level
    with Image.open(tmp_path / "frame_0003.png") as p, Image.open(tmp_path / "six.png") as q:
        assert np.array_equal(np.asarray(p), np.asarray(q)) and np.array_equal(np.asarray(p), fr.arrays[keys.IMAGE])


def test_npz_level_refuses_object_arrays(tmp_path):
    from refsoft.io import write_npz_level

    with pytest.raises(ValueError):
        write_npz_level(tmp_path / "o.npz", {"o": np.array([{}, None], dtype=object)}, 1)
    assert list(tmp_path.iterdir()) == []  # atomic: nothing left behind
