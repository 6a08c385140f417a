"""The restart of coherent walks that stop on the border (``border_restart``, beyond the papers):
the rule against both walks made separately, and what it mends on the ``ufo``."""

import numpy as np
import pytest

import refsoft
from refsoft.frame import FrameDriver, RenderOptions
from refsoft import constants, raster
from refsoft.search import BORDER, CULLED, RESTARTED, search
from refsoft.search.method import VertexSearch
from refsoft.truth import TruthRenderer, metrics


def _ufo_case(rng):
    """The ufo's G-buffer at its frame 59 (160x120; the saucer seen from above, whose far rim
    holds local maxima of the score), its vertices, and starts spread over the G-buffer (covered,
    uncovered and none), most on the saucer's outline."""
    scene = refsoft.load_scene("ufo", width=160, height=120)
    k = scene.reflector_ids[0]
    cam = scene.camera_at(59)
    gb = raster.gbuffer(scene.world_mesh(k, 59, proxy=True), cam, "float32", origin=cam.eye)
    verts = np.concatenate([scene.world_mesh(j, 59).vertices for j in range(1, len(scene.objects) + 1) if j != k])
    h, w = gb.mask.shape
    prev = np.stack([rng.integers(0, h, len(verts)), rng.integers(0, w, len(verts))], axis=1).astype(np.int64)
    # most starts on the outline, where walks stop on the border
    m = gb.mask
    inner = m.copy()
    inner[1:] &= m[:-1]
    inner[:-1] &= m[1:]
    inner[:, 1:] &= m[:, :-1]
    inner[:, :-1] &= m[:, 1:]
    rim = np.argwhere(m & ~inner)
    on_rim = rng.random(len(verts)) < 0.7
    prev[on_rim] = rim[rng.integers(0, len(rim), on_rim.sum())]
    prev[rng.random(len(verts)) < 0.1] = -1
    return scene, cam, gb, verts, prev


def test_the_restart_keeps_the_better_of_both_walks(rng):
    """Per vertex: the walk from its previous pixel, unless it stopped on the border (not
    restarted, not culled) with a score below BORDER_RESTART_SCORE and the walk from the start
    without history scores strictly higher; iterations of both walks when walked twice."""
    scene, cam, gb, verts, prev = _ufo_case(rng)
    opts = RenderOptions(border_restart=True)
    got = VertexSearch(scene, opts).search_vertices(gb, cam.eye, verts, prev)
    first = search(gb, cam.eye, verts, opts.neighbourhood, opts.inverse, prev, opts.cap)
    fresh = search(gb, cam.eye, verts, opts.neighbourhood, opts.inverse, None, opts.cap)
    border = ((first.flags & BORDER) != 0) & (prev[:, 0] >= 0) & ((first.flags & (CULLED | RESTARTED)) == 0)
    again = border & (first.score < constants.BORDER_RESTART_SCORE)
    take = again & (fresh.score > first.score)
    assert again.sum() > 20 and take.sum() > 5 and (again & ~take).sum() > 5  # every branch exercised
    assert (border & ~again).sum() > 5  # border walks scoring near 1, not walked again
    for name in ("pixel", "score", "margin", "flags"):
        want = np.where(take.reshape((-1,) + (1,) * (getattr(first, name).ndim - 1)), getattr(fresh, name),
                        getattr(first, name))
        np.testing.assert_array_equal(getattr(got, name), want, err_msg=name)
    np.testing.assert_array_equal(got.iterations, first.iterations + np.where(again, fresh.iterations, 0))
    # off: the walk from the previous pixel alone
    plain = VertexSearch(scene, RenderOptions(border_restart=False)).search_vertices(gb, cam.eye, verts, prev)
    np.testing.assert_array_equal(plain.pixel, first.pixel)


def test_the_restart_mends_a_walk_stopped_on_the_far_rim():
    """The ufo's frame 59 rendered after frame 44 (a frame of the accuracy benchmark's, which
    renders frames spread over the animation, each after the previous one measured): walks from
    frame 44's pixels stop on the saucer's far rim at scores near -0.5 (measured at 192x144:
    98.3% of the mirror's pixels agree with the truth; restarted, 99.4%)."""
    scene = refsoft.load_scene("ufo", width=192, height=144)
    truth = TruthRenderer(scene, exact=False).render_frame(59).arrays
    agree = {}
    for restart in (False, True):
        driver = FrameDriver(scene, RenderOptions(border_restart=restart))
        driver.render_frame(44)
        got = driver.render_frame(59).arrays
        agree[restart] = 1 - metrics.disagreement(got["reflected_id"], truth["reflected_id"])
    assert agree[True] >= agree[False] + 0.008, agree


def test_border_restart_is_refused_with_the_inverse_search():
    with pytest.raises(refsoft.RefsoftError, match="border_restart"):
        RenderOptions(border_restart=True, inverse="search")
    assert RenderOptions(preset="paper").border_restart is False
    assert RenderOptions().border_restart is True
    assert RenderOptions(inverse="search").border_restart is False  # the preset's value gives way
