"""The layered depth textures behind ``RenderOptions(method="ldt")``, ``refsoft.render`` and
``refsoft render --method ldt``: options, refusals, the run's files."""

import json

import numpy as np
import pytest

import refsoft
from refsoft import cli
from refsoft.errors import RefsoftError
from refsoft.frame import RenderOptions
from refsoft.ldt import build_ldt
from refsoft.options import LDT_DEFAULTS


def test_options_fill_the_ldt_defaults_and_record_only_what_the_method_reads():
    o = RenderOptions(method="ldt", ldt_tau=1.5, ldt_layers="1")
    assert o.ldt_tau == 1.5 and o.ldt_layers == 1 and o.ldt_resolution == LDT_DEFAULTS["ldt_resolution"]
    d = o.as_dict()
    assert set(d) == {"method", "precision"} | set(LDT_DEFAULTS)
    assert RenderOptions(**d) == o
    # the vertex search records no LDT option: its golden manifests do not change
    assert not any(k.startswith("ldt_") for k in RenderOptions().as_dict())
    assert RenderOptions(**RenderOptions(preset="paper").as_dict()) == RenderOptions(preset="paper")


@pytest.mark.parametrize("kwargs, match", [
    (dict(ldt_tau=1.0), "ldt_tau applies to method='ldt' only"),
    (dict(method="ldt", ldt_resolution=2), "ldt_resolution"),
    (dict(method="ldt", ldt_layers=3), "ldt_layers must be 'all' or 1"),
    (dict(method="ldt", ldt_layers=True), "ldt_layers must be 'all' or 1"),
    (dict(method="ldt", ldt_faces="two"), "ldt_faces"),
    (dict(method="ldt", ldt_linear=0), "ldt_linear"),
    (dict(method="ldt", ldt_linear="fine"), "ldt_linear"),
    (dict(method="ldt", ldt_tau=-1.0), "ldt_tau"),
    (dict(method="ldt", ldt_regions="sphere"), "ldt_regions"),
])
def test_bad_ldt_options_are_refused(kwargs, match):
    with pytest.raises(RefsoftError, match=match):
        RenderOptions(**kwargs)


@pytest.mark.parametrize("argv, match", [
    (["--method", "ldt", "--neighbourhood", "box"], "--neighbourhood is an option of the vertex search"),
    (["--method", "ldt", "--no-coherence"], "--no-coherence is an option of the vertex search"),
    (["--ldt-tau", "1"], "ldt_tau applies to method='ldt' only"),
    (["--method", "ldt", "--ldt-linear", "many"], "--ldt-linear must be a step count or 'texel'"),
])
def test_cli_refuses_options_of_the_other_method(tmp_path, capsys, argv, match):
    out = tmp_path / "o"
    assert cli.main(["render", "sphere", "--frames", "1", "--width", "32", "--height", "24", "--out", str(out)]
                    + argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and match in err[0]
    assert not out.exists()


def test_cli_render_writes_frames_stats_and_one_texture_file_per_reflected_object(tmp_path, capsys):
    out = tmp_path / "o"
    assert cli.main(["render", "balls", "--method", "ldt", "--ldt-resolution", "32", "--ldt-linear", "texel",
                     "--frames", "2", "--width", "64", "--height", "48", "--out", str(out)]) == 0
    assert "method ldt" in capsys.readouterr().out
    scene = refsoft.load_scene("balls", width=64, height=48)
    targets = [k for k in range(1, len(scene.objects) + 1) if not scene.object_by_id(k).reflector]
    assert sorted(p.name for p in out.glob("ldt_*.npz")) == sorted(f"ldt_{j}.npz" for j in targets)
    for j in targets:  # the texture as built from the object's model mesh, bit for bit
        want = build_ldt(scene.object_by_id(j).mesh, 32).arrays()
        with np.load(out / f"ldt_{j}.npz") as z:
            assert sorted(z.files) == sorted(want)
            for name, value in want.items():
                np.testing.assert_array_equal(z[name], value, err_msg=name)
    stats = json.loads((out / "stats.json").read_text())
    assert stats["options"]["method"] == "ldt" and stats["options"]["ldt_linear"] == "texel"
    t0, t1 = (f["time_ms"] for f in stats["frames"])
    assert list(t0)[:3] == ["ldt_build", "regions", "ldt_search"]
    assert t0["ldt_build"] > 0 and t1["ldt_build"] == 0
    assert stats["summary"]["ldt_linear_samples"]["max"] > 0
    with np.load(out / "frame_0001.npz") as z:
        assert z["ldt_object_distance"].shape == (len(targets), 48, 64)
        off = z["object_id"] != scene.reflector_ids[0]
        assert np.all(z["ldt_face"][off] == -1) and np.all(z["ldt_hit_distance"][off] == -1)
    # compare takes the run against its truth and gives the per-pixel hit error
    truth = tmp_path / "t"
    assert cli.main(["truth", "balls", "--frames", "2", "--width", "64", "--height", "48", "--out", str(truth)]) == 0
    capsys.readouterr()
    assert cli.main(["compare", str(out), str(truth), "--out", str(tmp_path / "c")]) == 0
    report = json.loads((tmp_path / "c" / "metrics.json").read_text())
    for m in report["frames"]:
        assert m["reflected_id_disagreement"] < 0.02
        assert m["hit_distance"]["pixels"] > 0 and m["hit_distance"]["median"] < 0.05
    assert "hit " in capsys.readouterr().out


def test_cli_trace_replays_one_pixel(tmp_path, capsys):
    from refsoft.frame import FrameDriver

    scene = refsoft.load_scene("balls", width=64, height=48)
    frame = FrameDriver(scene, RenderOptions(method="ldt", ldt_resolution=32)).render_frame(0)
    rows, cols = np.nonzero(frame.arrays["reflected_id"] > 0)
    row, col = int(rows[len(rows) // 2]), int(cols[len(cols) // 2])
    base = ["trace", "balls", "--width", "64", "--height", "48", "--out", str(tmp_path / "t")]
    assert cli.main(base + ["--method", "ldt", "--ldt-resolution", "32", "--pixel", str(row), str(col),
                            "--bisection"]) == 0
    out = capsys.readouterr().out
    assert f"pixel ({row}, {col})" in out and "result: object" in out and "b1" in out
    got = json.loads((tmp_path / "t" / "trace.json").read_text())
    assert got["result"]["face"] == int(frame.arrays["ldt_face"][row, col])
    assert '"kind":"ldt"' in (tmp_path / "t" / "trace.html").read_text() and "trace.html" in out
    for argv, match in ((["--method", "ldt"], "give --pixel ROW COL"),
                        (["--method", "ldt", "--pixel", "0", "0"], "not a reflector"),
                        (["--method", "ldt", "--pixel", "1", "1", "--vertex", "3"], "--vertex is an option"),
                        (["--pixel", "1", "1"], "add --method ldt"),
                        (["--method", "envmap", "--pixel", "1", "1"], "no search to trace")):
        assert cli.main(base + argv) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and match in err[0], (argv, err)
