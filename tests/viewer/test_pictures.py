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


def _dark_runs(block):
    """Runs of consecutive rows of ``block`` holding dark (text) pixels: [(first, last), ...]."""
    rows = np.flatnonzero((block < 80).all(axis=-1).any(axis=1))
    runs = []
    for r in rows:
        if runs and r == runs[-1][1] + 1:
            runs[-1][1] = r
        else:
            runs.append([r, r])
    return runs


def test_row_label_sits_below_the_title(walk_replay):
    tr, mask = walk_replay.trace, walk_replay.gbuffer.mask
    plain = pictures.trace_picture(tr, mask)
    for big in (pictures.trace_picture(tr, mask, labelled=True, replay=walk_replay),
                pictures.trace_frames(tr, mask, labelled=True)[1]):
        at = _contains(big, plain if big.shape[0] > plain.shape[0] + 60 else plain)
        at = at or _contains(big, pictures.trace_frames(tr, mask)[1])
        # the words above the picture at the left: the title (and the step line), then "row", apart
        runs = _dark_runs(big[: at[0] - 1, :40])
        assert len(runs) >= 2 and runs[-1][0] > runs[-2][1] + 1


def test_inverse_search_gets_a_second_panel_with_its_path_visible(inverse_replay):
    tr, mask = inverse_replay.trace, inverse_replay.gbuffer.mask
    std = pictures._standard_panel(tr, mask, 512)[0].shape
    inv, r0, c0, zoom = pictures._inverse_panel(tr, mask, 512)
    both = pictures.trace_picture(tr, mask, labelled=True, replay=inverse_replay)
    at = _contains(both, inv)
    assert at is not None and at[1] > std[1]  # right of the standard panel
    cyan = np.all(inv == pictures._PATH["inverse"], axis=-1).sum()
    n_inv = sum(s["phase"] == "inverse" for s in tr.steps)
    assert cyan >= 4 * 2 * (zoom // 4) * n_inv  # drawn, not hidden under the end marker
    # the panel's colours are the inverse score field's, not the standard one's
    field = pictures.colour_scores(tr.inverse_map, mask)
    r1, c1 = r0 + inv.shape[0] // zoom, c0 + inv.shape[1] // zoom
    centres = inv[zoom // 2::zoom, zoom // 2::zoom]
    assert np.mean(np.all(centres == field[r0:r1, c0:c1], axis=-1)) > 0.8


def test_gif_inverse_frames_are_drawn_on_the_inverse_field(inverse_replay):
    tr, mask = inverse_replay.trace, inverse_replay.gbuffer.mask
    frames = pictures.trace_frames(tr, mask)
    std, r0, c0, zoom = pictures._setup(tr, mask, 384)
    inv = pictures._setup(tr, mask, 384, tr.inverse_map)[0]
    big = {k: np.repeat(np.repeat(b, zoom, 0), zoom, 1) for k, b in (("standard", std), ("inverse", inv))}
    n = len(tr.steps)
    picks = np.unique(np.linspace(0, n - 1, min(n, 150)).round().astype(int))
    for frame, k in zip(frames, picks):
        phase = tr.steps[k]["phase"]
        other = "standard" if phase == "inverse" else "inverse"
        same = np.all(frame == big[phase], axis=-1).mean()
        assert same > 0.8 and same > np.all(frame == big[other], axis=-1).mean()


def test_gif_colours_are_the_same_in_every_frame(inverse_replay, tmp_path):
    import imageio.v3 as iio

    tr, mask = inverse_replay.trace, inverse_replay.gbuffer.mask
    frames = pictures.trace_frames(tr, mask, size=200, max_frames=12, labelled=True)
    pictures.write_trace_gif(tmp_path / "t.gif", frames)
    decoded = iio.imread(tmp_path / "t.gif")[..., :3]
    pal = {tuple(c) for c in pictures.gif_palette()}
    legend = [tuple(int(v) for v in rgb) for rgb, _ in pictures._legend(tr)] + [(255, 220, 0), (255, 140, 0)]
    for f in decoded:
        assert {tuple(c) for c in np.unique(f.reshape(-1, 3), axis=0)} <= pal
        for rgb in legend:  # each legend swatch in its exact colour in every frame
            assert np.all(f == rgb, axis=-1).sum() >= 81  # at least the 9x9 inside of its swatch
    # the colour bar's ramp (14 pixels wide, right of the picture): the same pixels in every frame
    x0 = 48 + pictures.trace_frames(tr, mask, size=200, max_frames=12)[0].shape[1] + 14
    bars = [f[26 + 20 + 16 + 16:26 + 20 + 16 + 16 + 120, x0:x0 + 14] for f in decoded]  # below its label
    assert len(np.unique(bars[0].reshape(-1, 3), axis=0)) > 40
    assert all(np.array_equal(bars[0], b) for b in bars)


def test_several_images_are_all_circled(walk_replay):
    tr, mask = walk_replay.trace, walk_replay.gbuffer.mask
    other = [int(v) for v in np.argwhere(mask)[len(np.argwhere(mask)) // 3]]
    images = [tr.pixel, other]
    pic = pictures.trace_picture(tr, mask, images=images)
    r0, _, c0, _ = pictures._crop(mask)
    zoom = pictures._setup(tr, mask, 512)[3]
    ring = np.all(pic == pictures._RING, axis=-1)
    for r, c in images:
        cy, cx = (r - r0) * zoom + zoom // 2, (c - c0) * zoom + zoom // 2
        rad = max(zoom, 7)
        assert ring[cy - rad - 2:cy + rad + 3, cx - rad - 2:cx + rad + 3].sum() >= 2 * rad
    labelled = pictures.trace_picture(tr, mask, labelled=True, images=images)
    assert np.all(labelled == pictures._RING, axis=-1).sum() > ring.sum()  # and a legend swatch
    assert not np.any(np.all(pictures.trace_picture(tr, mask, images=[tr.pixel]) == pictures._RING, axis=-1))


def test_hierarchy_picture_crops_keys_every_level_and_rings_the_choice(hierarchy_replay):
    tr, mask = hierarchy_replay.trace, hierarchy_replay.gbuffer.mask
    plain = pictures.hierarchy_picture(tr, mask)
    r0, r1, c0, c1 = pictures._crop(mask)
    zoom = plain.shape[0] // (r1 - r0)
    assert plain.shape[:2] == ((r1 - r0) * zoom, (c1 - c0) * zoom)
    popped = {s["level"] for s in tr.steps if s["event"] == "popped"}
    shown = {lv for lv in range(tr.levels) if np.any(np.all(plain == pictures._LEVELS[lv], axis=-1))}
    assert shown <= popped and min(popped) in shown  # the finest level popped is never covered over
    # the chosen pixel: a red ring around it, its own pixel not painted over
    r, c = tr.pixel
    cy, cx = (r - r0) * zoom + zoom // 2, (c - c0) * zoom + zoom // 2
    red = np.all(plain == pictures._END, axis=-1)
    assert red.sum() > 20 and not red[cy, cx]
    big = pictures.hierarchy_picture(tr, mask, labelled=True, replay=hierarchy_replay)
    at = _contains(big, plain)
    below = big[at[0] + plain.shape[0]:]
    for lv in range(tr.levels):  # a key per level, in the colour the picture uses
        assert np.any(np.all(below == pictures._LEVELS[lv], axis=-1))
    assert np.any(np.all(below == pictures._END, axis=-1))
