"""The task store: a result is reused only for the same key, refsoft version and sources; a
stored file that does not match its name is computed again."""

import os
import shutil

import numpy as np

import refsoft
from refsoft.bench import tasks as T
from refsoft.bench.tasks import Task, run_tasks

CALLS = []


def counted(x, scale):
    """A task that records each call (serial runs call it in this process)."""
    CALLS.append(x)
    return {"y": x * scale, "arr": np.arange(3, dtype=np.float32) * x}


def _tasks(options):
    return [Task({"x": x, "options": options}, counted, (x, options["scale"]), label=f"x={x}") for x in (1, 2, 3)]


def test_same_key_reused_other_options_versions_or_sources_not(tmp_path, monkeypatch):
    store = tmp_path / "tasks"
    CALLS.clear()
    first = run_tasks(_tasks({"scale": 2}), store=store)
    assert (first.reused, first.computed, CALLS) == (0, 3, [1, 2, 3])
    again = run_tasks(_tasks({"scale": 2}), store=store)
    assert (again.reused, again.computed, CALLS) == (3, 0, [1, 2, 3])
    assert [r["y"] for r in again.results] == [2, 4, 6]
    np.testing.assert_array_equal(again.results[2]["arr"], first.results[2]["arr"])
    assert again.results[2]["arr"].dtype == np.float32

    other = run_tasks(_tasks({"scale": 5}), store=store)  # other options: a different key
    assert (other.reused, other.computed) == (0, 3) and [r["y"] for r in other.results] == [5, 10, 15]

    monkeypatch.setattr(refsoft, "__version__", refsoft.__version__ + ".other")
    newer = run_tasks(_tasks({"scale": 2}), store=store)
    assert (newer.reused, newer.computed) == (0, 3)
    monkeypatch.undo()

    monkeypatch.setattr(T, "_CODE", "0" * 64)  # other sources, same version
    edited = run_tasks(_tasks({"scale": 2}), store=store)
    assert (edited.reused, edited.computed) == (0, 3)
    monkeypatch.undo()

    import numba

    monkeypatch.setattr(numba, "__version__", numba.__version__ + ".other")  # may round differently
    assert run_tasks(_tasks({"scale": 2}), store=store).computed == 3
    monkeypatch.undo()
    assert run_tasks(_tasks({"scale": 2}), store=store).reused == 3  # the first results, still there


def test_misnamed_damaged_and_torn_files_are_computed_again(tmp_path):
    store = tmp_path / "tasks"
    CALLS.clear()
    run_tasks(_tasks({"scale": 2}), store=store)
    ident = T.identity()
    d = [T.task_digest(t, ident) for t in _tasks({"scale": 2})]
    st = T.Store(store)
    shutil.copy(st.path(d[0]), st.path(d[1]))  # task 1's name, task 0's result
    with open(st.path(d[2]), "r+b") as fh:  # damaged
        fh.truncate(40)
    open(os.path.join(store, ".x.npz.tmp123"), "wb").close()  # what a killed writer leaves
    CALLS.clear()
    r = run_tasks(_tasks({"scale": 2}), store=store)
    assert (r.reused, r.computed, CALLS) == (1, 2, [2, 3])
    assert [x["y"] for x in r.results] == [2, 4, 6]
    assert not [n for n in os.listdir(store) if ".tmp" in n]
    assert run_tasks(_tasks({"scale": 2}), store=store).reused == 3


def test_fresh_computes_everything_again(tmp_path):
    store = tmp_path / "tasks"
    run_tasks(_tasks({"scale": 2}), store=store)
    CALLS.clear()
    r = run_tasks(_tasks({"scale": 2}), store=store, fresh=True)
    assert (r.reused, r.computed, CALLS) == (0, 3, [1, 2, 3])


def test_estimate_bounds():
    from refsoft.bench.report import estimate

    e = {r["workers"]: r for r in estimate([4.0, 1.0, 1.0, 2.0], workers=(1, 2, 8))}
    assert e[1]["at_least"] == 8.0 and e[1]["at_most"] == 8.0
    assert e[2]["at_least"] == 4.0 and e[2]["at_most"] == 8.0
    assert e[8]["at_least"] == 4.0 and e[8]["at_most"] == 5.0
