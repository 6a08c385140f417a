"""``refsoft bench accuracy`` reports each frame's specks and holes, as ``refsoft compare`` counts
them, in its CSV and its table."""

import csv

import numpy as np

from refsoft.bench.accuracy import accuracy
from refsoft.bench._common import task_scene, plan_scene
from refsoft.frame import FrameDriver
from refsoft.options import RenderOptions
from refsoft.truth.metrics import defect_counts
from refsoft.truth.raytrace import render_truth


def test_the_csv_and_the_table_hold_specks_and_holes(tmp_path):
    # the paper preset: the accurate one draws the reflection exactly and leaves none of either
    rows = accuracy(["quad"], tmp_path, sizes=[(96, 72)], frames=1, settings=["paper"], timing=False)
    with open(tmp_path / "accuracy.csv") as f:
        got = list(csv.DictReader(f))
    assert len(got) == len(rows) == 1
    # the same counts from a render and a truth made here
    scene = task_scene(plan_scene("quad", 96, 72)[1], 96, 72)
    fr = FrameDriver(scene, RenderOptions(preset="paper")).render_frame(0)
    truth, _ = render_truth(scene, frames=[0])
    want = defect_counts(fr.arrays, truth[0].arrays)
    assert int(got[0]["specks"]) == want["specks"] and int(got[0]["holes"]) == want["holes"]
    assert np.isclose(float(got[0]["hole_fraction"]), want["hole_fraction"])
    assert want["specks"] + want["holes"] > 0  # the quad in a ball at this size has some of either
    table = (tmp_path / "accuracy.md").read_text()
    assert "| specks | holes |" in table
