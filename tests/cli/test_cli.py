"""The command line: outputs, one-line errors, atomic writes; README and CI stay in step."""

import os
import re
import subprocess
import sys

import numpy as np
import pytest

from refsoft import cli
from scene_data import ANIMATED

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def run_cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "refsoft", *args], capture_output=True, text=True, cwd=cwd)


def test_gbuffer_command_writes_maps_and_pictures(tmp_path):
    out = tmp_path / "o"
    assert cli.main(["gbuffer", "sphere", "--width", "80", "--height", "60", "--out", str(out)]) == 0
    with np.load(out / "gbuffer_1.npz") as z:
        assert z["gbuffer_position"].shape == (60, 80, 3) and z["gbuffer_position"].dtype == np.float32
        assert z["gbuffer_normal"].dtype == np.float32
        assert z["gbuffer_mask"].dtype == bool and z["gbuffer_mask"].sum() > 100
        assert z["gbuffer_view_proj"].shape == (4, 4) and z["gbuffer_view_proj"].dtype == np.float64
    import imageio.v3 as iio

    pic = iio.imread(out / "gbuffer.png")
    assert pic.shape == (60, 2 * 80 + 4, 3)
    assert iio.imread(out / "view.png").shape == (60, 80, 3)
    assert not [f for f in os.listdir(out) if f.endswith(".tmp") or ".tmp." in f]


def test_widened_and_float64(tmp_path):
    assert cli.main(["gbuffer", "sphere", "--width", "40", "--height", "30", "--widen", "1.5",
                     "--precision", "float64", "--out", str(tmp_path)]) == 0
    with np.load(tmp_path / "gbuffer_1.npz") as z:
        assert z["gbuffer_position"].shape == (45, 60, 3) and z["gbuffer_position"].dtype == np.float64


def test_scenes_lists_builtins(capsys):
    assert cli.main(["scenes"]) == 0
    out = capsys.readouterr().out
    assert re.search(r"^sphere\s+(\d+) -> \1\s+(\d+) -> \2\s+1\s+1\s", out, re.M)  # not subdivided
    before, after = map(int, re.search(r"^kitchen\s+(\d+) -> (\d+)", out, re.M).groups())
    assert 11000 < before < after < 16000  # the loader's subdivision, as the paper's 11,379 -> 14,979


@pytest.mark.parametrize("args, message", [
    (["gbuffer", "nope"], "unknown scene 'nope'"),
    (["gbuffer", "sphere", "--width", "0"], "width must be positive"),
    (["gbuffer", "sphere", "--width", "100000"], "exceeds the limit"),
    (["gbuffer", "sphere", "--reflector", "2"], "not a reflector"),
    (["gbuffer", "ellipsoid", "--frame", "99"], "frame must be an integer in [0, "),
    (["gbuffer", "sphere", "--widen", "0.5"], "widen must be a number >= 1"),
    (["gbuffer", "missing.toml"], "scene file not found"),
])
def test_bad_input_gives_one_line_and_exit_2(tmp_path, args, message):
    r = run_cli(*args, "--out", str(tmp_path / "o"), cwd=tmp_path)
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("refsoft: error:") and message in lines[0], r.stderr
    assert "Traceback" not in r.stderr


def test_failed_run_does_not_damage_existing_outputs(tmp_path):
    out = tmp_path / "o"
    assert cli.main(["gbuffer", "sphere", "--width", "40", "--height", "30", "--out", str(out)]) == 0
    before = {f: (out / f).read_bytes() for f in os.listdir(out)}
    r = run_cli("gbuffer", "sphere", "--width", "40", "--height", "30", "--reflector", "3", "--out", str(out))
    assert r.returncode == 2
    assert {f: (out / f).read_bytes() for f in os.listdir(out)} == before


def test_readme_opens_with_two_commands_that_ci_runs():
    readme = open(os.path.join(ROOT, "README.md")).read()
    block = readme.split("```")[1].splitlines()[1:]
    commands = [line for line in block if line.strip()]
    assert len(commands) == 2
    assert "refsoft " in commands[0] and "pip install" in commands[0]
    assert "pytest" in commands[1] and "pip install" in commands[1]
    ci = open(os.path.join(ROOT, ".ci", "run")).read()
    assert "README.md" in ci  # .ci/run executes exactly the README's first code block


def test_trace_command_writes_table_json_png_gif(tmp_path, capsys):
    import json

    import imageio.v3 as iio

    out = tmp_path / "t"
    assert cli.main(["trace", "sphere", "--vertex", "1500", "--width", "160", "--height", "120", "--search", "box",
                     "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "result: pixel" in text and "up-left" in text
    data = json.loads((out / "trace.json").read_text())
    assert data["vertex_index"] == 1500 and data["reflector"] == 1
    assert len(data["steps"]) == data["result"]["iterations"]
    png = iio.imread(out / "trace.png")
    assert png.ndim == 3 and png.shape[2] == 3 and min(png.shape[:2]) >= 100
    # start marker green, end marker red are drawn
    assert np.any(np.all(png == [40, 220, 60], axis=-1)) and np.any(np.all(png == [230, 30, 30], axis=-1))
    gif = iio.imread(out / "trace.gif", index=None)
    assert len(gif) == min(len(data["steps"]), 150) + 1
    assert oct(os.stat(out / "trace.png").st_mode & 0o777) != "0o600"
    page = (out / "trace.html").read_text()
    assert page.startswith("<!DOCTYPE html>") and '"kind":"walk"' in page and "trace.html" in text




def test_trace_command_coherent_frame_starts_at_previous_pixel(tmp_path, capsys):
    import json

    import refsoft
    from refsoft.search.reflect import reflect

    (tmp_path / "anim.toml").write_text(ANIMATED)
    scene = refsoft.load_scene(tmp_path / "anim.toml")
    prev = None
    for f in range(2):
        _, _, r = reflect(scene, f, previous=prev)
        prev = {1: r[1].result.pixel}
    _, _, r2 = reflect(scene, 2, previous=prev)
    vertex = 7
    assert cli.main(["trace", str(tmp_path / "anim.toml"), "--vertex", str(vertex), "--frame", "2",
                     "--out", str(tmp_path / "a")]) == 0
    data = json.loads((tmp_path / "a" / "trace.json").read_text())
    assert data["start"] == list(prev[1][vertex])  # frame 1's pixel, still covered
    assert data["result"]["pixel"] == list(r2[1].result.pixel[vertex])
    assert data["result"]["iterations"] == r2[1].result.iterations[vertex]


def test_trace_command_replays_a_later_bounce(tmp_path, capsys):
    import json

    out = tmp_path / "b"
    assert cli.main(["trace", "mirrors", "--vertex", "1500", "--through", "1,2", "--width", "160", "--height", "120",
                     "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "bounce 2: reflector 2 ('ball_2') as seen via 1 ('ball_1')" in text and "result: pixel" in text
    data = json.loads((out / "trace.json").read_text())
    assert data["through"] == [1, 2] and data["reflector"] == 2 and len(data["box"]) == 4
    assert (out / "trace.png").exists() and (out / "trace.html").exists()


@pytest.mark.parametrize("args, message", [
    (["trace", "mirrors", "--vertex", "1", "--through", "1,x"], "--through must be reflector ids"),
    (["trace", "mirrors", "--vertex", "1", "--through", "1,2", "--reflector", "1"], "leave out --reflector"),
    (["trace", "sphere", "--vertex", "999999"], "vertex must be an integer in [0, "),
    (["trace", "sphere", "--vertex", "1", "--reflector", "3"], "not a reflector"),
    (["trace", "ellipsoid", "--vertex", "1", "--frame", "99"], "frame must be an integer in [0, "),
])
def test_trace_bad_input(tmp_path, args, message):
    r = run_cli(*args, "--out", str(tmp_path / "o"), cwd=tmp_path)
    assert r.returncode == 2 and message in r.stderr and "Traceback" not in r.stderr


def test_every_option_of_every_command_has_help_text():
    import argparse

    parser = cli.build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    missing = [f"{name} {act.option_strings or act.dest}" for name, p in sub.choices.items() for act in p._actions
               if not isinstance(act, argparse._HelpAction) and not act.help]
    assert not missing, missing


@pytest.mark.parametrize("what, own, other", [("accuracy", "--sizes", "--knob"), ("sweep", "--knob", "--sizes"),
                                              ("table1", "--scenes", "--max-width"),
                                              ("scaling", "--max-width", "--setting")])
def test_each_bench_subcommand_has_its_own_help(what, own, other, capsys):
    with pytest.raises(SystemExit) as e:
        cli.main(["bench", what, "--help"])
    out = capsys.readouterr().out
    assert e.value.code == 0 and f"refsoft bench {what}" in out
    assert own in out and other not in out  # its own options only
    # and its own defaults only: no other subcommand's named in its help
    others = {"accuracy", "sweep", "scaling", "table1"} - {what}
    words = " ".join(out.split())
    assert not any(f"{o}:" in words or f"{o} " in words.split("options:", 1)[-1] for o in others), words
    assert f"out/bench/{what}" in words
