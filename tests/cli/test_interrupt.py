"""Ctrl-C at any moment of a render, from the start of refsoft's code to the middle of a frame:
one line, exit status 130, no traceback, every file written whole, and ``stats.json`` for the
frames written. (Before refsoft's package is imported, Python is still starting: that time is
Python's own, tens of milliseconds on a quiet machine, several hundred on a busy one, so the
delays count from the package's import.)"""

import json
import os
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _interrupted_render(out, after):
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    # -X importtime reports each import as it ends: once ``refsoft`` itself is reported, its
    # package has run and its interrupt handler is in place
    proc = subprocess.Popen([sys.executable, "-X", "faulthandler", "-X", "importtime", "-m", "refsoft", "render",
                             "planar", "--frames", "30", "--preset", "paper", "--width", "96", "--height", "72",
                             "--out", str(out)], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    lines, imported = [], threading.Event()

    def drain():  # read stderr as it comes (a full pipe would stall the process)
        for line in proc.stderr:
            lines.append(line)
            if line.rstrip().endswith("| refsoft"):
                imported.set()
        imported.set()

    reader = threading.Thread(target=drain, daemon=True)
    reader.start()
    assert imported.wait(600)
    time.sleep(after)
    proc.send_signal(signal.SIGINT)
    stdout = proc.stdout.read()
    proc.wait(timeout=600)
    reader.join(600)
    stderr = "".join(line for line in lines if not line.startswith("import time:"))
    return proc.returncode, stdout, stderr


@pytest.mark.parametrize("after", [0.0, 0.1, 0.3, 0.7, 1.0, 2.5])
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
