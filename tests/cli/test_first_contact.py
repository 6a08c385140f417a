"""What a new user meets: runs own their folders, a first run says it compiles, progress shows in
logs, options a command does not use are refused, ids and frames are named the same everywhere."""

import json
import os
import subprocess
import sys

import pytest

from refsoft import cli

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SMALL = ["--width", "48", "--height", "36", "--preset", "paper"]


def run_cli(*args, cwd=None):
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, "-m", "refsoft", *args], capture_output=True, text=True, env=env, cwd=cwd,
                          timeout=600)


def test_a_run_owns_its_folder(tmp_path, capsys):
    out = tmp_path / "r"
    assert cli.main(["render", "sphere", "--frames", "2", "--out", str(out), *SMALL]) == 0
    run = json.loads((out / "run.json").read_text())
    assert (run["kind"], run["scene"], run["frames"], run["width"]) == ("render", "sphere", [0, 1], 48)
    capsys.readouterr()
    # another run into the same folder is refused, and nothing is touched
    before = {p.name: p.stat().st_mtime_ns for p in out.iterdir()}
    assert cli.main(["render", "planar", "--frames", "1", "--out", str(out), *SMALL]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "already holds a render of 'sphere', 2 frames at 48x36" in err[0] and "--overwrite" in err[0]
    assert {p.name: p.stat().st_mtime_ns for p in out.iterdir()} == before
    # --overwrite replaces that run's files: no frame of the sphere is left beside the planar ones
    assert cli.main(["render", "planar", "--frames", "1", "--out", str(out), "--overwrite", *SMALL]) == 0
    assert sorted(p.name for p in out.glob("frame_*")) == ["frame_0000.npz", "frame_0000.png"]
    stats = json.loads((out / "stats.json").read_text())
    assert [f["frame"] for f in stats["frames"]] == [0] and json.loads((out / "run.json").read_text())["scene"] == "planar"


def test_default_folders_are_named_after_the_scene(tmp_path):
    r = run_cli("render", "sphere", "--frames", "1", *SMALL, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    t = run_cli("truth", "sphere", "--frames", "1", "--width", "48", "--height", "36", cwd=tmp_path)
    assert t.returncode == 0, t.stderr
    assert (tmp_path / "out" / "sphere" / "frame_0000.npz").exists()
    assert json.loads((tmp_path / "out" / "sphere-truth" / "run.json").read_text())["kind"] == "truth"


def test_progress_shows_in_logs_and_the_closing_line_is_honest(tmp_path):
    """Off a terminal (a log) a line every tenth of the run; the closing figure is a median of
    the frames, with no word of compiling when nothing was compiled."""
    r = run_cli("render", "planar", "--frames", "4", *SMALL, "--out", str(tmp_path / "o"))
    assert r.returncode == 0, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.startswith("render planar: ")]
    assert [ln.split(" frames")[0] for ln in lines] == [f"render planar: {n}/4" for n in (1, 2, 3, 4)]
    assert "median" in r.stdout and "compiling" not in r.stdout


def test_a_first_run_says_it_compiles_once_its_inputs_are_checked(monkeypatch, capsys, tmp_path):
    from refsoft import _numba
    from refsoft.cli import main

    monkeypatch.setattr(_numba, "kernels_cached", lambda minimum=20: False)
    (tmp_path / "taken").mkdir()
    (tmp_path / "taken" / "frame_0000.npz").write_bytes(b"")
    assert main(["render", "sphere", "--frames", "1", "--out", str(tmp_path / "taken")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "already holds" in err[0]  # refused before any notice
    assert main(["render", "sphere", "--frames", "1", "--width", "32", "--height", "24", "--preset", "paper",
                 "--out", str(tmp_path / "o")]) == 0
    captured = capsys.readouterr()
    assert captured.err.strip().splitlines()[0] == ("refsoft: first run: compiling the render kernels (about 20 s "
                                                    "on 2 cores; cached for later runs)")
    assert "s for the frame, compiling included" in captured.out


@pytest.mark.parametrize("args, message", [
    (["bench", "table1", "--repeats", "2"], "bench table1 takes no --repeats"),
    (["bench", "scaling", "--frames", "2"], "bench scaling takes no --frames"),
    (["bench", "accuracy", "--width", "64"], "bench accuracy takes no --width"),
    (["bench", "sweep", "--sizes", "64x48"], "bench sweep takes no --sizes"),
    (["gbuffer", "sphere", "--reflector", "9"], "has no object 9 (object ids are 1..6"),
    (["gbuffer", "sphere", "--reflector", "2"], "object 2 ('floor') of scene 'sphere' is not a reflector"),
])
def test_options_a_command_cannot_use_are_refused_by_name(args, message, capsys):
    assert cli.main(args) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err, err


def test_static_scenes_take_any_frame_in_every_command(tmp_path):
    """A static scene has every frame: gbuffer and trace accept --frame 5 as render does."""
    assert cli.main(["gbuffer", "sphere", "--frame", "5", "--width", "48", "--height", "36",
                     "--out", str(tmp_path / "g")]) == 0
    assert cli.main(["trace", "sphere", "--vertex", "10", "--frame", "2", "--width", "48", "--height", "36",
                     "--out", str(tmp_path / "t")]) == 0


def test_the_readme_claims_what_its_command_measures(tmp_path):
    """The README says the accurate preset agrees with the truth on 99.97-100% of the mirrors'
    pixels of the convex scenes and the paper preset on 0.2-70%, measured by `refsoft bench
    accuracy`: the same command at a small size on one scene lands in those ranges."""
    import re

    readme = open(os.path.join(ROOT, "README.md")).read()
    lo, hi, plo, phi = map(float, re.search(r"agrees on ([\d.]+)-([\d.]+)% of the mirrors'.*?preset agrees on "
                                            r"([\d.]+)-([\d.]+)%", readme, re.S).groups())
    assert cli.main(["bench", "accuracy", "--scheduler", "serial", "--scenes", "quad", "--sizes", "160x120", "--frames", "1",
                     "--setting", "paper", "--setting", "accurate", "--out", str(tmp_path)]) == 0
    rows = {r["setting"]: float(r["agreement"]) * 100
            for r in __import__("csv").DictReader(open(tmp_path / "accuracy.csv"))}
    assert lo <= rows["accurate"] <= hi and plo <= rows["paper"] <= phi, rows


def test_a_misspelt_scene_name_gets_a_suggestion(capsys):
    assert cli.main(["render", "kitchn", "--frames", "1"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "unknown scene 'kitchn' (did you mean 'kitchen'?)" in err
    assert cli.main(["render", "zzzzzz", "--frames", "1"]) == 2
    assert "did you mean" not in capsys.readouterr().err


def test_run_json_names_the_vertices_searched_and_all(tmp_path):
    import json

    import refsoft

    assert cli.main(["render", "sphere", "--frames", "1", "--width", "32", "--height", "24",
                     "--out", str(tmp_path / "r")]) == 0
    run = json.loads((tmp_path / "r" / "run.json").read_text())
    scene = refsoft.load_scene("sphere")
    assert run["vertices_all"] == sum(o.mesh.n_vertices for o in scene.objects)
    assert run["vertices"] == sum(o.mesh.n_vertices for o in scene.objects if not o.reflector) < run["vertices_all"]


def test_a_late_frame_of_a_static_scene_renders_two_frames_not_all(tmp_path, capsys):
    """Every frame of a static scene after the first is the same: --frame 9 renders frames 0 and 9,
    and frame 9 is --frame 1's frame 1, bit for bit."""
    import json

    import numpy as np

    base = ["render", "sphere", "--width", "32", "--height", "24", "--preset", "paper"]
    assert cli.main(base + ["--frame", "9", "--out", str(tmp_path / "a")]) == 0
    assert "2/2 frames" in capsys.readouterr().err  # frames 0 and 9, not 0 .. 9
    assert cli.main(base + ["--frame", "1", "--out", str(tmp_path / "b")]) == 0
    assert json.loads((tmp_path / "a" / "run.json").read_text())["frames"] == [9]
    assert sorted(p.name for p in (tmp_path / "a").glob("frame_*.npz")) == ["frame_0009.npz"]
    a, b = np.load(tmp_path / "a" / "frame_0009.npz"), np.load(tmp_path / "b" / "frame_0001.npz")
    assert sorted(a.files) == sorted(b.files)
    for k in a.files:
        assert np.array_equal(a[k], b[k], equal_nan=a[k].dtype.kind == "f"), k


def test_refsoft_glsl_help_reads_as_plain_text():
    import subprocess
    import sys

    env = dict(os.environ, PYTHONPATH=os.pathsep.join([os.path.join(ROOT, "ports", "glsl"), ROOT]))
    r = subprocess.run([sys.executable, "-m", "refsoft_glsl", "--help"], capture_output=True, text=True, env=env,
                       timeout=60)
    assert r.returncode == 0 and "refsoft-glsl run GOLDEN" in r.stdout and "``" not in r.stdout
