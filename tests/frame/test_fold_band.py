"""The drawing of every image against the truth where the mapping folds: on the `shaving` mirror
the yellow box sits in the caustic of the camera's reflected rays and is imaged twice, the two
images meeting at a fold (spec section 4.8), and some of the floor with it.

The *multi-image band* is read off the ray-traced truth alone: the mirror pixels whose reflected
ray hits a point that a pixel more than ``APART`` pixels away also sees (its hit on the same
object within ``NEAR`` of one pixel's footprint, the farthest two samples of one surface spaced a
footprint apart can be from a point between them: along each axis the distance from its hit to the nearer of
its two neighbours' hits on that object, the larger of the two axes' distances; the nearer
neighbour, so that a tear in the mapping on one side does not widen it). There the accurate preset draws every image, the triangles across the fold cut by the
per-pixel acceptance; the paper preset's single image per vertex draws one of them across both.
Measured at 192x144 (2026-12-07): the band holds 1,735 pixels on frame 0 (the box and the floor)
and 1,424 on frame 12 (the box); the accurate preset agrees with the truth on 100.00% of both, the
paper preset on 14.1% and 45.6%. The floor is one point under the measurement."""

import numpy as np
import pytest

import refsoft
from refsoft.frame.driver import FrameDriver
from refsoft.options import RenderOptions
from refsoft.truth.raytrace import TruthRenderer

W, H = 192, 144
#: Pixels apart beyond which two pixels seeing one point are two images of it.
APART = 4.0
#: Share of a pixel's footprint within which two hits are one point.
NEAR = 0.75
FRAMES = (0, 12)
MEASURED_ACCURATE = 100.0


def multi_image_band(object_id, reflected_id, reflected_hit, mirror_id):
    """Rows, cols of the mirror's pixels that see something, and whether each lies in the band
    (module docstring), from a truth frame's arrays."""
    h, w = object_id.shape
    rows, cols = np.nonzero((object_id == mirror_id) & (reflected_id > 0))
    hit, obj = reflected_hit[rows, cols], reflected_id[rows, cols]
    footprint = np.zeros(len(rows))
    for axis in ((1, 0), (0, 1)):
        nearer = np.full(len(rows), np.inf)
        for sign in (-1, 1):
            rr, cc = rows + sign * axis[0], cols + sign * axis[1]
            inside = (rr >= 0) & (rr < h) & (cc >= 0) & (cc < w)
            rr, cc = np.clip(rr, 0, h - 1), np.clip(cc, 0, w - 1)
            d = np.linalg.norm(reflected_hit[rr, cc] - hit, axis=1)
            nearer = np.minimum(nearer, np.where(inside & (reflected_id[rr, cc] == obj), d, np.inf))
        footprint = np.maximum(footprint, np.where(np.isfinite(nearer), nearer, 0.0))
    band = np.zeros(len(rows), bool)
    for lo in range(0, len(rows), 1024):
        s = slice(lo, lo + 1024)
        near = np.linalg.norm(hit[s, None] - hit[None], axis=-1) <= NEAR * footprint[s, None]
        apart = np.hypot(rows[s, None] - rows[None], cols[s, None] - cols[None]) > APART
        band[s] = np.any(near & apart & (obj[s, None] == obj[None]), axis=1)
    return rows, cols, band


def test_the_band_finder_sees_a_point_seen_twice_and_not_a_point_seen_once():
    oid = np.ones((3, 12), np.int32)
    rid = np.full((3, 12), 2, np.int32)
    hit = np.zeros((3, 12, 3))
    hit[..., 0] = np.arange(12) * 0.1  # distinct points 0.1 apart along a row ...
    hit[..., 1] = np.arange(3)[:, None] * 0.1  # ... and along a column,
    hit[:, 9:] = hit[:, 1:4]  # columns 9-11 seeing again what columns 1-3 see (a tear at 8 | 9)
    rows, cols, band = multi_image_band(oid, rid, hit, 1)
    seen_twice = np.isin(cols, [1, 2, 3, 9, 10, 11])
    assert np.array_equal(band, seen_twice)


@pytest.fixture(scope="module")
def shaving():
    scene = refsoft.load_scene("shaving", width=W, height=H)
    mirror = 1 + [o.name for o in scene.objects].index("shaving_mirror")
    truth = TruthRenderer(scene, exact=False)
    accurate, paper = FrameDriver(scene), FrameDriver(scene, RenderOptions(preset="paper"))
    out = []
    for f in FRAMES:
        t = truth.render_frame(f).arrays
        rows, cols, band = multi_image_band(t["object_id"], t["reflected_id"], t["reflected_hit"], mirror)
        want = t["reflected_id"][rows, cols]
        got = {name: d.render_frame(f).arrays["reflected_id"][rows, cols] for name, d in
               (("accurate", accurate), ("paper", paper))}
        out.append((f, band, want, got))
    return out


def test_every_image_is_drawn_across_the_fold(shaving):
    for f, band, want, got in shaving:
        assert band.sum() >= 500, f  # the box is imaged twice on these frames
        accurate = 100 * np.mean(got["accurate"][band] == want[band])
        paper = 100 * np.mean(got["paper"][band] == want[band])
        print(f"\nframe {f}: band {band.sum()} px, accurate {accurate:.2f}%, paper {paper:.2f}%")
        assert accurate >= MEASURED_ACCURATE - 1.0, f
        assert paper <= 67.0, f  # one image per vertex gets a third of the band wrong or more: it is several images
