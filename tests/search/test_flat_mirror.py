"""A flat mirror's exact drawing (``exact.flat_plane``, kernel ``_several.flat_bounds``): its
candidates are dilated by the pixels alone, but near its plane, and the frames are those of the
whole dilation."""

import numpy as np

from refsoft import constants, load_scene
from refsoft._parallel import one_thread, parallel_range
from refsoft.frame import FrameDriver, RenderOptions
from refsoft.scene.mesh import Mesh
from refsoft.search import exact
from refsoft.search._several import flat_bounds


def _sheet(bend=0.0, normal_tilt=0.0):
    """A 3x3 grid of vertices in the plane z = 2 x + 1 (its normals (-2, 0, 1) / sqrt 5), the
    middle vertex moved by ``bend`` along z, one normal tilted by ``normal_tilt``."""
    xs, ys = np.meshgrid([0.0, 1.0, 2.0], [0.0, 1.0, 2.0])
    v = np.stack([xs.ravel(), ys.ravel(), 2 * xs.ravel() + 1], axis=1)
    v[4, 2] += bend
    n = np.tile(np.array([-2.0, 0.0, 1.0]) / np.sqrt(5.0), (9, 1))
    n[7] += [0.0, normal_tilt, 0.0]
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    f = np.array([[0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4], [3, 4, 7], [3, 7, 6], [4, 5, 8], [4, 8, 7]])
    return Mesh(v, f, n)


def test_a_plane_is_flat_and_a_bent_one_is_not():
    normal, offset, near = exact.flat_plane(_sheet())
    assert np.allclose(normal, np.array([-2.0, 0.0, 1.0]) / np.sqrt(5.0)) and np.isclose(offset, 1 / np.sqrt(5.0))
    size = np.linalg.norm(np.array([2.0, 2.0, 4.0]))
    assert np.isclose(near, constants.EXACT_FLAT_NEAR * size)
    assert exact.flat_plane(_sheet(bend=1e-6)) is None
    assert exact.flat_plane(_sheet(normal_tilt=1e-6)) is None
    assert exact.flat_plane(load_scene("sphere", width=32, height=24).world_mesh(1)) is None
    assert exact.flat_plane(load_scene("planar", width=32, height=24).world_mesh(1)) is not None


def test_flat_bounds_dilate_by_the_pixels_alone_but_near_the_plane():
    """The kernel against NumPy: candidates with no loose corner and a usable projection get the
    dilation ``pixels`` and its bounds; the others keep theirs."""
    rng = np.random.default_rng(2)
    c, n, r0, pixels = 300, 200, 7, 1.0
    corner = rng.integers(0, n, (c, 3)).astype(np.int64)
    loose = rng.random(n) < 0.05
    screen = rng.uniform(0, 300, (c, 3, 2))
    bbox = rng.integers(-5, 400, (c, 4)).astype(np.int64)
    dilate = rng.uniform(1.0, 9.0, c)
    dilate[::11] = -1.0  # unusable projections
    want_b, want_d = bbox.copy(), dilate.copy()
    tight = (dilate >= 0) & ~loose[corner].any(axis=1)
    lo, hi = screen[tight].min(axis=1) - pixels, screen[tight].max(axis=1) + pixels
    want_b[tight] = np.stack([np.floor(lo[:, 1] - 0.5) - r0, np.ceil(hi[:, 1] - 0.5) + 1 - r0,
                              np.floor(lo[:, 0] - 0.5), np.ceil(hi[:, 0] - 0.5) + 1], axis=1).astype(np.int64)
    want_d[tight] = pixels
    assert 100 < tight.sum() < c
    for threads in (1, 2):
        got_b, got_d = bbox.copy(), dilate.copy()
        with one_thread(threads == 1):
            parallel_range(flat_bounds, c, loose, corner, screen, pixels, r0, got_b, got_d)
        assert np.array_equal(got_b, want_b) and np.array_equal(got_d, want_d)


def test_planar_frames_are_those_of_the_whole_dilation(monkeypatch):
    """The planar scene's frames drawn with the flat mirror's dilation are the same images and
    ids as with the whole dilation (each candidate tried over a quarter of its longest edge
    more), and the flat rule did shrink candidates' bounds."""
    scene = load_scene("planar", width=160, height=120)
    shrunk = []
    plain = exact.flat_bounds

    def counted(fn, n, loose, corner, *rest, **kw):
        shrunk.append(int(n - np.count_nonzero(loose[corner].any(axis=1))))
        return parallel_range(fn, n, loose, corner, *rest, **kw)

    monkeypatch.setattr(exact, "parallel_range", lambda fn, n, *a, **k: counted(fn, n, *a, **k) if fn is plain
                        else parallel_range(fn, n, *a, **k))
    flat = [FrameDriver(scene, RenderOptions()).render_frame(f).arrays for f in (3, 17)]
    assert sum(shrunk) > 100
    monkeypatch.setattr(exact, "flat_plane", lambda mesh: None)
    whole = [FrameDriver(scene, RenderOptions()).render_frame(f).arrays for f in (3, 17)]
    for a, b in zip(flat, whole):
        assert np.array_equal(a["image"], b["image"]) and np.array_equal(a["reflected_id"], b["reflected_id"])
