"""The bad-input corpus (tests/bad_inputs.py): every case is refused by the API with a specific
exception and a one-line message, and by the CLI with that line, exit status 2, no traceback,
and the output folder untouched."""

import os
import subprocess
import sys

import pytest

from bad_inputs import CASES, api_call
from refsoft import cli

IDS = [c[0] for c in CASES]


def _materialise(tmp_path, files):
    for name, content in files.items():
        p = tmp_path / name
        p.parent.mkdir(parents=True, exist_ok=True)
        if isinstance(content, bytes):
            p.write_bytes(content)
        else:
            p.write_text(content)
    out = tmp_path / "out"
    out.mkdir()
    (out / "frame_0000.png").write_bytes(b"an earlier result")
    return out


def _untouched(out):
    return sorted(os.listdir(out)) == ["frame_0000.png"] and (out / "frame_0000.png").read_bytes() == b"an earlier result"


def test_the_corpus_is_large_and_distinct():
    assert len(CASES) >= 40
    assert len(set(IDS)) == len(IDS)


@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_api_raises_a_specific_error(tmp_path, case):
    _, files, argv, error, message = case
    _materialise(tmp_path, files)
    with pytest.raises(error) as info:
        api_call(tmp_path, argv)
    text = str(info.value)
    assert message in text and "\n" not in text, text


@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_cli_prints_one_line_and_exits_2(tmp_path, capsys, case):
    _, files, argv, _, message = case
    out = _materialise(tmp_path, files)
    code = cli.main([a.format(d=tmp_path) for a in argv])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len(err) == 1 and err[0].startswith("refsoft: error:") and message in err[0], err
    assert _untouched(out)


@pytest.mark.parametrize("case", [c for c in CASES if c[0] in ("malformed_toml", "mesh_nan_vertex", "no_reflector",
                                                                 "width_absurd", "cli_memory_limit_tiny")],
                         ids=lambda c: c[0])
def test_process_exit_has_no_traceback(tmp_path, case):
    _, files, argv, _, message = case
    out = _materialise(tmp_path, files)
    r = subprocess.run([sys.executable, "-m", "refsoft", *[a.format(d=tmp_path) for a in argv]],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], r.stderr
    assert _untouched(out)
