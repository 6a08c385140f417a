"""`refsoft bench` on Dask: a local cluster of 2 workers gives the serial run's error figures,
an unreachable scheduler is refused before any work, and a stored result is reused only for
the same inputs and refsoft."""

import os
import socket
import time

import refsoft
from refsoft import cli
from refsoft.bench import sweep

TINY = dict(scenes=["sphere", "planar"], width=40, height=30, frames=2, repeats=1, knobs=["inverse"], timing=False)


def test_two_local_workers_give_the_serial_error_figures(tmp_path):
    info_s, info_l = {}, {}
    serial = sweep(out=tmp_path / "s", scheduler="serial", run_info=info_s, **TINY)
    local = sweep(out=tmp_path / "l", scheduler="local", workers=2, run_info=info_l, **TINY)
    run = info_l["run"]
    assert (run.scheduler, run.workers, run.computed, run.reused) == ("local", 2, 6, 0)
    assert len({m["host"] for m in run.meta}) == 1 and all(m["reused"] is False for m in run.meta)
    assert local == serial  # every error figure, exactly (no times: --no-timing)
    assert len(serial) == 6 and all(r["disagreement"] is not None for r in serial)
    assert (tmp_path / "l" / "sweep.csv").read_bytes() == (tmp_path / "s" / "sweep.csv").read_bytes()
    page = (tmp_path / "l" / "report.html").read_text()
    assert "2 workers" in page and "<table>" in page and "http" not in page.replace("http-equiv", "")


def _closed_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_unreachable_scheduler_one_line_exit_2_before_any_work(tmp_path, capsys, monkeypatch):
    import importlib

    sweep_mod = importlib.import_module("refsoft.bench.sweep")

    def no_work(*a, **k):
        raise AssertionError("a task ran")

    monkeypatch.setattr(sweep_mod, "sweep_task", no_work)
    out = tmp_path / "o"
    t0 = time.perf_counter()
    code = cli.main(["bench", "sweep", "--scenes", "sphere", "--width", "40", "--height", "30", "--frames", "1",
                     "--knob", "inverse", "--scheduler", f"tcp://127.0.0.1:{_closed_port()}", "--connect-timeout", "1",
                     "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and time.perf_counter() - t0 < 15
    assert err.count("\n") == 1 and err.startswith("refsoft: error: cannot reach the Dask scheduler at tcp://127.0.0.1:")
    written = [os.path.join(d, n) for d, _, names in os.walk(out) for n in names]
    assert written == []  # nothing computed, nothing written
    assert cli.main(["bench", "sweep", "--scheduler", "tcp://nohost", "--out", str(out)]) == 2
    assert "tcp://HOST:PORT" in capsys.readouterr().err


def test_stored_sweep_reused_only_for_the_same_inputs_and_version(tmp_path, monkeypatch):
    one = dict(TINY, scenes=["planar"])
    info = {}
    out = tmp_path / "o"
    first = sweep(out=out, scheduler="serial", run_info=info, **one)
    assert (info["run"].reused, info["run"].computed) == (0, 3)
    sweep(out=out, scheduler="serial", run_info=info, **one)
    assert (info["run"].reused, info["run"].computed) == (3, 0)
    sweep(out=out, scheduler="serial", run_info=info, **dict(one, knobs=["inverse", "gbuffer_scale"]))
    assert (info["run"].reused, info["run"].computed) == (3, 2)  # the two new settings only
    bigger = sweep(out=out, scheduler="serial", run_info=info, **dict(one, width=48, height=36))
    assert (info["run"].reused, info["run"].computed) == (0, 3) and bigger != first
    sweep(out=out, scheduler="serial", run_info=info, **dict(one, frames=1))
    assert (info["run"].reused, info["run"].computed) == (0, 3)
    sweep(out=out, scheduler="serial", run_info=info, **dict(one, timing=True))
    assert (info["run"].reused, info["run"].computed) == (0, 3)
    monkeypatch.setattr(refsoft, "__version__", refsoft.__version__ + ".other")
    again = sweep(out=out, scheduler="serial", run_info=info, **one)
    assert (info["run"].reused, info["run"].computed) == (0, 3) and again == first
