"""Atomic writes: every output is written under a temporary name in the same folder, then renamed,
so an interrupted run never leaves a torn file and never damages an existing one."""

from __future__ import annotations

import json
import os
import tempfile
from contextlib import contextmanager

import numpy as np


#: Temporary files being written (removed by :func:`remove_temporaries` on a hard exit).
_ACTIVE = set()


@contextmanager
def atomic_path(path, suffix=""):
    """Yield a temporary path next to ``path``; rename it to ``path`` if the block succeeds."""
    path = os.fspath(path)
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(path) + ".", suffix=".tmp" + suffix, dir=folder)
    _ACTIVE.add(tmp)
    os.close(fd)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; outputs get the usual permissions
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
        _ACTIVE.discard(tmp)


def remove_temporaries() -> None:
    """Remove the temporary files of writes in progress (before leaving without finishing them)."""
    for tmp in list(_ACTIVE):
        try:
            os.unlink(tmp)
        except OSError:
            pass


def write_npz(path, **arrays):
    """``np.savez_compressed`` to ``path`` atomically (zlib's default level, 6)."""
    with atomic_path(path, ".npz") as tmp:
        np.savez_compressed(tmp, **arrays)


def write_json(path, data):
    """Write JSON (indented, keys in order) atomically."""
    with atomic_path(path) as tmp:
        with open(tmp, "w") as fh:
            json.dump(data, fh, indent=1)
            fh.write("\n")
