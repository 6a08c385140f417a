"""``refsoft`` run as a child process, and the one-line error it must give (shared by the tests
that concern a process: exit status, stdout, stderr)."""

import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run_cli(*args, cwd):
    """``python -m refsoft ARGS`` in a child process: (exit status, stdout, stderr)."""
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    r = subprocess.run([sys.executable, "-m", "refsoft", *map(str, args)], cwd=cwd, env=env, capture_output=True,
                       text=True, timeout=300)
    return r.returncode, r.stdout, r.stderr


def assert_one_line_error(rc, err, *names):
    """Exit status 2, no traceback, one line ``refsoft: error: ...`` naming each of ``names``;
    returns that line."""
    assert rc == 2, err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("refsoft: error: "), err
    for name in names:
        assert name in lines[0], (name, lines[0])
    return lines[0]
