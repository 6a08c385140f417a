"""The oracle's own bits, guarded: the SHA-256 of every array of the golden set, committed in
``tests/conformance/golden_hashes.json`` and compared by ``tests/conformance/test_golden_hashes.py``.

A NumPy, Numba or llvmlite release (or a change of refsoft) that changes one bit of one output
then fails the test suite, naming the arrays, instead of changing the port authors' reference
silently. Arrays are hashed rather than the ``.npz`` files, whose bytes also depend on zlib;
the other files of the set (traces, inputs) are written byte for byte by refsoft and are hashed
whole.

When a change of outputs is meant, regenerate the file on purpose, in the commit that changes
them, with the reason in the commit message::

    python tests/golden_hashes.py            # writes tests/conformance/golden_hashes.json
"""

from __future__ import annotations

import hashlib
import json
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
HASHES = os.path.join(HERE, "conformance", "golden_hashes.json")
FORMAT = "refsoft-golden-hashes-1"


def array_digest(a) -> str:
    """SHA-256 of an array's dtype, shape and C-order bytes."""
    a = np.ascontiguousarray(a)
    h = hashlib.sha256(f"{a.dtype.str}{a.shape}".encode("ascii"))
    h.update(a.tobytes())
    return h.hexdigest()


def golden_hashes(golden) -> dict:
    """``{"CASE/FILE.npz:ARRAY": sha, "CASE/FILE.json": sha, ..., "manifest.json:cases": sha}``
    for every file a golden set's manifest lists (sorted keys)."""
    golden = os.fspath(golden)
    with open(os.path.join(golden, "manifest.json")) as fh:
        manifest = json.load(fh)
    out = {"manifest.json:cases": hashlib.sha256(json.dumps(manifest["cases"], sort_keys=True).encode()).hexdigest()}
    for rel in manifest["files"]:
        path = os.path.join(golden, *rel.split("/"))
        if rel.endswith(".npz"):
            with np.load(path, allow_pickle=False) as z:
                for name in z.files:
                    out[f"{rel}:{name}"] = array_digest(z[name])
        else:
            with open(path, "rb") as fh:
                out[rel] = hashlib.sha256(fh.read()).hexdigest()
    return dict(sorted(out.items()))


def read_hashes(path=HASHES) -> dict:
    with open(path) as fh:
        data = json.load(fh)
    if data.get("format") != FORMAT:
        raise ValueError(f"{path}: not a {FORMAT} file")
    return data


def write_hashes(golden, path=HASHES) -> dict:
    """Hash the golden set in ``golden`` into ``path`` (with the versions that made it)."""
    import numba

    import refsoft

    data = {"format": FORMAT, "refsoft": refsoft.__version__, "numpy": np.__version__, "numba": numba.__version__,
            "hashes": golden_hashes(golden)}
    tmp = path + ".tmp"
    with open(tmp, "w") as fh:
        json.dump(data, fh, indent=1)
        fh.write("\n")
    os.replace(tmp, path)
    return data


def differences(expected: dict, observed: dict) -> list:
    """Lines naming every entry that is missing, new or different (empty when the two agree)."""
    lines = [f"missing: {k}" for k in expected if k not in observed]
    lines += [f"new: {k}" for k in observed if k not in expected]
    lines += [f"changed: {k}" for k in expected if k in observed and expected[k] != observed[k]]
    return lines


def main(argv=None):
    import tempfile

    from refsoft.conformance.golden import write_golden

    argv = sys.argv[1:] if argv is None else argv
    path = argv[0] if argv else HASHES
    with tempfile.TemporaryDirectory() as tmp:
        write_golden(tmp, progress=True)
        data = write_hashes(tmp, path)
    print(f"{path}: {len(data['hashes'])} hashes (numpy {data['numpy']}, numba {data['numba']})")


if __name__ == "__main__":
    main()
