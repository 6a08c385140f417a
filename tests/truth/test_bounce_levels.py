"""Per-level agreement of a render with several bounces against the truth's mirror paths
(refsoft.truth.metrics.bounce_levels and the line `refsoft compare` prints)."""

import numpy as np

from refsoft.cli.commands import levels_line
from refsoft.truth.metrics import bounce_levels


def _arrays(rid, depth=None):
    out = {"reflected_id": np.asarray(rid, np.int32)}
    if depth is not None:
        out["bounce_depth"] = np.asarray(depth, np.int8)
    return out


def test_levels_count_pixels_and_disagreement_per_depth():
    truth = _arrays([[-1, 3, 3, 4], [-1, 5, 5, 0]], [[0, 1, 1, 2], [0, 2, 2, 3]])
    render = _arrays([[-1, 3, 4, 4], [-1, 5, 6, 0]], [[0, 1, 1, 2], [0, 2, 3, 3]])
    got = bounce_levels(render, truth)
    assert got["pixels"] == {"1": 2, "2": 3, "3": 1}
    assert got["disagreement"] == {"1": 0.5, "2": 1 / 3, "3": 0.0}
    assert got["depth_mismatch"] == 1 / 6


def test_one_bounce_everywhere_and_no_render_depth_gives_nothing():
    truth = _arrays([[-1, 3]], [[0, 1]])
    assert bounce_levels(_arrays([[-1, 3]]), truth) is None
    assert bounce_levels(_arrays([[-1, 3]], [[0, 1]]), truth)["depth_mismatch"] == 0.0


def test_the_line_says_when_the_render_follows_one_bounce():
    truth = _arrays([[-1, 3, 4]], [[0, 1, 2]])
    one = {"levels": bounce_levels(_arrays([[-1, 3, 5]]), truth)}
    line = levels_line([one])
    assert "1 reflection(s): 1 px, 0.00% differ" in line and "2 reflection(s): 1 px, 100.00% differ" in line
    assert "records no bounce_depth" in line
    two = {"levels": bounce_levels(_arrays([[-1, 3, 4]], [[0, 1, 2]]), truth)}
    assert "differs on 0.00% of reflector pixels" in levels_line([two])
    assert levels_line([{}]) == ""
