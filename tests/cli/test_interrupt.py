"""Ctrl-C at any moment of a render, from Python's start-up to the middle of a frame: one line, exit
status 130, no traceback, every file written whole, and ``stats.json`` for the frames written.
(The first ~10 ms, before Python has run a line of refsoft, are Python's own.)"""

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _interrupted_render(out, after):
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.Popen([sys.executable, "-X", "faulthandler", "-m", "refsoft", "render", "planar", "--frames", "30", "--preset", "paper",
                             "--width", "96", "--height", "72", "--out", str(out)], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(after)
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=600)
    return proc.returncode, stdout, stderr


@pytest.mark.parametrize("after", [0.1, 0.3, 0.7, 1.0, 2.5])
def test_an_interrupt_at_any_moment_ends_cleanly(tmp_path, after):
    out = tmp_path / "o"
    code, stdout, stderr = _interrupted_render(out, after)
    assert "Traceback" not in stderr, stderr[-2000:]
    if code == 0:  # it finished first: nothing to check but the outputs
        assert len(list(out.glob("frame_*.npz"))) == 30
        return
    assert code == 130, (code, stderr[-2000:])
    assert stderr.strip().splitlines()[-1] == "refsoft: interrupted"
    frames = sorted(out.glob("frame_*.npz"))
    for f in frames:  # whole files only (written under a temporary name, then renamed)
        with np.load(f) as z:
            assert z["image"].shape == (72, 96, 3)
    assert not list(out.glob(".*.tmp*"))
    if frames:
        stats = json.loads((out / "stats.json").read_text())
        assert [fr["frame"] for fr in stats["frames"]] == list(range(len(frames)))


def test_an_interrupt_during_a_first_run_compile_leaves_within_the_grace_time(tmp_path):
    """Inside Numba's compiler the interrupt is only recorded; with no safe point in reach the
    program removes its temporary files and leaves after refsoft.interrupt.GRACE_SECONDS."""
    from refsoft.interrupt import GRACE_SECONDS

    out = tmp_path / "o"
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"),  # nothing compiled yet
               PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.Popen([sys.executable, "-m", "refsoft", "render", "planar", "--frames", "3", "--width", "96",
                             "--height", "72", "--out", str(out)], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    time.sleep(4.0)  # compiling by now
    t0 = time.perf_counter()
    proc.send_signal(signal.SIGINT)
    _, stderr = proc.communicate(timeout=600)
    assert proc.returncode == 130 and "Traceback" not in stderr, stderr[-2000:]
    assert stderr.strip().splitlines()[-1] == "refsoft: interrupted"
    assert time.perf_counter() - t0 < GRACE_SECONDS + 3.0
    assert not list(out.glob(".*")) and not list(out.glob("frame_*"))
