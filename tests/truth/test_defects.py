"""Specks and holes (one-pixel defects of colour and of reflected object) on hand-made images with
defects placed by the test, at the image's border and the mirror's rim, and against a per-pixel
loop that states the definition."""

import numpy as np
import pytest

from refsoft import RefsoftError
from refsoft.constants import SPECK_LEVELS, SPECK_NEIGHBOUR_LEVELS
from refsoft.truth.metrics import defect_counts, holes, specks


def loop_defects(bad, good):
    """The definition, pixel by pixel: bad, and both row neighbours good or both column neighbours
    good (a neighbour outside the image is not good)."""
    h, w = bad.shape

    def ok(r, c):
        return 0 <= r < h and 0 <= c < w and good[r, c]

    out = np.zeros_like(bad)
    for r in range(h):
        for c in range(w):
            out[r, c] = bad[r, c] and ((ok(r, c - 1) and ok(r, c + 1)) or (ok(r - 1, c) and ok(r + 1, c)))
    return out


def scene(h=12, w=16):
    """A truth image, its reflected_id (a mirror of two objects' reflections inside a frame of
    non-mirror pixels) and a render equal to it."""
    rng = np.random.default_rng(0)
    img = rng.integers(40, 200, (h, w, 3)).astype(np.uint8)
    tid = np.full((h, w), -1, np.int32)
    tid[1:h - 1, 1:w - 1] = 2
    tid[1:h - 1, w // 2:w - 1] = 3
    return img, tid, img.copy(), tid.copy()


def test_specks_placed_by_hand_are_counted():
    truth, tid, render, rid = scene()
    bump = lambda r, c, d: render.__setitem__((r, c, 1), truth[r, c, 1] + d)  # noqa: E731
    bump(5, 4, SPECK_LEVELS + 1)      # a speck
    bump(3, 3, SPECK_LEVELS)          # not enough off: no speck
    bump(8, 10, SPECK_LEVELS + 10)    # a speck whose row neighbour is off a little: still one by its column
    bump(8, 11, SPECK_NEIGHBOUR_LEVELS + 1)
    for r, c in ((4, 12), (4, 13), (5, 12), (5, 13)):  # a 2x2 block: no pixel has a good pair
        bump(r, c, 60)
    bump(1, 6, 50)                    # on the mirror's rim: its row neighbours are on the mirror, a speck
    bump(10, 1, 50)                   # a mirror corner: no pair on the mirror either way, no speck
    m = specks(render, truth, tid)
    assert sorted(zip(*np.nonzero(m))) == [(1, 6), (5, 4), (8, 10)]
    c = defect_counts({"image": render, "reflected_id": rid}, {"image": truth, "reflected_id": tid})
    assert c["specks"] == 3 and c["holes"] == 0
    assert c["speck_fraction"] == pytest.approx(3 / (tid >= 0).sum())


def test_specks_at_the_image_border():
    truth, _, render, _ = scene()
    tid = np.zeros(truth.shape[:2], np.int32)  # the mirror fills the image
    for r, c in ((0, 0), (0, 5), (7, 15), (11, 15)):
        render[r, c, 0] = 255 - truth[r, c, 0] // 8  # far off in the first channel
    m = specks(render, truth, tid)
    # a corner has no pair of neighbours; a border pixel has the pair along the border
    assert sorted(zip(*np.nonzero(m))) == [(0, 5), (7, 15)]


def test_holes_placed_by_hand_are_counted():
    _, tid, _, rid = scene()
    rid[5, 4] = 3          # the wrong object: a hole
    rid[6, 9] = 0          # nothing instead of object 3: a hole
    rid[8, 2] = 3          # a pair along a row: each has good column neighbours, two holes
    rid[8, 3] = 3
    rid[2:4, 12:14] = 0    # a 2x2 block: none
    rid[10, 7] = 3         # on the rim between the objects and the frame: column neighbour off the mirror,
    # row neighbours (10, 6) right and (10, 8) right: a hole
    rid[1, 1] = 0          # a mirror corner: none
    m = holes(rid, tid)
    assert sorted(zip(*np.nonzero(m))) == [(5, 4), (6, 9), (8, 2), (8, 3), (10, 7)]
    c = defect_counts({"image": np.zeros(tid.shape + (3,), np.uint8), "reflected_id": rid},
                      {"image": np.zeros(tid.shape + (3,), np.uint8), "reflected_id": tid})
    assert c["holes"] == 5 and c["specks"] == 0 and c["hole_fraction"] == pytest.approx(5 / (tid >= 0).sum())


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_masks_equal_the_definition_pixel_by_pixel(seed):
    rng = np.random.default_rng(seed)
    h, w = 17, 23
    truth = rng.integers(0, 256, (h, w, 3)).astype(np.uint8)
    noise = rng.choice([0, 5, 9, 31, 80], size=(h, w, 3), p=[0.6, 0.1, 0.1, 0.1, 0.1])
    render = np.clip(truth.astype(int) + noise * rng.choice([-1, 1], (h, w, 3)), 0, 255).astype(np.uint8)
    tid = rng.choice([-1, 1, 2], size=(h, w), p=[0.2, 0.4, 0.4]).astype(np.int32)
    rid = np.where(rng.random((h, w)) < 0.15, rng.choice([-1, 0, 1, 2], size=(h, w)), tid).astype(np.int32)
    mirror = tid >= 0
    d = np.abs(render.astype(int) - truth.astype(int)).max(axis=-1)
    want_s = loop_defects(mirror & (d > SPECK_LEVELS), mirror & (d <= SPECK_NEIGHBOUR_LEVELS))
    want_h = loop_defects(mirror & (rid != tid), mirror & (rid == tid))
    assert want_s.sum() > 3 and want_h.sum() > 3
    assert np.array_equal(specks(render, truth, tid), want_s)
    assert np.array_equal(holes(rid, tid), want_h)


def test_bad_inputs():
    img = np.zeros((4, 5, 3), np.uint8)
    with pytest.raises(RefsoftError, match="uint8"):
        specks(img.astype(np.float32), img, np.zeros((4, 5), np.int32))
    with pytest.raises(RefsoftError, match="differ"):
        specks(img, img[:3], np.zeros((4, 5), np.int32))
    with pytest.raises(RefsoftError, match="shapes differ"):
        holes(np.zeros((4, 5), np.int32), np.zeros((4, 6), np.int32))
