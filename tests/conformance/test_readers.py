"""Bad files given to `refsoft check` and `refsoft compare`: a truncated or random-bytes .npz, a
.json that is not JSON or lacks a key, swapped or unrelated folders. Each ends, in a separate
process, in one line on stderr naming the file, exit status 2 and no traceback."""

import json
import os
import shutil

import numpy as np
import pytest

from refsoft.conformance.golden import write_golden
from refsoft.errors import InputFileError
from refsoft.io import read_json, read_npz, write_npz

from child_cli import assert_one_line_error, run_cli


def truncate(path):
    data = open(path, "rb").read()
    open(path, "wb").write(data[:len(data) // 2])


def random_bytes(path):
    open(path, "wb").write(np.random.default_rng(7).bytes(3000))


@pytest.fixture(scope="module")
def golden(tmp_path_factory):
    out = tmp_path_factory.mktemp("golden") / "golden"
    write_golden(out, ["pixel_grid"])
    return out


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """A render and its truth of `sphere`, and a render of `planar`, all at 32x24."""
    from refsoft import render, render_truth

    base = tmp_path_factory.mktemp("runs")
    size = dict(width=32, height=24)
    render("sphere", out=base / "render", keep=False, preset="paper", **size)
    render_truth("sphere", out=base / "truth", **size)
    render("planar", frames=1, out=base / "planar", keep=False, preset="paper", **size)
    return base


# --- the readers themselves ---------------------------------------------------------------------

def test_read_npz_names_the_file_and_the_problem(tmp_path):
    good = tmp_path / "good.npz"
    write_npz(good, a=np.arange(3))
    assert list(read_npz(good, required=["a"])) == ["a"]
    cases = {"truncated": (truncate, "truncated or damaged"), "random": (random_bytes, "not an .npz file")}
    for name, (spoil, words) in cases.items():
        p = tmp_path / f"{name}.npz"
        shutil.copy(good, p)
        spoil(p)
        with pytest.raises(InputFileError, match=words) as e:
            read_npz(p)
        assert str(e.value).startswith(str(p)) and "\n" not in str(e.value)
    np.savez(tmp_path / "obj.npz", a=np.array([{}, 1], dtype=object))
    with pytest.raises(InputFileError, match="object"):  # never unpickled
        read_npz(tmp_path / "obj.npz")
    np.save(tmp_path / "one.npy", np.zeros(2))
    with pytest.raises(InputFileError, match="single .npy"):
        read_npz(tmp_path / "one.npy")
    with pytest.raises(InputFileError, match="lacks b"):
        read_npz(good, required=["a", "b"])
    with pytest.raises(InputFileError, match="no such file"):
        read_npz(tmp_path / "nope.npz")


def test_every_damaged_byte_of_a_frame_is_one_input_error(golden, tmp_path):
    """Truncations and overwritten bytes anywhere in a frame's .npz (the zip directory, headers,
    compressed data): each read either succeeds or raises InputFileError, never anything else."""
    data = (golden / "pixel_grid" / "frame_0000.npz").read_bytes()
    rng = np.random.default_rng(3)
    p = tmp_path / "f.npz"
    errors = 0
    for t in range(300):
        b = bytearray(data)
        if t % 2:
            b = b[:int(rng.integers(0, len(b)))]
        else:
            i = int(rng.integers(0, len(b) - 8))
            b[i:i + 8] = rng.bytes(8)
        p.write_bytes(bytes(b))
        try:
            read_npz(p)
        except InputFileError as exc:
            errors += 1
            assert str(exc).startswith(str(p)) and "\n" not in str(exc)
    assert errors >= 250  # nearly every change is caught (CRC-32), a few land in slack bytes


def test_read_json_names_the_file_and_the_problem(tmp_path):
    p = tmp_path / "x.json"
    p.write_text('{"format": "f", "a": 1')
    with pytest.raises(InputFileError, match=r"x.json: not valid JSON \(.* at line 1 column"):
        read_json(p)
    p.write_text('[1, 2]')
    with pytest.raises(InputFileError, match="not a JSON object"):
        read_json(p, required=["a"])
    p.write_text('{"format": "g", "a": 1}')
    with pytest.raises(InputFileError, match="not a f file"):
        read_json(p, format="f")
    with pytest.raises(InputFileError, match="lacks the key 'b'"):
        read_json(p, required=["a", "b"])
    p.write_bytes(b"\xff\xfe{}")
    with pytest.raises(InputFileError, match="not UTF-8"):
        read_json(p)


# --- check, in a child process --------------------------------------------------------------------

def _spoil_traces_not_json(cand):
    p = cand / "pixel_grid" / "traces_0000.json"
    p.write_text('{"format": "refsoft-traces-1", "reflectors": ')
    return p


def _spoil_traces_missing_key(cand):
    p = cand / "pixel_grid" / "traces_0000.json"
    t = json.loads(p.read_text())
    del t["reflectors"]["1"][0]["vertex"]
    p.write_text(json.dumps(t))
    return p


def _spoil_npz(spoil):
    def f(cand):
        p = cand / "pixel_grid" / "frame_0000.npz"
        spoil(p)
        return p
    return f


CHECK_SPOILS = {
    "npz truncated": (_spoil_npz(truncate), "truncated or damaged .npz"),
    "npz random bytes": (_spoil_npz(random_bytes), "not an .npz file"),
    "traces not JSON": (_spoil_traces_not_json, "not valid JSON"),
    "traces missing key": (_spoil_traces_missing_key, "lacks 'vertex'"),
}


@pytest.mark.parametrize("what", list(CHECK_SPOILS))
def test_check_of_a_bad_candidate_file_is_one_line_and_exit_2(golden, tmp_path, what):
    spoil, words = CHECK_SPOILS[what]
    cand = tmp_path / "cand"
    shutil.copytree(golden, cand)
    bad = spoil(cand)
    rc, out, err = run_cli("check", golden, cand, "--out", tmp_path / "report", cwd=tmp_path)
    line = assert_one_line_error(rc, err, str(bad), words)
    assert "allow_pickle" not in line and "PASSED" not in out and "FAILED" not in out


@pytest.mark.parametrize("what", ["not JSON", "missing key"])
def test_check_of_a_bad_manifest_is_one_line_and_exit_2(golden, tmp_path, what):
    gold = tmp_path / "golden"
    shutil.copytree(golden, gold)
    m = gold / "manifest.json"
    if what == "not JSON":
        m.write_text(m.read_text()[:-40])
        words = "not valid JSON"
    else:
        data = json.loads(m.read_text())
        del data["cases"][0]["frames"]
        m.write_text(json.dumps(data))
        words = "cases[0] lacks 'frames'"
    rc, _, err = run_cli("check", gold, golden, "--out", tmp_path / "report", cwd=tmp_path)
    assert_one_line_error(rc, err, str(m), words)


# --- compare, in a child process -----------------------------------------------------------------

def _copy_runs(runs, tmp_path):
    """Copies of the runs without any run.json (each test writes the ones it needs)."""
    for name in ("render", "truth", "planar"):
        shutil.copytree(runs / name, tmp_path / name, ignore=shutil.ignore_patterns("run.json"))
    return tmp_path / "render", tmp_path / "truth"


def _drop_key(path, key):
    arrays = read_npz(path)
    del arrays[key]
    write_npz(path, **arrays)


def _run_json(folder, **fields):
    run = {"format": "refsoft-run-1", "kind": "render", "scene": "sphere", "width": 32, "height": 24, "frames": [0]}
    run.update(fields)
    (folder / "run.json").write_text(json.dumps(run))
    return folder / "run.json"


@pytest.mark.parametrize("what", ["render npz truncated", "truth npz random bytes", "render npz missing key",
                                  "run.json not JSON", "run.json missing key"])
def test_compare_of_a_bad_file_is_one_line_and_exit_2(runs, tmp_path, what):
    r, t = _copy_runs(runs, tmp_path)
    if what == "render npz truncated":
        bad, words = r / "frame_0000.npz", "truncated or damaged .npz"
        truncate(bad)
    elif what == "truth npz random bytes":
        bad, words = t / "frame_0000.npz", "not an .npz file"
        random_bytes(bad)
    elif what == "render npz missing key":
        bad, words = r / "frame_0000.npz", "lacks reflected_id"
        _drop_key(bad, "reflected_id")
    elif what == "run.json not JSON":
        bad, words = _run_json(t, kind="truth"), "not valid JSON"
        bad.write_text(bad.read_text()[:-1])
    else:
        bad, words = _run_json(r), "lacks the key 'scene'"
        data = json.loads(bad.read_text())
        del data["scene"]
        bad.write_text(json.dumps(data))
    rc, out, err = run_cli("compare", r, t, cwd=tmp_path)
    assert_one_line_error(rc, err, str(bad), words)
    assert out == "" and not (tmp_path / "out").exists()  # refused before anything is printed or written


def test_compare_refuses_swapped_and_unrelated_folders(runs, tmp_path):
    r, t = _copy_runs(runs, tmp_path)
    rc, _, err = run_cli("compare", t, r, cwd=tmp_path)
    assert_one_line_error(rc, err, "swapped", f"render side {t / 'frame_0000.npz'}",
                          f"truth side {r / 'frame_0000.npz'}")
    rc, _, err = run_cli("compare", r, r, cwd=tmp_path)
    assert_one_line_error(rc, err, f"truth side {r / 'frame_0000.npz'} is not a truth frame")
    rc, _, err = run_cli("compare", tmp_path / "planar", t, cwd=tmp_path)  # same size, another scene
    assert_one_line_error(rc, err, "not the same scene", "vertex_object_1")
    _run_json(t, kind="truth", width=64)  # a run.json at odds with its own frames
    rc, _, err = run_cli("compare", r, t, cwd=tmp_path)
    assert_one_line_error(rc, err, str(t / "run.json"), "says 64x24 pixels", "is 32x24")
    _run_json(r)
    _run_json(t, kind="truth", scene="planar")
    rc, _, err = run_cli("compare", r, t, cwd=tmp_path)
    assert_one_line_error(rc, err, "not the same scene", "'sphere'", "'planar'", "run.json")
    _run_json(t, kind="truth", width=64)
    rc, _, err = run_cli("compare", r, t, cwd=tmp_path)
    assert_one_line_error(rc, err, "32x24", "64x24", "run.json")
    _run_json(t, kind="render")
    rc, _, err = run_cli("compare", r, t, cwd=tmp_path)
    assert_one_line_error(rc, err, f"{t}, given as the truth, is a render")
    assert not (tmp_path / "out").exists() and not (r / "compare").exists() and not (t / "compare").exists()


def test_compare_writes_its_report_to_its_own_folder(runs, tmp_path):
    r, t = _copy_runs(runs, tmp_path)
    _run_json(r)
    _run_json(t, kind="truth")
    before = sorted(os.listdir(r)), sorted(os.listdir(t))
    rc, out, err = run_cli("compare", r, t, cwd=tmp_path)
    assert rc == 0, err
    assert "1 frame(s)" in out and "out/compare/metrics.json" in out
    assert (tmp_path / "out" / "compare" / "metrics.json").exists()
    assert (tmp_path / "out" / "compare" / "agreement_0000.png").exists()
    assert (sorted(os.listdir(r)), sorted(os.listdir(t))) == before  # nothing written into the inputs
    rc, _, err = run_cli("compare", r, t, "--out", r / "report", cwd=tmp_path)
    assert_one_line_error(rc, err, "inside the render folder")
    assert not (r / "report").exists()
