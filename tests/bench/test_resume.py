"""A sweep killed midway (a subprocess, SIGKILL) leaves only whole results; run again, it
computes only the missing tasks and writes the CSV of an uninterrupted run."""

import os
import re
import signal
import subprocess
import sys
import time

from refsoft import cli

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
ARGS = ["bench", "sweep", "--scheduler", "serial", "--no-timing", "--scenes", "sphere", "planar", "--width", "48",
        "--height", "36", "--frames", "2", "--knob", "inverse"]
N_TASKS = 6
#: `python -m refsoft`, its third task held for a minute before it starts (the test kills the
#: process meanwhile: after exactly two stored results, however loaded the machine).
HOLD_THIRD_TASK = """
import importlib, sys, time
m = importlib.import_module("refsoft.bench.sweep")  # the package's `sweep` is the function
calls, task = [], m.sweep_task
def held(*args, **kwargs):
    calls.append(1)
    if len(calls) == 3:
        time.sleep(60)
    return task(*args, **kwargs)
m.sweep_task = held
from refsoft import cli
sys.exit(cli.main(sys.argv[1:]))
"""


def _stored(folder):
    if not os.path.isdir(folder):
        return {}
    return {n: os.stat(os.path.join(folder, n)).st_mtime_ns for n in os.listdir(folder) if n.endswith(".npz")}


def test_killed_sweep_resumes_to_the_same_csv(tmp_path, capsys):
    ref = tmp_path / "ref"
    assert cli.main(ARGS + ["--out", str(ref)]) == 0
    capsys.readouterr()

    out = tmp_path / "run"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in (ROOT, os.environ.get("PYTHONPATH")) if p))
    proc = subprocess.Popen([sys.executable, "-c", HOLD_THIRD_TASK] + ARGS + ["--out", str(out)], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    while len(_stored(out / "tasks")) < 2 and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.01)
    time.sleep(0.2)  # into the held third task
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    before = _stored(out / "tasks")
    assert len(before) == 2, "the run was not killed midway"
    assert not (out / "sweep.csv").exists()

    assert cli.main(ARGS + ["--out", str(out)]) == 0
    said = capsys.readouterr().out
    k = len(before)
    assert re.search(rf"\({N_TASKS} tasks: {k} reused, {N_TASKS - k} computed in this process\)", said), said
    after = _stored(out / "tasks")
    assert len(after) == N_TASKS and all(after[n] == t for n, t in before.items())  # kept, not rewritten
    assert not [n for n in os.listdir(out / "tasks") if not n.endswith(".npz")]  # no temporaries left
    assert (out / "sweep.csv").read_bytes() == (ref / "sweep.csv").read_bytes()
    assert said.rstrip().splitlines()[-1] == f"report: {(out / 'report.html').resolve().as_uri()}"
