"""The GLSL port (ports/glsl) against the oracle, as CI runs it: a golden set of every canonical
case, both variants rendered from the cases' inputs by ``refsoft-glsl run``, judged by
``refsoft check``.

The port needs an EGL context on Mesa llvmpipe (Debian packages ``libegl1 libegl-mesa0
libgl1-mesa-dri``, installed by ``.ci/run``); without one these tests fail with the reason,
they are not skipped.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]


def _run(args, env=None, timeout=600):
    return subprocess.run(args, capture_output=True, text=True, env=env, timeout=timeout)


def _glsl(*args):
    """``refsoft-glsl ARGS``: the installed entry point, or the package from the work tree."""
    script = Path(sys.executable).with_name("refsoft-glsl")
    if script.exists():
        return _run([str(script), *args])
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(REPO / "ports" / "glsl"), env.get("PYTHONPATH")) if p)
    return _run([sys.executable, "-m", "refsoft_glsl", *args], env=env)


def _refsoft(*args):
    return _run([sys.executable, "-m", "refsoft", *args])


def _why(proc) -> str:
    return f"exit {proc.returncode}\nstdout:\n{proc.stdout[-3000:]}\nstderr:\n{proc.stderr[-3000:]}"


@pytest.fixture(scope="module")
def llvmpipe():
    """The renderer's versions; fails (never skips) without an llvmpipe EGL context."""
    proc = _glsl("info")
    if proc.returncode != 0:
        pytest.fail("the GLSL port needs Mesa llvmpipe through EGL (apt-get install libegl1 libegl-mesa0 "
                    f"libgl1-mesa-dri; .ci/run does) and moderngl (pip install '.[glsl]'): {_why(proc)}",
                    pytrace=False)
    return dict(line.split(": ", 1) for line in proc.stdout.splitlines())


#: The reflection methods the GLSL port implements; it declares the others in ported.json.
PORTED_METHODS = ("walk", "hierarchy", "envmap", "ldt")
DECLARED_METHODS = []
#: The drawings of the virtual triangles the port declares not ported (it rasterizes them).
DECLARED_DRAWING = ["exact"]
#: The stages each method's frames time (stats.json), besides ``total``.
STAGES = {"walk": {"main", "gbuffer", "search", "virtual", "composite"},
          "envmap": {"main", "envmap_build", "envmap_lookup", "composite"},
          "ldt": {"main", "ldt_build", "regions", "ldt_search", "composite"}}


def _doc_commands():
    """docs/ports.md section 7's shell block: its ``refsoft-glsl run`` and ``refsoft check``
    command lines (comments dropped), as a port author types them."""
    text = (REPO / "docs" / "ports.md").read_text()
    section = text.split("## 7. ", 1)[1].split("\n## ", 1)[0]
    block = section.split("```sh\n", 1)[1].split("```", 1)[0]
    lines = [ln.split("#", 1)[0].split() for ln in block.splitlines()]
    return [ln for ln in lines if ln[:2] in (["refsoft-glsl", "run"], ["refsoft", "check"])]


def _as_written(line, golden, out):
    """A documented command line with its folders made the test's: ``golden`` the session's
    golden set, the candidate (the word after ``--out`` of ``run``, the second folder of
    ``check``) ``out``."""
    folders = {"golden": str(golden)}
    if line[0] == "refsoft-glsl":
        folders[line[line.index("--out") + 1]] = str(out)
    else:
        folders[line[3]] = str(out)
    return [folders.get(word, word) for word in line[1:]]


@pytest.fixture(scope="module")
def golden(golden_set, llvmpipe):
    """The session's golden set (tests/conftest.py: written once, shared with the conformance
    tests), the names of its cases the port implements and of those it declares not ported."""
    manifest = json.loads((golden_set / "manifest.json").read_text())
    options = {c["name"]: c["options"] for c in manifest["cases"]}
    declared = [n for n, o in options.items() if o.get("method", "walk") in DECLARED_METHODS
                or o.get("draw") in DECLARED_DRAWING]
    names = [n for n, o in options.items() if o.get("method", "walk") in PORTED_METHODS and n not in declared]
    assert len(names) >= 28 and declared == ["kitchen_exact"] and len(names) + 1 == len(options), options
    assert "touching_envmap" in names and "balls_ldt" in names, names
    return golden_set, names, declared


#: Arrays of the golden frames that only the oracle writes (a port does not).
ORACLE_ONLY = ("gbuffer_depth_margin_",)
#: Arrays the port declares it does not write (its ported.json: every image of every vertex).
NOT_PORTED = ("image_count_", "image_vertex_", "image_pixel_", "image_virtual_", "image_sheet_", "bounce_depth")
#: The flag the enumeration of every image sets (not ported either).
SEVERAL = 32


def _candidate(golden, tmp_path_factory, variant):
    """docs/ports.md's ``refsoft-glsl run`` line of ``variant`` (the exact one has no
    ``--plain``), run as written on the session's golden set: every case, exit 0, one line per
    case it declares not ported."""
    runs = [ln for ln in _doc_commands() if ln[0] == "refsoft-glsl"]
    line = [ln for ln in runs if ("--plain" in ln) == (variant == "plain")]
    assert len(line) == 1, runs
    out = tmp_path_factory.mktemp("candidate") / "out"
    proc = _glsl(*_as_written(line[0], golden[0], out), "--quiet")
    assert proc.returncode == 0, _why(proc)
    skipped = [ln for ln in proc.stderr.splitlines() if "not ported (declared in ported.json)" in ln]
    assert len(skipped) == len(golden[2]), proc.stderr
    for name in golden[2]:
        assert f"case {name}: option draw='exact' not ported (declared in ported.json)" in skipped, (name, proc.stderr)
    return out


@pytest.fixture(scope="module")
def exact(golden, tmp_path_factory):
    return _candidate(golden, tmp_path_factory, "exact")


@pytest.fixture(scope="module")
def plain(golden, tmp_path_factory):
    return _candidate(golden, tmp_path_factory, "plain")


def _frames(golden_dir, name):
    return sorted(p.name for p in (golden_dir / name).glob("frame_*.npz"))


def _check(golden, candidate, report, *flags):
    """docs/ports.md's ``refsoft check`` line, as written (every case), with ``flags``."""
    line = [ln for ln in _doc_commands() if ln[0] == "refsoft"]
    assert len(line) == 1, _doc_commands()
    proc = _refsoft(*_as_written(line[0], golden[0], candidate), "--out", str(report), *flags)
    assert proc.returncode in (0, 1), _why(proc)
    return proc, json.loads((report / "summary.json").read_text())


def _declared_not_ported(golden, proc, summary):
    """Every case the port declares is reported not ported, in the summary and the output (it
    declares none: every case is judged)."""
    gaps = summary["not_ported"]["cases"]
    assert sorted(gaps) == sorted(golden[2]), gaps
    assert all("declared not ported" in why for why in gaps.values()), gaps
    if golden[2]:
        assert f"not ported: {len(golden[2])} case(s)" in proc.stdout, proc.stdout[-2000:]
    else:
        assert "case(s), declared in" not in proc.stdout, proc.stdout[-2000:]


def test_the_documented_commands_need_no_case_list():
    lines = _doc_commands()
    assert [ln[:2] for ln in lines] == [["refsoft-glsl", "run"], ["refsoft", "check"], ["refsoft-glsl", "run"]]
    assert not any("--case" in ln for ln in lines), lines


def test_llvmpipe_and_its_versions(llvmpipe):
    assert "llvmpipe" in llvmpipe["GL_RENDERER"]
    assert llvmpipe["mesa"] != "None" and llvmpipe["llvm"] != "None"


def test_exact_variant_is_bit_identical_on_every_golden_case(golden, exact):
    golden_dir, names, _ = golden
    # every case it ports and its declaration, nothing else
    assert sorted(p.name for p in exact.iterdir()) == sorted(names + ["ported.json"])
    assert json.loads((exact / "ported.json").read_text())["not_ported"] == {"options": {"draw": ["exact"]},
                                                                             "kinds": ["images", "bounces"]}
    differ = []
    for name in names:
        frames = _frames(golden_dir, name)
        assert frames and _frames(exact, name) == frames, name
        textures = sorted(p.name for p in (golden_dir / name).glob("ldt_*.npz"))
        assert sorted(p.name for p in (exact / name).glob("ldt_*.npz")) == textures, name
        for f in textures:  # the layered depth textures, once per case
            want, got = np.load(golden_dir / name / f), np.load(exact / name / f)
            assert sorted(want.files) == sorted(got.files), (name, f)
            differ += [f"{name}/{f}:{k}" for k in want.files if want[k].dtype != got[k].dtype
                       or want[k].shape != got[k].shape or want[k].tobytes() != got[k].tobytes()]
        for f in frames:
            want, got = np.load(golden_dir / name / f), np.load(exact / name / f)
            expected = [k for k in want.files if not k.startswith(ORACLE_ONLY + NOT_PORTED)]
            assert sorted(got.files) == sorted(expected), (name, f)
            for key in expected:
                if key in ("image", "reflected_id") and any(k.startswith("image_count_") or k == "bounce_depth"
                                                            for k in want.files):
                    continue  # drawn from every image of every vertex, or with several bounces: declared
                    # not ported
                a, b = want[key], got[key]
                if key.startswith("flags_"):
                    a = a & ~np.uint8(SEVERAL)
                if a.dtype != b.dtype or a.shape != b.shape or a.tobytes() != b.tobytes():
                    differ.append(f"{name}/{f}:{key}")
    assert not differ, f"{len(differ)} arrays differ from the oracle: {differ[:10]}"


def test_exact_variant_passes_the_default_rules_with_no_tie(golden, exact, tmp_path):
    proc, summary = _check(golden, exact, tmp_path / "report")
    assert proc.returncode == 0, _why(proc)
    assert summary["passed"]
    _declared_not_ported(golden, proc, summary)
    assert summary["counts"]["fail"] == 0 and summary["counts"]["missing"] == 0, summary["counts"]
    assert summary["counts"]["accepted"] == 0, summary["counts"]  # bit-identical: nothing to accept
    assert summary["counts"]["pass"] > 0
    assert not summary["missing_files"]


def test_a_case_missing_without_a_declaration_fails(golden, exact, tmp_path):
    """A candidate of the port's first case alone, whose ported.json declares method ``ldt``:
    ``touching_envmap``, not declared, is missing and check fails; ``balls_ldt`` is not ported."""
    golden_dir, names, declared = golden
    envmap, ldt = ["touching_envmap"], ["balls_ldt"]
    cand = tmp_path / "cand"
    shutil.copytree(exact / names[0], cand / names[0])
    (cand / "ported.json").write_text(json.dumps({"format": "refsoft-ported-1",
                                                  "not_ported": {"methods": ["ldt"], "kinds": ["images", "bounces"]}}))
    cases = [arg for n in (names[0], envmap[0], ldt[0]) for arg in ("--case", n)]
    proc = _refsoft("check", str(golden_dir), str(cand), "--out", str(tmp_path / "report"), *cases)
    assert proc.returncode == 1, _why(proc)
    summary = json.loads((tmp_path / "report" / "summary.json").read_text())
    assert not summary["passed"] and summary["counts"]["missing"] > 0, summary["counts"]
    assert summary["counts"]["fail"] == 0, summary["counts"]
    missing = {f["case"] for f in summary["findings"] if f["status"] == "missing"}
    assert missing == {envmap[0]}, missing
    assert sorted(summary["not_ported"]["cases"]) == [ldt[0]], summary["not_ported"]


def test_stats_record_the_renderer_and_per_stage_milliseconds(golden, exact, llvmpipe):
    golden_dir, names, _ = golden
    for name in names:
        stats = json.loads((exact / name / "stats.json").read_text())
        assert stats["variant"] == "exact"
        assert stats["gl"]["mesa"] == llvmpipe["mesa"] and stats["gl"]["llvm"] == llvmpipe["llvm"]
        assert [f"frame_{f['frame']:04d}.npz" for f in stats["frames"]] == _frames(golden_dir, name)
        for f in stats["frames"]:
            t = f["time_ms"]
            method = stats["options"]["method"] if stats["options"]["method"] in STAGES else "walk"
            assert STAGES[method] | {"total"} <= set(t), name
            assert t["total"] > 0 and t["total"] >= max(v for k, v in t.items() if k != "total")


def _has_gpu_profile() -> bool:
    proc = _refsoft("check", "--help")
    assert proc.returncode == 0, _why(proc)
    return "--profile" in proc.stdout


def test_plain_variant_is_judged_by_the_gpu_profile(golden, plain, tmp_path):
    """The plain variant under ``--profile gpu``: no failure, no missing output. Where
    ``refsoft check`` has no ``gpu`` profile yet, the default rules judge it: it must then be
    complete (nothing missing), cover exactly the oracle's G-buffer pixels, and differ from the
    oracle (it is not the exact variant under another name)."""
    golden_dir, names, _ = golden
    assert sorted(p.name for p in plain.iterdir()) == sorted(names + ["ported.json"])
    for name in names:
        assert json.loads((plain / name / "stats.json").read_text())["variant"] == "plain"
    if _has_gpu_profile():
        proc, summary = _check(golden, plain, tmp_path / "report", "--profile", "gpu")
        assert proc.returncode == 0, _why(proc)
        assert summary["counts"]["fail"] == 0 and summary["counts"]["missing"] == 0, summary["counts"]
        _declared_not_ported(golden, proc, summary)
        return
    proc, summary = _check(golden, plain, tmp_path / "report")
    assert summary["counts"]["missing"] == 0 and not summary["missing_files"], summary["counts"]
    by_key = {}
    for f in summary["findings"]:
        by_key.setdefault(f["key"].rstrip("0123456789"), []).append(f["status"])
    assert by_key["gbuffer_mask_"] and set(by_key["gbuffer_mask_"]) == {"pass"}, by_key["gbuffer_mask_"]
    assert by_key["object_id"] and set(by_key["object_id"]) <= {"pass", "accepted"}  # reported, not judged
    assert "fail" in by_key["gbuffer_position_"]  # GL's interpolation, not refsoft's


def test_plain_environment_map_is_gl_s_own_cube(golden, plain):
    """The plain variant's cube maps are GL's raster (its interpolation, not refsoft's): their
    colours differ from the oracle's somewhere; the exact variant's are the oracle's (above)."""
    golden_dir = golden[0]
    for name in ("touching_envmap", "cube_edge_envmap"):
        want, got = np.load(golden_dir / name / "frame_0000.npz"), np.load(plain / name / "frame_0000.npz")
        assert want["envmap_color_1"].shape == got["envmap_color_1"].shape, name
        assert not np.array_equal(want["envmap_color_1"], got["envmap_color_1"]), name


def test_a_cube_face_with_its_axes_swapped_is_caught(golden, tmp_path):
    """A mutant of the exact variant whose +Y face (the only face the box is seen in) is rendered
    with its s and t axes swapped (the build's face table; the lookup keeps GL's): ``refsoft
    check`` fails its ids."""
    golden_dir = golden[0]
    out = tmp_path / "mutant"
    code = ("import sys; from refsoft_glsl import cli, envmap; t = list(envmap.FACE_TABLE); "
            "t[2] = (t[2][1], t[2][0], t[2][2]); envmap.FACE_TABLE = tuple(t); "
            "sys.exit(cli.main(sys.argv[1:]))")
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(REPO / "ports" / "glsl"), env.get("PYTHONPATH")) if p)
    proc = _run([sys.executable, "-c", code, "run", str(golden_dir), "--out", str(out), "--quiet",
                 "--case", "touching_envmap"], env=env)
    assert proc.returncode == 0, _why(proc)
    proc = _refsoft("check", str(golden_dir), str(out), "--out", str(tmp_path / "report"), "--case", "touching_envmap")
    assert proc.returncode == 1, _why(proc)
    summary = json.loads((tmp_path / "report" / "summary.json").read_text())
    failed = {f["key"] for f in summary["findings"] if f["status"] == "fail"}
    assert "envmap_id_1" in failed, failed


ENVMAP = ["--method", "envmap", "--envmap-resolution", "16"]
LDT = ["--method", "ldt", "--ldt-resolution", "16"]


@pytest.mark.parametrize("scene, options", [
    ("touching", ENVMAP), ("balls", ENVMAP), ("touching", ENVMAP + ["--precision", "float64"]),
    ("hollow_box", LDT + ["--ldt-linear", "texel", "--ldt-faces", "entry"]),
    ("cup", LDT + ["--ldt-regions", "none", "--ldt-layers", "1", "--ldt-tau", "0.5"])])
def test_exported_frames_of_the_comparison_methods_are_refsofts_bit_for_bit(llvmpipe, scene, options, tmp_path):
    """Two coherent frames exported by ``refsoft export`` into a folder without a manifest (the
    port reads ``CASE/inputs/``), with options the golden set does not hold: the environment map
    on ``touching`` (nothing moves: both peers keep the cube map of frame 0), on ``balls`` (the
    objects move: both rebuild it) and in float64; the LDT with one step per texel and the entry
    face only, and without the cone test, with one layer and another tau. Every array of both
    frames, and the LDT's textures, are refsoft's."""
    opts = [*options, "--frames", "2", "--width", "64", "--height", "48"]
    name = f"{scene}_case"
    proc = _refsoft("export", scene, *opts, "--out", str(tmp_path / "cases" / name / "inputs"))
    assert proc.returncode == 0, _why(proc)
    proc = _refsoft("render", scene, *opts, "--out", str(tmp_path / "ref"))
    assert proc.returncode == 0, _why(proc)
    if scene in ("touching", "balls"):
        reused = [f["cube_maps_reused"] for f in json.loads((tmp_path / "ref" / "stats.json").read_text())["frames"]]
        assert reused == ([[], [1]] if scene == "touching" else [[], []]), reused
    proc = _glsl("run", str(tmp_path / "cases"), "--out", str(tmp_path / "port"), "--quiet")
    assert proc.returncode == 0, _why(proc)
    files = sorted(p.name for p in (tmp_path / "ref").glob("*.npz"))
    assert "frame_0001.npz" in files and sorted(p.name for p in (tmp_path / "port" / name).glob("*.npz")) == files
    assert any(f.startswith("ldt_") for f in files) == ("ldt" in options), files
    for f in files:
        want, got = np.load(tmp_path / "ref" / f), np.load(tmp_path / "port" / name / f)
        assert sorted(want.files) == sorted(got.files), (f, want.files, got.files)
        for key in want.files:
            assert want[key].dtype == got[key].dtype and want[key].tobytes() == got[key].tobytes(), (f, key)


def test_an_ldt_face_with_its_axes_swapped_is_caught(golden, tmp_path):
    """A mutant of the exact variant whose textures' +X face is built with its s and t axes
    swapped (the build's face table; the search keeps refsoft's): ``refsoft check`` fails the
    textures and the search."""
    golden_dir = golden[0]
    out = tmp_path / "mutant"
    code = ("import sys; from refsoft_glsl import cli, ldt_build; t = list(ldt_build.FACE_TABLE); "
            "t[0] = (t[0][2], t[0][3], t[0][0], t[0][1]); ldt_build.FACE_TABLE = tuple(t); "
            "sys.exit(cli.main(sys.argv[1:]))")
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(REPO / "ports" / "glsl"), env.get("PYTHONPATH")) if p)
    proc = _run([sys.executable, "-c", code, "run", str(golden_dir), "--out", str(out), "--quiet",
                 "--case", "balls_ldt"], env=env)
    assert proc.returncode == 0, _why(proc)
    proc = _refsoft("check", str(golden_dir), str(out), "--out", str(tmp_path / "report"), "--case", "balls_ldt")
    assert proc.returncode == 1, _why(proc)
    summary = json.loads((tmp_path / "report" / "summary.json").read_text())
    failed = {f["kind"] for f in summary["findings"] if f["status"] == "fail"}
    assert "ldt_texture" in failed, failed


def test_a_declared_method_is_skipped_and_reported_not_ported(golden, tmp_path):
    """The port with ``ldt`` added to its declaration (``run.NOT_PORTED``): ``refsoft-glsl run``
    skips the ``ldt`` case with one line, writes the declaration and exits 0; ``refsoft check``
    lists the case as not ported and passes."""
    golden_dir, names, _ = golden
    out = tmp_path / "cand"
    code = ("import sys; from refsoft_glsl import cli, run; run.NOT_PORTED['methods'] = ['ldt']; "
            "sys.exit(cli.main(sys.argv[1:]))")
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(REPO / "ports" / "glsl"), env.get("PYTHONPATH")) if p)
    cases = [arg for n in (names[0], "balls_ldt") for arg in ("--case", n)]
    proc = _run([sys.executable, "-c", code, "run", str(golden_dir), "--out", str(out), "--quiet", *cases], env=env)
    assert proc.returncode == 0, _why(proc)
    skipped = "case balls_ldt: method 'ldt' not ported (declared in ported.json)"
    assert proc.stderr.splitlines() == [skipped], proc.stderr
    assert sorted(p.name for p in out.iterdir()) == sorted([names[0], "ported.json"])
    assert json.loads((out / "ported.json").read_text())["not_ported"] == {"kinds": ["images", "bounces"],
                                                                           "options": {"draw": ["exact"]},
                                                                           "methods": ["ldt"]}
    proc = _refsoft("check", str(golden_dir), str(out), "--out", str(tmp_path / "report"), *cases)
    assert proc.returncode == 0, _why(proc)
    summary = json.loads((tmp_path / "report" / "summary.json").read_text())
    assert list(summary["not_ported"]["cases"]) == ["balls_ldt"] and summary["counts"]["missing"] == 0, summary
    assert "not ported: 1 case(s)" in proc.stdout, proc.stdout[-2000:]
