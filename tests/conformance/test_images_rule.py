"""`refsoft check`'s rule of the per-image arrays (refsoft/conformance/rules/images.py): the
golden cases on mirrors that are not convex hold them, the oracle passes against itself, a
changed count, pixel or virtual vertex is flagged, and a port that declares the kind ``images``
not ported passes without them (and without the flag SEVERAL)."""

import json
import shutil

import numpy as np
import pytest

from refsoft import keys
from refsoft.conformance.check import check
from refsoft.io import write_npz
from refsoft.search import SEVERAL

CASES = ["concave_accurate", "torus_accurate"]


def _copy(golden, tmp_path, case, mutate=None, frame=0):
    cand = tmp_path / "cand"
    cand.mkdir(parents=True, exist_ok=True)
    shutil.copytree(golden / case, cand / case)
    for f in (cand / case).glob("traces_*.json"):
        f.unlink()
    if mutate is not None:
        path = cand / case / f"frame_{frame:04d}.npz"
        with np.load(path) as z:
            arrays = {k: z[k] for k in z.files}
        mutate(arrays)
        write_npz(path, **arrays)
    return cand


def _status(s, key):
    return {f.status for f in s["_findings"] if f.key == key}


@pytest.mark.parametrize("case", CASES)
def test_golden_cases_hold_the_images_and_pass_against_themselves(golden, tmp_path, case):
    with np.load(golden / case / "frame_0000.npz") as z:
        count = z[keys.IMAGE_COUNT(1)]
        assert (count > 1).any() and len(z[keys.IMAGE_PIXEL(1)]) == count.sum()
        assert np.array_equal((z[keys.FLAGS(1)] & SEVERAL) != 0, count > 1)
    s = check(golden, _copy(golden, tmp_path, case), cases=[case])
    assert s["passed"] and {f.kind for f in s["_findings"]} >= {"images"}
    assert all(f.status == "pass" for f in s["_findings"] if f.kind == "images")


def _drop_image(a):
    """The first vertex with two images loses its second."""
    count = a[keys.IMAGE_COUNT(1)]
    i = int(np.flatnonzero(count > 1)[0])
    row = int(count[:i].sum()) + 1
    count[i] -= 1
    for name in (keys.IMAGE_VERTEX, keys.IMAGE_PIXEL, keys.IMAGE_VIRTUAL, keys.IMAGE_SHEET):
        a[name(1)] = np.delete(a[name(1)], row, axis=0)


def test_mutations_are_flagged(golden, tmp_path):
    case = "concave_accurate"
    s = check(golden, _copy(golden, tmp_path / "a", case, _drop_image), cases=[case])
    assert not s["passed"] and "fail" in _status(s, keys.IMAGE_COUNT(1))

    def move(a):
        a[keys.IMAGE_PIXEL(1)][-1, 1] += 1

    s = check(golden, _copy(golden, tmp_path / "b", case, move), cases=[case])
    assert not s["passed"] and "fail" in _status(s, keys.IMAGE_PIXEL(1))

    def nudge(a, ulps=None):
        v = a[keys.IMAGE_VIRTUAL(1)]
        v[0] = v[0] + np.float32(1e-2) if ulps is None else v[0] + ulps * np.spacing(np.abs(v[0]))

    s = check(golden, _copy(golden, tmp_path / "c", case, nudge), cases=[case])
    assert not s["passed"] and "fail" in _status(s, keys.IMAGE_VIRTUAL(1))
    s = check(golden, _copy(golden, tmp_path / "d", case, lambda a: nudge(a, 2)), cases=[case])
    assert _status(s, keys.IMAGE_VIRTUAL(1)) == {"accepted", "pass"}  # frame 0 nudged, frame 1 not


def test_a_port_without_images_says_so(golden, tmp_path):
    case = "torus_accurate"

    def strip(a):
        for name in keys.IMAGE_ARRAYS:
            del a[name(1)]
        a[keys.FLAGS(1)] = a[keys.FLAGS(1)] & ~np.uint8(SEVERAL)

    cand = _copy(golden, tmp_path, case, strip)
    for f in (cand / case).glob("frame_*.npz"):
        if f.name != "frame_0000.npz":
            with np.load(f) as z:
                a = {k: z[k] for k in z.files}
            strip(a)
            write_npz(f, **a)
    s = check(golden, cand, cases=[case])
    assert not s["passed"] and "missing" in _status(s, keys.IMAGE_COUNT(1))
    (cand / "ported.json").write_text(json.dumps({"format": "refsoft-ported-1", "not_ported": {"kinds": ["images"]}}))
    s = check(golden, cand, cases=[case])
    assert s["passed"] and _status(s, keys.IMAGE_COUNT(1)) == {"not_ported"}
    assert _status(s, keys.FLAGS(1)) == {"pass"}
