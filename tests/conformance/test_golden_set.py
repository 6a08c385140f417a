"""Handling a golden set with care: `golden` into an existing set refuses without --add or
--replace, --add keeps the other cases, --replace starts anew; `check` writes its report to
its own folder, pictures (magnified) only of what did not pass; the manifest's git hash is
refsoft's own or null."""

import json
import os
import shutil
import subprocess
import sys

import imageio.v3 as iio
import numpy as np
import pytest

from refsoft.conformance.check import MAGNIFY, check
from refsoft.conformance.golden import GOLDEN_SIZE, read_manifest, write_golden
from refsoft.errors import RefsoftError
from refsoft.io import read_npz, write_npz

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def run_cli(*args, cwd):
    """``python -m refsoft ARGS`` in a child process: (exit status, stdout, stderr)."""
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    r = subprocess.run([sys.executable, "-m", "refsoft", *map(str, args)], cwd=cwd, env=env, capture_output=True,
                       text=True, timeout=300)
    return r.returncode, r.stdout, r.stderr


def assert_one_line_error(rc, err, *names):
    assert rc == 2, err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("refsoft: error: "), err
    for name in names:
        assert name in lines[0], (name, lines[0])


@pytest.fixture(scope="module")
def golden(tmp_path_factory):
    out = tmp_path_factory.mktemp("golden") / "golden"
    write_golden(out, ["pixel_grid"])
    return out


def _listing(folder):
    return sorted(os.path.relpath(os.path.join(d, f), folder) for d, _, fs in os.walk(folder) for f in fs)


# --- golden into an existing set ------------------------------------------------------------------

def test_golden_into_an_existing_set_refuses_without_add_or_replace(golden, tmp_path):
    gold = tmp_path / "golden"
    shutil.copytree(golden, gold)
    before = (gold / "manifest.json").read_bytes()
    rc, out, err = run_cli("golden", "--out", gold, "--case", "sphere", cwd=tmp_path)
    assert_one_line_error(rc, err, f"{gold} already holds a golden set", "--add", "--replace")
    assert (gold / "manifest.json").read_bytes() == before and not (gold / "sphere").exists()
    with pytest.raises(RefsoftError, match="already holds"):
        write_golden(gold, ["pixel_grid"])
    rc, _, err = run_cli("golden", "--out", gold, "--add", "--replace", cwd=tmp_path)
    assert rc == 2 and "not allowed with" in err and (gold / "manifest.json").read_bytes() == before


def test_add_keeps_the_other_cases_and_regenerating_one_changes_nothing(golden, tmp_path):
    gold = tmp_path / "golden"
    shutil.copytree(golden, gold)
    old = read_manifest(gold)
    rc, out, err = run_cli("golden", "--out", gold, "--case", "sphere", "--add", cwd=tmp_path)
    assert rc == 0, err
    assert "2 cases (1 written)" in out
    m = read_manifest(gold)
    assert [c["name"] for c in m["cases"]] == ["sphere", "pixel_grid"]  # canonical order
    assert {k: v for k, v in m["files"].items() if k.startswith("pixel_grid/")} == old["files"]
    inputs = {f"sphere/inputs/{n}" for n in os.listdir(gold / "sphere" / "inputs")}
    assert "sphere/inputs/case.json" in inputs and "sphere/inputs/mesh_1.ply" in inputs
    assert set(m["files"]) == set(old["files"]) | {"sphere/frame_0000.npz", "sphere/traces_0000.json"} | inputs
    assert check(gold, gold)["passed"]  # both cases checked
    both = (gold / "manifest.json").read_bytes()
    write_golden(gold, ["pixel_grid"], mode="add")  # regenerated: byte-identical files, same manifest
    assert (gold / "manifest.json").read_bytes() == both


def test_add_refuses_when_a_kept_file_was_altered(golden, tmp_path):
    gold = tmp_path / "golden"
    shutil.copytree(golden, gold)
    before = (gold / "manifest.json").read_bytes()
    with open(gold / "pixel_grid" / "traces_0000.json", "a") as fh:
        fh.write(" ")
    rc, _, err = run_cli("golden", "--out", gold, "--case", "sphere", "--add", cwd=tmp_path)
    assert_one_line_error(rc, err, str(gold / "pixel_grid" / "traces_0000.json"), "altered", "--replace")
    assert (gold / "manifest.json").read_bytes() == before and not (gold / "sphere").exists()


def test_replace_starts_the_set_anew(golden, tmp_path):
    gold = tmp_path / "golden"
    shutil.copytree(golden, gold)
    (gold / "notes.txt").write_text("mine")  # not listed in the manifest: left alone
    m = write_golden(gold, ["sphere"], mode="replace")
    assert [c["name"] for c in m["cases"]] == ["sphere"]
    assert not (gold / "pixel_grid").exists() and (gold / "notes.txt").exists()
    assert _listing(gold) == sorted(["manifest.json", "notes.txt", *[p.replace("/", os.sep) for p in m["files"]]])


def test_a_new_folder_needs_no_mode(tmp_path):
    m = write_golden(tmp_path / "new", ["pixel_grid"], mode="add")
    assert [c["name"] for c in m["cases"]] == ["pixel_grid"]


# --- check's report -------------------------------------------------------------------------------

def test_check_report_goes_to_out_check_never_into_the_inputs(golden, tmp_path):
    gold = tmp_path / "golden"
    shutil.copytree(golden, gold)
    before = _listing(gold)
    rc, out, err = run_cli("check", gold, gold, cwd=tmp_path)
    assert rc == 0, err
    assert _listing(gold) == before  # nothing written into the golden set
    summary = json.loads((tmp_path / "out" / "check" / "summary.json").read_text())
    assert summary["passed"] and summary["pictures"] == []
    assert os.listdir(tmp_path / "out" / "check") == ["summary.json"]  # no pictures of passes
    n = summary["counts"]["pass"]
    assert n == sum(k["pass"] for k in summary["by_kind"].values()) and n > 0
    assert summary["by_kind"]["pixel"] == {"pass": 1, "accepted": 0, "fail": 0, "missing": 0}
    table = [line.split() for line in out.splitlines()]
    assert ["kind", "pass", "accepted", "fail", "missing"] in table and ["pixel", "1", "0", "0", "0"] in table
    assert f"PASSED: {n} pass" in out
    for inside in (gold / "report", gold / "pixel_grid"):
        rc, _, err = run_cli("check", gold, gold, "--out", inside, cwd=tmp_path)
        assert_one_line_error(rc, err, f"report folder {inside} is inside the golden set {gold}")
    assert _listing(gold) == before


def test_check_pictures_only_what_did_not_pass_magnified(golden, tmp_path):
    cand = tmp_path / "cand"
    shutil.copytree(golden, cand)
    path = cand / "pixel_grid" / "frame_0000.npz"
    a = read_npz(path)
    a["image"] = a["image"][::-1].copy()  # a y-flipped image: fails; every other output passes
    write_npz(path, **a)
    report = tmp_path / "report"
    s = check(golden, cand, out=report)
    assert not s["passed"] and s["counts"]["fail"] == 1
    assert sorted(os.listdir(report)) == ["pixel_grid_frame_0000_image.png", "pixel_grid_frame_0000_image_diff.png",
                                          "summary.json"]
    w, h = GOLDEN_SIZE
    mask = iio.imread(report / "pixel_grid_frame_0000_image.png")
    assert mask.shape == (MAGNIFY * h, MAGNIFY * w, 3) and MAGNIFY == 4
    blocks = mask.reshape(h, MAGNIFY, w, MAGNIFY, 3)
    assert (blocks == blocks[:, :1, :, :1]).all()  # nearest neighbour: each pixel a 4x4 block
    red = np.all(blocks[:, 0, :, 0] == (220, 0, 0), axis=-1)
    d = np.abs(a["image"].astype(int) - golden_image(golden).astype(int)).max(axis=2)
    assert np.array_equal(red, d > 1)  # red exactly where the rule fails
    # a passing run into the same folder removes the earlier report's pictures
    s = check(golden, golden, out=report)
    assert s["passed"] and os.listdir(report) == ["summary.json"]


def golden_image(golden):
    return read_npz(golden / "pixel_grid" / "frame_0000.npz")["image"]


# --- the manifest's git hash ------------------------------------------------------------------------

def _git_hash_of_copy(tmp_path, pyproject, under):
    """_git_hash() of a copy of the package in folder ``under`` of a fresh git repository whose
    top level holds ``pyproject`` (None: no pyproject.toml)."""
    repo = tmp_path / "repo"
    shutil.copytree(os.path.join(ROOT, "refsoft"), repo / under / "refsoft",
                    ignore=shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc"))
    if pyproject is not None:
        (repo / "pyproject.toml").write_text(pyproject)
    git = ["git", "-c", "user.name=t", "-c", "user.email=t@t", "-c", "commit.gpgsign=false"]
    subprocess.run(["git", "init", "-q", str(repo)], check=True)
    subprocess.run(git + ["-C", str(repo), "add", "-A"], check=True)
    subprocess.run(git + ["-C", str(repo), "commit", "-qm", "x"], check=True)
    head = subprocess.run(["git", "-C", str(repo), "rev-parse", "HEAD"], capture_output=True, text=True,
                          check=True).stdout.strip()
    r = subprocess.run([sys.executable, "-c", "from refsoft.conformance.golden import _git_hash; print(_git_hash())"],
                       env=dict(os.environ, PYTHONPATH=str(repo / under)), cwd=tmp_path, capture_output=True, text=True,
                       check=True)
    return r.stdout.strip(), head


REFSOFT_TOML = '[project]\nname = "refsoft"\n'


@pytest.mark.parametrize("pyproject, under, ours", [(REFSOFT_TOML, ".", True), (REFSOFT_TOML, "site-packages", False),
                                                    ('[project]\nname = "other"\n', ".", False), (None, ".", False)])
def test_git_hash_only_of_refsofts_own_work_tree(tmp_path, pyproject, under, ours):
    """Recorded for refsoft's own work tree; null for a package in another project's repository,
    in a repository without pyproject.toml, or installed below the top level."""
    got, head = _git_hash_of_copy(tmp_path, pyproject, under)
    assert got == (head if ours else "None")
