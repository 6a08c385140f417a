"""Declared partial ports (``ported.json``, refsoft.conformance.ported): what a candidate declares
and lacks is ``not_ported`` (counted, listed, exit 0), what it lacks without a declaration is
``missing`` (a failure); a declared output it does write is judged as usual; a malformed
declaration is refused."""

import json
import shutil

import numpy as np
import pytest

from refsoft import cli
from refsoft.conformance.check import check
from refsoft.errors import InputFileError
from refsoft.io import read_npz, write_npz

CASES = ["sphere", "sphere_search", "balls_ldt", "touching_envmap"]


def _candidate(golden, tmp_path, cases, declared=None, drop=()):
    """The oracle's own outputs of ``cases`` (a perfect port of those), without the arrays whose
    names start with one of ``drop``, and ``declared`` as its ported.json."""
    cand = tmp_path / "cand"
    for case in cases:
        shutil.copytree(golden / case, cand / case, ignore=shutil.ignore_patterns("inputs", "traces_*"))
        for path in (cand / case).glob("frame_*.npz"):
            arrays = {k: v for k, v in read_npz(path).items() if not k.startswith(tuple(drop))}
            write_npz(path, **arrays)
    cand.mkdir(exist_ok=True)
    if declared is not None:
        (cand / "ported.json").write_text(json.dumps({"format": "refsoft-ported-1", "not_ported": declared}))
    return cand


def _frames(golden, case):
    return len(list((golden / case).glob("frame_*.npz")))


def test_a_port_of_the_vertex_search_that_declares_the_other_methods_passes(golden, tmp_path):
    cand = _candidate(golden, tmp_path, ["sphere", "sphere_search"], {"methods": ["ldt", "envmap"]})
    s = check(golden, cand, cases=CASES)
    n = _frames(golden, "balls_ldt") + _frames(golden, "touching_envmap")
    assert s["passed"] and s["counts"]["fail"] == 0 and s["counts"]["missing"] == 0
    assert s["counts"]["not_ported"] == n and s["counts"]["pass"] > 0
    assert s["not_ported"]["cases"] == {"balls_ldt": "balls_ldt/frame_0000.npz not in the candidate: method 'ldt' "
                                                     "declared not ported",
                                        "touching_envmap": "touching_envmap/frame_0000.npz not in the candidate: "
                                                           "method 'envmap' declared not ported"}
    assert s["declared"]["methods"] == ["ldt", "envmap"]


def test_without_the_declaration_the_same_candidate_fails(golden, tmp_path):
    cand = _candidate(golden, tmp_path, ["sphere", "sphere_search"])
    s = check(golden, cand, cases=CASES)
    assert not s["passed"] and s["counts"]["not_ported"] == 0
    textures = len(list((golden / "balls_ldt").glob("ldt_*.npz")))  # each missing too
    assert s["counts"]["missing"] == _frames(golden, "balls_ldt") + _frames(golden, "touching_envmap") + textures


def test_an_option_value_declared_makes_its_cases_not_ported(golden, tmp_path):
    cand = _candidate(golden, tmp_path, ["sphere"], {"options": {"inverse": ["search"]}, "methods": ["ldt", "envmap"]})
    s = check(golden, cand, cases=CASES)
    assert s["passed"] and "option inverse='search' declared not ported" in s["not_ported"]["cases"]["sphere_search"]


def test_a_declared_kind_is_not_ported_and_an_undeclared_missing_array_fails(golden, tmp_path):
    cand = _candidate(golden, tmp_path, ["sphere"], {"kinds": ["score"]}, drop=("score_",))
    s = check(golden, cand, cases=["sphere"])
    assert s["passed"] and s["not_ported"]["outputs"] == {"score": 1} and s["counts"]["not_ported"] == 1
    shutil.rmtree(tmp_path / "cand")
    cand = _candidate(golden, tmp_path, ["sphere"], {"kinds": ["score"]}, drop=("score_", "margin_"))
    s = check(golden, cand, cases=["sphere"])
    missing = [f for f in s["_findings"] if f.status == "missing"]
    assert not s["passed"] and [f.key for f in missing] == ["margin_1"] and s["counts"]["not_ported"] == 1


def test_a_declared_output_the_candidate_writes_is_judged(golden, tmp_path):
    cand = _candidate(golden, tmp_path, ["sphere"], {"kinds": ["pixel"], "methods": ["walk"]})
    path = cand / "sphere" / "frame_0000.npz"
    arrays = read_npz(path)
    arrays["reflection_pixel_1"] = arrays["reflection_pixel_1"] + np.array([0, 2], np.int32)
    write_npz(path, **arrays)
    s = check(golden, cand, cases=["sphere"])
    status = {f.key: f.status for f in s["_findings"]}
    assert not s["passed"] and status["reflection_pixel_1"] == "fail" and s["counts"]["not_ported"] == 0


def test_the_command_line_lists_what_is_not_ported_and_exits_0(golden, tmp_path, capsys):
    cand = _candidate(golden, tmp_path, ["sphere"], {"methods": ["ldt", "envmap"], "options": {"inverse": ["search"]}})
    args = ["check", str(golden), str(cand), "--out", str(tmp_path / "report")]
    assert cli.main(args + [arg for c in CASES for arg in ("--case", c)]) == 0
    out = capsys.readouterr().out
    assert "not ported: 3 case(s)" in out and "  balls_ldt: method 'ldt' declared not ported" in out
    assert "0 missing, 4 not ported (default profile)" in out and "PASSED" in out  # balls_ldt: 2 frames
    assert "NOT PORTED" not in out  # the declared gaps are summed up, not printed one by one


@pytest.mark.parametrize("content, why", [
    ('{"format": "refsoft-ported-1", "not_ported": {"methods": ["raytrace"]}}', "unknown method 'raytrace'"),
    ('{"format": "refsoft-ported-1", "not_ported": {"kinds": ["pixels"]}}', "unknown kind 'pixels'"),
    ('{"format": "refsoft-ported-1", "not_ported": {"options": {"colour": ["red"]}}}', "unknown option 'colour'"),
    ('{"format": "refsoft-ported-1", "not_ported": {"options": {"inverse": "search"}}}', "must be a list"),
    ('{"format": "refsoft-ported-1", "not_ported": {"method": ["ldt"]}}', "'not_ported' must be an object"),
    ('{"format": "refsoft-ported-2", "not_ported": {}}', "format"),
    ('{"format": "refsoft-ported-1", "not_ported": ', "ported.json"),
])
def test_a_malformed_declaration_is_refused(golden, tmp_path, capsys, content, why):
    cand = _candidate(golden, tmp_path, ["sphere"])
    (cand / "ported.json").write_text(content)
    with pytest.raises(InputFileError, match=why):
        check(golden, cand, cases=["sphere"])
    report = tmp_path / "report"
    assert cli.main(["check", str(golden), str(cand), "--case", "sphere", "--out", str(report)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("refsoft: error:") and "ported.json" in err and len(err.splitlines()) == 1
    assert not report.exists()  # nothing written on bad input


def _one_image_picture(path):
    """The frame at ``path`` as a port that draws one image per vertex might write it: the
    per-image arrays left out, one pixel of the picture and of the reflected ids changed."""
    arrays = {k: v for k, v in read_npz(path).items() if not k.startswith("image_")}
    arrays["image"] = arrays["image"].copy()
    arrays["image"][0, 0] ^= np.uint8(64)
    arrays["reflected_id"] = arrays["reflected_id"].copy()
    arrays["reflected_id"][0, 0] += 1
    write_npz(path, **arrays)


def test_a_port_without_every_image_leaves_the_picture_drawn_from_every_image_not_ported(golden, tmp_path):
    """On a frame the oracle drew from every image (it holds image_count_K), a port that declares
    kind 'images' not ported is not judged on its picture and reflected ids; without the
    declaration the same candidate fails."""
    cand = _candidate(golden, tmp_path, ["concave_accurate"], {"kinds": ["images"]})
    for path in (cand / "concave_accurate").glob("frame_*.npz"):
        _one_image_picture(path)
    s = check(golden, cand, cases=["concave_accurate"])
    status = {(f.frame, f.key): f.status for f in s["_findings"]}
    frames = _frames(golden, "concave_accurate")
    assert s["passed"] and s["counts"]["fail"] == 0 and s["counts"]["missing"] == 0
    assert all(status[(i, k)] == "not_ported" for i in range(frames) for k in ("image", "reflected_id"))
    (cand / "ported.json").unlink()
    s = check(golden, cand, cases=["concave_accurate"])
    status = {(f.frame, f.key): f.status for f in s["_findings"]}
    assert not s["passed"] and status[(0, "image")] == "fail"


def test_a_port_without_every_image_is_judged_on_a_convex_picture(golden, tmp_path):
    """The declaration does not excuse a picture the oracle drew from one image per vertex."""
    cand = _candidate(golden, tmp_path, ["sphere"], {"kinds": ["images"]})
    _one_image_picture(cand / "sphere" / "frame_0000.npz")
    s = check(golden, cand, cases=["sphere"])
    status = {f.key: f.status for f in s["_findings"]}
    assert not s["passed"] and status["image"] == "fail"
