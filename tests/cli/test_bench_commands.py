"""`refsoft bench sweep | scaling | table1` at tiny sizes (a CI smoke run): the
files are written with the expected rows and columns; no time is asserted."""

import csv

import numpy as np
import pytest

from refsoft import cli
from refsoft.bench import KNOBS, PAPER_TABLE1
from refsoft.bench.scaling import fit_slope
from refsoft.bench.sweep import pareto_front, settings


def _csv(path):
    with open(path) as fh:
        return list(csv.DictReader(fh))


def test_pareto_front_hand_case():
    t = [1.0, 2.0, 3.0, 2.0, 1.0]
    e = [0.5, 0.2, 0.1, 0.3, 0.5]
    np.testing.assert_array_equal(pareto_front(t, e), [True, True, True, False, True])  # equal points: both kept


def test_fit_slope_recovers_exponents():
    n = np.array([1e3, 1e4, 1e5, 1e6])
    assert fit_slope(n, 3e-6 * n) == pytest.approx(1.0)
    assert fit_slope(n, 2e-9 * n ** 1.5) == pytest.approx(1.5)


def test_settings_are_one_factor_at_a_time():
    s = settings()
    assert s[0][0] == "paper" and len(s) == 1 + sum(len(v) - 1 for v in KNOBS.values())
    assert all(len(opts) == 1 for _, _, _, opts in s[1:])


def test_sweep_smoke(tmp_path, capsys):
    out = tmp_path / "sweep"
    assert cli.main(["bench", "sweep", "--scheduler", "serial", "--scenes", "sphere", "planar", "--width", "48", "--height", "36", "--frames", "2",
                     "--repeats", "1", "--knob", "inverse", "--knob", "gbuffer_scale", "--out", str(out)]) == 0
    rows = _csv(out / "sweep.csv")
    assert [r["setting"] for r in rows[:5]] == ["paper", "paper, gbuffer_scale=0.5", "paper, gbuffer_scale=2.0",
                                                "paper, inverse=search", "paper, inverse=discard"]
    assert len(rows) == 10 and {r["scene"] for r in rows} == {"sphere", "planar"}
    for r in rows:
        assert float(r["time_ms"]) > 0 and 0 <= float(r["disagreement"]) <= 1
        assert r["pareto"] in ("True", "False")
    sphere = [r for r in rows if r["scene"] == "sphere"]
    assert all(r["virtual_distance_mean"] for r in sphere)  # exact points on the ball
    assert any(r["pareto"] == "True" for r in sphere)
    assert "## sphere" in (out / "sweep.md").read_text() and (out / "pareto.png").stat().st_size > 1000
    # the report says what made it, and agreement in % as the accuracy report does
    import refsoft

    page = (out / "report.html").read_text()
    assert f"<b>refsoft</b>: {refsoft.__version__}" in page and "<b>date</b>: 20" in page and "cores" in page
    assert "<code>refsoft bench sweep --scheduler serial --scenes sphere planar --width 48" in page
    assert "agreement %" in page and "disagreement</th>" not in page
    sph = [r for r in rows if r["scene"] == "sphere" and r["setting"] == "paper"][0]
    assert f"{100 * (1 - float(sph['disagreement'])):.3g}"[:3] in page
    assert cli.main(["bench", "sweep", "--scheduler", "serial", "--knob", "colour", "--out", str(out)]) == 2


def test_scaling_smoke(tmp_path):
    out = tmp_path / "scaling"
    assert cli.main(["bench", "scaling", "--scheduler", "serial", "--width", "64", "--height", "48", "--max-vertices", "4096",
                     "--max-subdivisions", "2", "--max-width", "256", "--repeats", "1", "--out", str(out)]) == 0
    rows = _csv(out / "scaling.csv")
    series = [r["series"] for r in rows]
    assert series.count("search_cold") == 2 and series.count("raster_triangles") == 2
    assert series.count("raster_resolution") == 2
    assert "slope" in (out / "scaling.md").read_text() and (out / "scaling.png").exists()


def test_table1_smoke(tmp_path, capsys):
    out = tmp_path / "t1"
    assert cli.main(["bench", "table1", "--scheduler", "serial", "--scenes", "kitchen", "ants", "--width", "48", "--height", "36",
                     "--frames", "2", "--out", str(out)]) == 0
    rows = _csv(out / "table1.csv")
    assert [r["scene"] for r in rows] == ["kitchen", "ants"]
    assert float(rows[0]["paper_max_frame_mean"]) == PAPER_TABLE1["kitchen"][0]
    assert float(rows[0]["max_frame_mean"]) >= float(rows[0]["total_mean"]) > 0
    assert "paper" in capsys.readouterr().out


def test_table1_against_gbuffer_resolution_and_motion(tmp_path, capsys):
    out = tmp_path / "t1"
    assert cli.main(["bench", "table1", "--scheduler", "serial", "--no-timing", "--scenes", "ants", "--width", "48",
                     "--height", "36", "--frames", "3", "--gbuffer-scales", "1", "2", "--slowdowns", "1", "2",
                     "--out", str(out)]) == 0
    rows = _csv(out / "table1.csv")
    assert [(r["gbuffer"], r["slowdown"], r["frames"]) for r in rows] == [
        ("48x36", "1", "3"), ("48x36", "2", "5"), ("96x72", "1", "3"), ("96x72", "2", "5")]
    # a finer G-buffer has more pixels to cross: the cold first frame's walks are longer
    assert float(rows[2]["max_frame_mean"]) > float(rows[0]["max_frame_mean"])
    assert "slowdown 2 (5 frames)" in capsys.readouterr().out


def test_a_slowed_animation_passes_through_the_same_poses():
    import refsoft
    from refsoft.bench.table1 import slowed

    scene = refsoft.load_scene("ants", width=48, height=36)
    slow = slowed(scene, 3)
    assert slow.n_frames == (scene.n_frames - 1) * 3 + 1
    for k in (0, 1, 7, scene.n_frames - 1):
        a, b = scene.camera_at(k), slow.camera_at(3 * k)
        assert np.array_equal(a.eye, b.eye) and np.array_equal(a.target, b.target)
        for j in range(1, len(scene.objects) + 1):
            assert np.array_equal(scene.world_mesh(j, k).vertices, slow.world_mesh(j, 3 * k).vertices)
    # between two poses, the midway frame of a slowdown 2 is the midway point of the path
    s2 = slowed(scene, 2)
    mid = s2.camera_at(3).eye
    assert np.allclose(mid, 0.5 * (scene.camera_at(1).eye + scene.camera_at(2).eye))


def test_without_matplotlib_the_tables_are_still_written(tmp_path, capsys, monkeypatch):
    import importlib

    sweep_mod = importlib.import_module("refsoft.bench.sweep")  # the package's `sweep` is the function
    monkeypatch.setattr(sweep_mod, "plt_or_none", lambda: None)
    out = tmp_path / "s"
    assert cli.main(["bench", "sweep", "--scheduler", "serial", "--scenes", "planar", "--width", "32", "--height", "24", "--frames", "1",
                     "--repeats", "1", "--knob", "precision", "--out", str(out)]) == 0
    assert (out / "sweep.csv").exists() and not (out / "pareto.png").exists()
    assert "pip install '.[plot]'" in capsys.readouterr().out
