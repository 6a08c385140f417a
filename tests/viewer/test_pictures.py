"""The static pictures explain themselves: trace.png and every GIF frame carry the picture
unchanged inside a title, axes, a colour bar and a legend; each GIF frame says its step."""

import numpy as np

from refsoft.search import pictures


def _contains(big, small):
    """Where ``small`` sits in ``big`` unchanged, or None."""
    h, w = small.shape[:2]
    ys, xs = np.nonzero(np.all(big[: big.shape[0] - h + 1, : big.shape[1] - w + 1] == small[0, 0], axis=-1))
    for y, x in zip(ys, xs):
        if np.array_equal(big[y:y + h, x:x + w], small):
            return y, x
    return None


def test_labelled_picture_holds_the_plain_one_and_a_colour_bar(walk_replay):
    tr, mask = walk_replay.trace, walk_replay.gbuffer.mask
    plain = pictures.trace_picture(tr, mask)
    big = pictures.trace_picture(tr, mask, labelled=True, replay=walk_replay)
    at = _contains(big, plain)
    assert at is not None and at[0] >= 20 and at[1] >= 20  # room for the title and the row axis
    right = big[:, at[1] + plain.shape[1]:]
    # the colour bar: the ramp's two ends, to the right of the picture
    for end in (pictures._RAMP[0], pictures._RAMP[-1]):
        assert np.any(np.all(right == end.astype(np.uint8), axis=-1))
    below = big[at[0] + plain.shape[0]:]
    assert np.any(np.all(below == [40, 220, 60], axis=-1)) and np.any(np.all(below == [230, 30, 30], axis=-1))
    # words are drawn: dark text pixels above the picture and beside the axes
    assert (big[: at[0]] < 80).all(axis=-1).sum() > 50 and (big[:, : at[1]] < 80).all(axis=-1).sum() > 50


def test_each_gif_frame_says_its_step(walk_replay):
    tr, mask = walk_replay.trace, walk_replay.gbuffer.mask
    plain = pictures.trace_frames(tr, mask)
    framed = pictures.trace_frames(tr, mask, labelled=True)
    assert len(framed) == len(plain) and len({f.shape for f in framed}) == 1
    at = _contains(framed[0], plain[0])
    assert at is not None
    headers = [f[: at[0]] for f in framed]
    for a, b in zip(headers, headers[1:]):
        assert not np.array_equal(a, b)  # the step and score written above differ from frame to frame
    for f, p in zip(framed, plain):
        assert np.array_equal(f[at[0]:at[0] + p.shape[0], at[1]:at[1] + p.shape[1]], p)


def test_ticks_are_round_and_inside():
    for lo, hi in ((0.0, 3.45), (37.0, 91.0), (0.0, 1e-3)):
        t = pictures._ticks(lo, hi)
        assert 2 <= len(t) <= 11 and all(lo - 1e-9 <= v <= hi + 1e-9 for v in t)
        steps = np.diff(t)
        assert np.allclose(steps, steps[0])
        mant = steps[0] / 10 ** np.floor(np.log10(steps[0]))
        assert any(np.isclose(mant, m) for m in (1, 2, 5, 10))
