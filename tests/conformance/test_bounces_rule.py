"""`refsoft check`'s rule of several bounces (refsoft/conformance/rules/bounces.py): the golden
case of mirrors that see each other holds `bounce_depth`, the oracle passes against itself, a
changed depth away from a level's outline fails and one beside it is accepted, and a port that
declares the kind ``bounces`` not ported passes with the first bounce drawn."""

import json
import shutil

import numpy as np

from refsoft import keys
from refsoft.conformance.check import check
from refsoft.conformance.rules.bounces import beside_a_change
from refsoft.io import write_npz

CASE = "mirrors_bounces"


def _copy(golden, tmp_path, mutate=None):
    cand = tmp_path / "cand"
    cand.mkdir(parents=True, exist_ok=True)
    shutil.copytree(golden / CASE, cand / CASE)
    for f in (cand / CASE).glob("traces_*.json"):
        f.unlink()
    for f in sorted((cand / CASE).glob("frame_*.npz")):
        if mutate is not None:
            with np.load(f) as z:
                arrays = {k: z[k] for k in z.files}
            mutate(arrays, f.name)
            write_npz(f, **arrays)
    return cand


def _status(s, key):
    return {f.status for f in s["_findings"] if f.key == key}


def test_the_case_holds_three_levels_and_passes_against_itself(golden, tmp_path):
    with np.load(golden / CASE / "frame_0000.npz") as z:
        assert set(np.unique(z[keys.BOUNCE_DEPTH])) == {0, 1, 2, 3}
    s = check(golden, _copy(golden, tmp_path), cases=[CASE])
    assert s["passed"] and _status(s, keys.BOUNCE_DEPTH) == {"pass"}


def test_a_changed_depth_fails_away_from_an_outline_and_is_accepted_beside_one(golden, tmp_path):
    with np.load(golden / CASE / "frame_0000.npz") as z:
        depth = z[keys.BOUNCE_DEPTH]
    edge = beside_a_change(depth)
    inner = np.argwhere((depth == 2) & ~edge)[0]
    outline = np.argwhere((depth == 2) & edge)[0]

    def at(pixel):
        def mutate(a, name):
            if name == "frame_0000.npz":
                a[keys.BOUNCE_DEPTH][tuple(pixel)] = 3
        return mutate

    s = check(golden, _copy(golden, tmp_path / "a", at(inner)), cases=[CASE])
    assert not s["passed"] and "fail" in _status(s, keys.BOUNCE_DEPTH)
    s = check(golden, _copy(golden, tmp_path / "b", at(outline)), cases=[CASE])
    assert s["passed"] and _status(s, keys.BOUNCE_DEPTH) == {"accepted", "pass"}


def test_a_port_of_one_bounce_says_so(golden, tmp_path):
    def one_bounce(a, name):
        del a[keys.BOUNCE_DEPTH]
        a[keys.REFLECTED_ID][a[keys.REFLECTED_ID] > 0] = 1  # not the oracle's (not judged)

    cand = _copy(golden, tmp_path, one_bounce)
    s = check(golden, cand, cases=[CASE])
    assert not s["passed"] and "missing" in _status(s, keys.BOUNCE_DEPTH)
    (cand / "ported.json").write_text(json.dumps({"format": "refsoft-ported-1",
                                                   "not_ported": {"kinds": ["bounces"]}}))
    s = check(golden, cand, cases=[CASE])
    assert s["passed"] and _status(s, keys.BOUNCE_DEPTH) == {"not_ported"}
    assert _status(s, keys.REFLECTED_ID) == {"not_ported"} and _status(s, keys.IMAGE) == {"not_ported"}
    assert _status(s, keys.REFLECTION_PIXEL(1)) == {"pass"}  # the first level is judged as ever


def test_beside_a_change():
    d = np.zeros((5, 5), np.int8)
    d[2, 2] = 2
    got = beside_a_change(d)
    assert got.sum() == 9 and got[1:4, 1:4].all()
