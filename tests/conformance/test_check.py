"""`refsoft golden` and `refsoft check`: the oracle checked against itself passes with nothing
flagged, and every mutation a buggy port could make is flagged (the mutation suite), under both
profiles."""

import json
import os
import shutil

import numpy as np
import pytest

import naive
from refsoft import cli, constants
from refsoft.conformance.check import check
from refsoft.conformance.golden import case_by_name, write_golden
from refsoft.io import write_npz
from refsoft.search.reflect import reflector_gbuffer
from refsoft.scene import scene_vertices
from refsoft.search import start_pixel

#: Every test of the mutation suite runs under each profile of `refsoft check`.
by_profile = pytest.mark.parametrize("profile", constants.CHECK_PROFILES)

def _candidate(golden, tmp_path, case, frame, mutate, traces=None):
    """A copy of the golden set with one frame's arrays changed by ``mutate(arrays)``."""
    cand = tmp_path / "cand"
    shutil.copytree(golden, cand)
    path = cand / case / f"frame_{frame:04d}.npz"
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    mutate(arrays)
    write_npz(path, **arrays)
    for f in (cand / case).glob("traces_*.json"):
        f.unlink()  # the golden's own traces are not a port's
    if traces is not None:
        (cand / case / f"traces_{frame:04d}.json").write_text(json.dumps(traces))
    return cand


def _statuses(summary, key=None):
    return {(f.key, f.status) for f in summary["_findings"] if key is None or f.key == key}


def _flagged(summary):
    return [f for f in summary["_findings"] if f.status != "pass"]


@by_profile
def test_oracle_against_itself_passes_with_nothing_flagged(golden, tmp_path, profile):
    from refsoft.conformance.golden import CASES

    s = check(golden, golden, out=tmp_path / "report", profile=profile)
    assert s["passed"] and _flagged(s) == [] and s["counts"]["pass"] >= 400 and s["profile"] == profile
    assert {f.case for f in s["_findings"]} == {c.name for c in CASES}
    assert os.listdir(tmp_path / "report") == ["summary.json"]  # pictures only of what did not pass
    assert sum(k["pass"] for k in s["by_kind"].values()) == s["counts"]["pass"]


def test_regenerating_gives_identical_files(golden, tmp_path):
    again = tmp_path / "again"
    write_golden(again, ["sphere", "pixel_grid"])
    for case in ("sphere", "pixel_grid"):
        names = [p.relative_to(golden) for p in (golden / case).rglob("*") if p.is_file()]
        assert any(n.parts[1] == "inputs" for n in names)
        for f in names:
            assert (again / f).read_bytes() == (golden / f).read_bytes(), f
    m1 = json.loads((golden / "manifest.json").read_text())
    m2 = json.loads((again / "manifest.json").read_text())
    assert {k: v for k, v in m1["files"].items() if k.split("/")[0] in ("sphere", "pixel_grid")} == m2["files"]
    assert m2["numpy"] == np.__version__ and m2["refsoft"] and "options" in m2["cases"][0]


def _walk(P, N, mask, eye, v, start, offsets, cap):
    """A plain hill climb with any visiting order, recording the path (float32, the search's
    arithmetic through tests/naive.py)."""
    h, w = mask.shape
    r, c = start
    path = []

    def s(rr, cc):
        return naive.naive_scores(P[rr, cc], N[rr, cc], eye, v, np.float32)[()]

    for _ in range(cap):
        path.append([int(r), int(c)])
        best, best_rc = s(r, c), (r, c)
        for dr, dc in offsets:
            rr, cc = r + dr, c + dc
            if 0 <= rr < h and 0 <= cc < w and mask[rr, cc]:
                sc = s(rr, cc)
                if sc > best:
                    best, best_rc = sc, (rr, cc)
        if best_rc == (r, c):
            break
        r, c = best_rc
    return (r, c), path


def _port_search(case_name, offsets, shift=(0, 0), every=7):
    """What a port with another visiting order or start rule computes for every ``every``-th
    vertex of a cold frame 0: pixels, iterations and traces."""
    case = case_by_name(case_name)
    scene = case.load()
    gb = reflector_gbuffer(scene, 1, 0)
    verts, _ = scene_vertices(scene, 0)
    eye = scene.camera_at(0).eye - gb.origin
    start = tuple(np.add(start_pixel(gb.mask), shift))
    out = {}
    for i in range(0, len(verts), every):
        end, path = _walk(gb.position, gb.normal, gb.mask, eye, verts[i] - gb.origin, start, offsets, 400)
        out[i] = (end, path)
    return out


def _apply_port(arrays, port):
    traces = {"format": "refsoft-traces-1", "reflectors": {"1": []}}
    for i, (end, path) in port.items():
        arrays["reflection_pixel_1"][i] = end
        arrays["iterations_1"][i] = len(path)
        traces["reflectors"]["1"].append({"vertex": i, "path": path})
    return traces


@by_profile
def test_mutation_neighbour_order_changed(golden, tmp_path, profile):
    order = [(1, 0), (0, 1), (-1, 0), (0, -1)]  # down, right, up, left instead of left, up, right, down
    port = _port_search("pixel_grid", order, every=3)
    traces = {}
    cand = _candidate(golden, tmp_path, "pixel_grid", 0, lambda a: traces.update(_apply_port(a, port)))
    (cand / "pixel_grid" / "traces_0000.json").write_text(json.dumps(traces))
    s = check(golden, cand, cases=["pixel_grid"], profile=profile)
    assert ("traces_1", "fail") in _statuses(s)
    f = [f for f in s["_findings"] if f.key == "traces_1"][0]
    assert "step" in f.details[0]


@by_profile
def test_mutation_start_pixel_shifted_by_one(golden, tmp_path, profile):
    port = _port_search("sphere", [(0, -1), (-1, 0), (0, 1), (1, 0)], shift=(1, 0), every=5)
    traces = {}
    cand = _candidate(golden, tmp_path, "sphere", 0, lambda a: traces.update(_apply_port(a, port)))
    s = check(golden, cand, cases=["sphere"], profile=profile)
    assert not s["passed"] and ("iterations_1", "fail") in _statuses(s)
    (cand / "sphere" / "traces_0000.json").write_text(json.dumps(traces))
    s = check(golden, cand, cases=["sphere"], profile=profile)
    f = [f for f in s["_findings"] if f.key == "traces_1"][0]
    assert f.status == "fail" and f.details[0].split(": step ")[1].startswith("0,")  # they part at the start


@by_profile
def test_mutation_fill_rule_flipped(golden, tmp_path, monkeypatch, profile):
    """A port with the opposite fill rule (bottom-right instead of top-left) covers the mirror's
    pixels whose centres lie exactly on its horizontal edges the other way."""
    case = case_by_name("pixel_grid")
    scene = case.load()
    cam = scene.camera_at(0)
    mesh = scene.world_mesh(1, 0, proxy=True)
    clip = np.c_[mesh.vertices, np.ones(mesh.n_vertices)] @ cam.view_proj().T
    monkeypatch.setattr(naive, "is_inclusive", lambda ax, ay, bx, by: not ((by - ay) < 0 or ((by - ay) == 0 and (bx - ax) > 0)))
    _, face, _, _ = naive.naive_rasterize(clip, mesh.faces, cam.width, cam.height)
    flipped = face >= 0

    def mutate(a):
        assert (a["gbuffer_mask_1"] != flipped).sum() > 0
        a["gbuffer_mask_1"] = flipped

    cand = _candidate(golden, tmp_path, "pixel_grid", 0, mutate)
    s = check(golden, cand, cases=["pixel_grid"], out=tmp_path / "r", profile=profile)
    f = [f for f in s["_findings"] if f.key == "gbuffer_mask_1"][0]
    assert f.status == "accepted" and f.count > 0 and "ambiguous" in f.message  # flagged: centres on edges
    assert (tmp_path / "r" / "pixel_grid_frame_0000_gbuffer_mask_1.png").exists()


@by_profile
def test_mutation_float64_arithmetic(golden, tmp_path, profile):
    with np.load(golden / "sphere_float64" / "frame_0000.npz") as z:
        f64 = {k: z[k] for k in z.files}
    cand = _candidate(golden, tmp_path, "sphere", 0, lambda a: a.update(f64))
    s = check(golden, cand, cases=["sphere"], profile=profile)
    assert not s["passed"] and ("score_1", "fail") in _statuses(s)  # float64 scores where float32 are due


@by_profile
def test_mutation_fma_like_score(golden, tmp_path, profile):
    def mutate(a):
        s = a["score_1"]
        a["score_1"] = np.nextafter(s, np.float32(2.0)).astype(np.float32)  # one ULP up, as a fused multiply-add

    s = check(golden, _candidate(golden, tmp_path, "sphere", 0, mutate), cases=["sphere"], profile=profile)
    assert ("score_1", "accepted") in _statuses(s)  # within 4 ULP: accepted, but flagged yellow


@by_profile
def test_mutation_y_flipped_image(golden, tmp_path, profile):
    s = check(golden, _candidate(golden, tmp_path, "sphere", 0, lambda a: a.update(image=a["image"][::-1].copy())),
              cases=["sphere"], profile=profile)
    assert not s["passed"] and ("image", "fail") in _statuses(s)


@by_profile
def test_mutation_dropped_vertex(golden, tmp_path, profile):
    def mutate(a):
        for k in list(a):
            if k.endswith("_1") and not k.startswith("gbuffer"):
                a[k] = a[k][:-1]

    s = check(golden, _candidate(golden, tmp_path, "sphere", 0, mutate), cases=["sphere"], profile=profile)
    assert not s["passed"] and ("reflection_pixel_1", "fail") in _statuses(s)


@by_profile
def test_mutation_transposed_gbuffer(golden, tmp_path, profile):
    def mutate(a):
        a["gbuffer_position_1"] = np.ascontiguousarray(a["gbuffer_position_1"].transpose(1, 0, 2))
        a["gbuffer_mask_1"] = np.ascontiguousarray(a["gbuffer_mask_1"].T)

    s = check(golden, _candidate(golden, tmp_path, "sphere", 0, mutate), cases=["sphere"], profile=profile)
    assert not s["passed"] and ("gbuffer_position_1", "fail") in _statuses(s)


@by_profile
def test_mutation_pixel_moved_off_the_optimum(golden, tmp_path, profile):
    """A port that ends one pixel away from the oracle where the scores are not tied fails, and
    the report says where, with the oracle's scores of both pixels."""
    def mutate(a):
        a["reflection_pixel_1"][::50, 1] += 2

    s = check(golden, _candidate(golden, tmp_path, "sphere", 0, mutate), cases=["sphere"], profile=profile)
    f = [f for f in s["_findings"] if f.key == "reflection_pixel_1"][0]
    assert f.status == "fail" and "oracle scores" in f.details[0]


def test_missing_outputs_and_references(golden, tmp_path):
    cand = tmp_path / "cand"
    shutil.copytree(golden, cand)
    os.remove(cand / "sphere" / "frame_0000.npz")
    s = check(golden, cand, cases=["sphere", "pixel_grid"])
    assert not s["passed"] and s["missing_files"] == ["sphere/frame_0000.npz"]  # listed, and a failure
    assert ("*", "missing") in _statuses(s) and s["counts"]["fail"] == 0 and s["counts"]["missing"] == 1
    with np.load(cand / "pixel_grid" / "frame_0000.npz") as z:
        part = {k: z[k] for k in z.files if k != "image"}
    write_npz(cand / "pixel_grid" / "frame_0000.npz", **part)
    s = check(golden, cand, cases=["pixel_grid"])
    assert not s["passed"] and ("image", "missing") in _statuses(s)
    bad_golden = tmp_path / "bad_golden"
    shutil.copytree(golden, bad_golden)
    os.remove(bad_golden / "pixel_grid" / "frame_0000.npz")
    s = check(bad_golden, golden, cases=["pixel_grid"])
    assert not s["passed"] and ("*", "fail") in _statuses(s)  # a missing reference fails


def test_a_subset_passes_only_when_the_candidate_says_so(golden, tmp_path, capsys):
    """A candidate without a whole case, or without one kind of output, fails (exit 1), and
    passes once it excludes them with --case or --kinds."""
    cand = tmp_path / "cand"
    cand.mkdir()
    for case in ("sphere", "planar"):
        shutil.copytree(golden / case, cand / case)
    for f in (cand / "planar").glob("frame_*.npz"):  # no virtual vertices, scores or margins
        with np.load(f) as z:
            write_npz(f, **{k: z[k] for k in z.files if not k.startswith(("virtual_vertex_", "score_", "margin_"))})
    r = str(tmp_path / "r")
    assert cli.main(["check", str(golden), str(cand), "--out", r]) == 1  # 19 cases missing
    out = capsys.readouterr().out
    assert "MISSING  ellipsoid frame 0 *" in out and "FAILED" in out and "--kinds" in out
    assert cli.main(["check", str(golden), str(cand), "--case", "sphere", "--case", "planar", "--out", r]) == 1
    out = capsys.readouterr().out
    assert "MISSING  planar frame 1 virtual_vertex_1 [virtual]" in out and "score_1 [score]" in out
    s = check(golden, cand, cases=["sphere", "planar"], kinds=["coverage,gbuffer,pixel", "flags", "vertex_object",
                                                               "iterations", "image", "ids", "trace"])
    assert s["passed"] and s["counts"]["missing"] == 0 and _flagged(s) == []
    assert not {"virtual", "score", "margin"} & {f.kind for f in s["_findings"]}  # excluded: not judged
    assert {"pixel", "iterations", "flags"} <= {f.kind for f in s["_findings"] if f.case == "planar"}
    assert cli.main(["check", str(golden), str(cand), "--case", "sphere", "--case", "planar", "--out", r,
                     "--kinds", "coverage,gbuffer,pixel,flags,vertex_object,iterations,image,ids"]) == 0
    assert "PASSED" in capsys.readouterr().out
    assert cli.main(["check", str(golden), str(cand), "--kinds", "pixels", "--out", r]) == 2
    assert "unknown kind of output 'pixels'" in capsys.readouterr().err
    # without the reflection pixels, the other per-vertex outputs are judged as if they agreed
    s = check(golden, cand, cases=["planar"], kinds=["iterations", "flags"])
    assert s["passed"] and {f.kind for f in s["_findings"]} == {"iterations", "flags"}
    broken = _candidate(golden, tmp_path / "b", "sphere", 0, lambda a: a["flags_1"].__setitem__(slice(0, 9), 8))
    s = check(golden, broken, cases=["sphere"], kinds=["flags"])
    assert not s["passed"] and ("flags_1", "fail") in _statuses(s)


def test_cli_exit_codes(golden, tmp_path, capsys, monkeypatch):
    assert cli.main(["check", str(golden), str(golden), "--case", "sphere", "--out", str(tmp_path / "r")]) == 0
    assert "PASSED" in capsys.readouterr().out
    assert cli.main(["check", str(golden), str(golden), "--case", "sphere", "--profile", "gpu", "--out",
                     str(tmp_path / "r")]) == 0
    assert "(gpu profile)" in capsys.readouterr().out
    with pytest.raises(SystemExit) as exc:  # argparse's choices
        cli.main(["check", str(golden), str(golden), "--profile", "gl", "--out", str(tmp_path / "r")])
    assert exc.value.code == 2 and "invalid choice: 'gl'" in capsys.readouterr().err
    cand = _candidate(golden, tmp_path, "sphere", 0, lambda a: a.update(image=a["image"][::-1].copy()))
    monkeypatch.chdir(tmp_path)
    assert cli.main(["check", str(golden), str(cand), "--case", "sphere"]) == 1
    out = capsys.readouterr().out
    assert "FAIL" in out and "expected" in out and (tmp_path / "out" / "check" / "summary.json").exists()
    assert not (cand / "check").exists()
    assert cli.main(["check", str(tmp_path / "nope"), str(cand)]) == 2
    assert cli.main(["check", str(golden), str(cand), "--case", "nosuch"]) == 2
    assert cli.main(["golden", "--list"]) == 0 and "pixel_grid" in capsys.readouterr().out


def test_check_says_in_one_line_when_the_set_was_made_with_other_versions(golden, tmp_path, capsys):
    import numba

    assert cli.main(["check", str(golden), str(golden), "--case", "sphere", "--out", str(tmp_path / "r")]) == 0
    assert "note:" not in capsys.readouterr().out  # the same versions: nothing said
    gold = tmp_path / "golden"
    shutil.copytree(golden, gold)
    manifest = json.loads((gold / "manifest.json").read_text())
    manifest["numpy"], manifest["numba"] = "1.26.4", numba.__version__
    (gold / "manifest.json").write_text(json.dumps(manifest))
    assert cli.main(["check", str(gold), str(golden), "--case", "sphere", "--out", str(tmp_path / "r")]) == 0
    notes = [line for line in capsys.readouterr().out.splitlines() if line.startswith("note:")]
    assert len(notes) == 1 and f"numpy 1.26.4 (this checker: {np.__version__})" in notes[0]
    assert "numba" not in notes[0] and "constraints.txt" in notes[0]
    summary = json.loads((tmp_path / "r" / "summary.json").read_text())
    assert summary["versions"]["golden"]["numpy"] == "1.26.4" and summary["versions"]["checker"]["numpy"] == np.__version__


def test_hierarchy_traces_are_replayed(golden, tmp_path):
    traces = json.loads((golden / "sphere_hierarchy" / "traces_0000.json").read_text())
    cand = _candidate(golden, tmp_path, "sphere_hierarchy", 0, lambda a: None, traces=traces)
    s = check(golden, cand, cases=["sphere_hierarchy"])
    assert ("traces_1", "pass") in _statuses(s)  # the oracle's own walks follow themselves
    rec = traces["reflectors"]["1"][0]
    rec["path"][1] = [rec["path"][1][0], rec["path"][1][1] + 1, rec["path"][1][2]]
    (cand / "sphere_hierarchy" / "traces_0000.json").write_text(json.dumps(traces))
    s = check(golden, cand, cases=["sphere_hierarchy"])
    f = [f for f in s["_findings"] if f.key == "traces_1"][0]
    assert f.status == "fail" and ": step 1," in f.details[0]
