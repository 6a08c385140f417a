"""The sweep's method knob: the vertex search's two methods, the layered depth textures, the
environment map and the ray-traced truth itself, on the same scene and frames."""

import numpy as np

from refsoft.bench import sweep
from refsoft.bench.sweep import pareto_front


def test_methods_and_the_truth_are_settings_of_one_sweep(tmp_path):
    rows = sweep(out=tmp_path / "s", scenes=["balls"], width=48, height=36, frames=1, repeats=1, knobs=["method"],
                 scheduler="serial", timing=True)
    by = {r["setting"]: r for r in rows}
    assert set(by) == {"paper", "paper, method=hierarchy", "method=ldt", "method=envmap", "method=truth"}
    assert by["method=truth"]["disagreement"] == 0.0 and by["method=truth"]["color_error_mean"] == 0.0
    # the LDT sees what the truth sees on this scene; the environment map's parallax does not
    assert by["method=ldt"]["disagreement"] < 0.02 < by["method=envmap"]["disagreement"]
    assert all(r["time_ms"] > 0 for r in rows)
    front = pareto_front([r["time_ms"] for r in rows], [r["disagreement"] for r in rows])
    assert [r["pareto"] for r in rows] == list(front)
    # nothing is closer than the truth itself: only a setting as exact and faster can hide it
    exact = [r for r in rows if r["disagreement"] == 0.0]
    assert by["method=truth"]["pareto"] or min(r["time_ms"] for r in exact) < by["method=truth"]["time_ms"]
    assert (tmp_path / "s" / "sweep.csv").exists()
