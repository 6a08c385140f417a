"""The enumeration of every reflection point (refsoft.search.images.find_images) against the exact
reflection points seen from inside a sphere (Alhazen's problem, up to four per vertex:
refsoft.truth.analytic.sphere_inside_reflection_points), on the G-buffer of a sphere's inside at
160x120, over the vertices whose exact images in the view lie more than 2 pixels apart and more
than 2 pixels from the view's border, and whose exact count does not change when the vertex
moves by 0.001 along an axis (a vertex beside a fold of the mapping, where two images are born
together, has a reflected ray passing within a fraction of a millimetre of it that the mesh's
facets and float32 can turn into two images or none: one such vertex, 0.2 mm from a fold, gives
two images at 160x120).

The goals are: the count of images found equals the exact count for 99.9% of those vertices, and
every image found lies within 1 pixel of an exact point's projection. Measured (these fixtures,
2026-12-07, Newton's iteration from each maximum and from the walk's pixel): counts agree on
99.97% at 160x120 (one vertex one image short: its iteration leaves the reach), 100% at 320x240
and 640x480 (the script of docs/several.md); every image lies within 0.90 pixels of an exact
point at 160x120 (0.71 at 320x240 and 640x480). The tests hold the goals: no image too many, the
counts' share at the goal, every image within 1 pixel.
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from refsoft import linalg, search
from refsoft.raster import gbuffer
from refsoft.scene.camera import Camera
from refsoft.scene.mesh import Mesh
from refsoft.scene.primitives import icosphere
from refsoft.search.images import find_images
from refsoft.truth.analytic import sphere_inside_reflection_points
from refsoft.truth.metrics import window_to_pixel

W, H = 160, 120
#: Pixels between two images of a vertex, and between an image and the view's border, below
#: which the vertex is not counted (two images about to merge; one about to leave the view).
APART = 2.0
#: A vertex whose exact count changes when it moves this far along an axis is beside a fold.
FOLD = 1e-3


@pytest.fixture(scope="module")
def inside():
    """The G-buffer of the inside of a unit sphere (icosphere, 6 subdivisions, faces and normals
    turned inwards) seen from inside, near its wall, and vertices filling the sphere."""
    s = icosphere(6, 1.0)
    mirror = Mesh(s.vertices, s.faces[:, [0, 2, 1]], -s.normals, name="inside")
    eye = np.array([0.05, 0.03, 0.8])
    cam = Camera(eye=eye, target=(0.0, 0.0, -1.0), fov_y=120.0, width=W, height=H, near=0.01, far=10.0)
    gb = gbuffer(mirror, cam, "float32", origin=cam.eye)
    rng = np.random.default_rng(0)
    d = rng.normal(size=(3000, 3))
    verts = d / np.linalg.norm(d, axis=1, keepdims=True) * rng.uniform(0.0, 0.95, (3000, 1)) ** (1 / 3)
    res = search.search(gb, cam.eye, verts, "box")
    return gb, eye, verts, find_images(gb, eye, verts, res)


def exact_in_view(gb, eye, verts):
    """Per vertex the exact points' projections (V, 4, 2), which lie in the view, and whether the
    vertex is clear: each point well inside or well outside the view, the ones inside more than
    APART pixels from each other."""
    pts, _, count = sphere_inside_reflection_points([0.0, 0.0, 0.0], 1.0, eye, verts)
    n, k = pts.shape[:2]
    flat = pts.reshape(-1, 3)
    found = np.isfinite(flat[:, 0])
    w = linalg.homogeneous(np.where(found[:, None], flat, 0.0), gb.view_proj)[:, 3]
    pix = np.full((n * k, 2), np.nan)
    pix[found] = window_to_pixel(flat[found], gb.view_proj, (H, W))
    pix, found, front = pix.reshape(n, k, 2), found.reshape(n, k), (w > 0).reshape(n, k)
    r, c = pix[..., 0], pix[..., 1]
    lo, hi_r, hi_c = -0.5 + APART, H - 0.5 - APART, W - 0.5 - APART
    inside = found & front & (r > lo) & (r < hi_r) & (c > lo) & (c < hi_c)
    outside = found & (~front | (r < -0.5 - APART) | (r > H - 0.5 + APART) | (c < -0.5 - APART)
                       | (c > W - 0.5 + APART))
    clear = np.all(~found | inside | outside, axis=1)
    gaps = np.linalg.norm(pix[:, :, None] - pix[:, None, :], axis=-1)
    both = inside[:, :, None] & inside[:, None, :] & ~np.eye(k, dtype=bool)
    clear &= ~np.any(both & ~(gaps > APART), axis=(1, 2))
    assert np.all(count <= k)
    for axis in range(3):  # away from a fold of the mapping (two images born together)
        for sign in (-1.0, 1.0):
            moved = np.array(verts, dtype=np.float64)
            moved[:, axis] += sign * FOLD
            clear &= sphere_inside_reflection_points([0.0, 0.0, 0.0], 1.0, eye, moved)[2] == count
    return pix, inside, clear


def test_image_counts_are_alhazens(inside):
    gb, eye, verts, im = inside
    _, in_view, clear = exact_in_view(gb, eye, verts)
    want = in_view.sum(axis=1)
    agree = (im.count == want)[clear]
    print(f"\n{clear.sum()} of {len(verts)} vertices clear; exact images in view per clear vertex: "
          f"{np.bincount(want[clear]).tolist()}; found: {np.bincount(im.count[clear]).tolist()}; "
          f"counts agree on {100 * agree.mean():.2f}%")
    assert clear.sum() >= 0.9 * len(verts)
    assert np.bincount(want[clear], minlength=4)[2:].sum() >= 500  # many vertices with several images
    assert np.all(im.count[clear] <= want[clear])  # never an image too many
    assert agree.mean() >= 0.999  # the goal (module docstring)


def test_every_image_found_is_near_an_exact_point(inside):
    gb, eye, verts, im = inside
    pix, in_view, clear = exact_in_view(gb, eye, verts)
    exact = pix[im.vertex]  # (M, 4, 2): the exact points of each image's vertex
    d = np.linalg.norm(exact - im.pixel[:, None, :].astype(np.float64), axis=-1)
    d = np.where(np.isfinite(d), d, np.inf).min(axis=1)[clear[im.vertex]]
    print(f"\n{len(d)} images: distance to the nearest exact point's projection: median {np.median(d):.3f}, "
          f"within 1 px {100 * np.mean(d <= 1.0):.2f}%, max {d.max():.3f} px")
    assert len(d) > 4000
    assert np.median(d) <= 0.5  # a texel's centre against a point spread over the texel: about 0.4
    assert d.max() <= 1.0  # the goal: every image within 1 pixel (module docstring)


@pytest.fixture(scope="module")
def sphere_inside():
    s = icosphere(6, 1.0)
    return Mesh(s.vertices, s.faces[:, [0, 2, 1]], -s.normals, name="inside")


@settings(max_examples=10, deadline=None, derandomize=True)
@given(seed=st.integers(0, 2**32 - 1), eye_r=st.floats(0.3, 0.85), eye_dir=st.tuples(*[st.floats(-1, 1)] * 3),
       look=st.tuples(*[st.floats(-1, 1)] * 3))
def test_hypothesis_over_eyes_and_points(sphere_inside, seed, eye_r, eye_dir, look):
    """Other eyes inside the sphere looking other ways, other points (2,000 a draw): never an image
    too many, the count the exact one for 99.9% of the clear vertices, every image within 1 pixel
    of an exact point."""
    d = np.asarray(eye_dir, np.float64)
    t = np.asarray(look, np.float64)
    if np.linalg.norm(d) < 0.1 or np.linalg.norm(t) < 0.1 or abs(np.dot(d, t)) > 0.99 * np.linalg.norm(d) * np.linalg.norm(t):
        return  # no direction, or looking along the up-vector's line
    eye = d / np.linalg.norm(d) * eye_r
    cam = Camera(eye=eye, target=eye + t / np.linalg.norm(t), fov_y=120.0, width=W, height=H, near=0.01, far=10.0,
                 up=(0.0, 1.0, 0.0) if abs(t[1]) < 0.9 * np.linalg.norm(t) else (1.0, 0.0, 0.0))
    gb = gbuffer(sphere_inside, cam, "float32", origin=cam.eye)
    rng = np.random.default_rng(seed)
    p = rng.normal(size=(2000, 3))
    verts = p / np.linalg.norm(p, axis=1, keepdims=True) * rng.uniform(0.0, 0.95, (2000, 1)) ** (1 / 3)
    im = find_images(gb, eye, verts, search.search(gb, cam.eye, verts, "box"))
    pix, in_view, clear = exact_in_view(gb, eye, verts)
    want = in_view.sum(axis=1)
    assert np.all(im.count[clear] <= want[clear])
    assert clear.sum() >= 1000 and np.mean((im.count == want)[clear]) >= 0.999
    dist = np.linalg.norm(pix[im.vertex] - im.pixel[:, None, :].astype(np.float64), axis=-1)
    dist = np.where(np.isfinite(dist), dist, np.inf).min(axis=1)[clear[im.vertex]]
    assert len(dist) == 0 or dist.max() <= 1.0


def test_an_eye_near_the_wall_looking_along_it(sphere_inside):
    """Eye (0, 0, 0.8125) looking along +y, near the wall: a view where solutions share a peak.
    1,931 clear vertices of 2,000 (seed 0). Without the seeds beside a fold the counts agreed on
    99.79%: three vertices had two exact images 2.5 to 6.8 pixels apart whose score forms one
    maximum. With them (``_images.seed_folds``) 99.95%: one vertex stays one image short, its
    maximum 7 pixels from its solution, beyond IMAGE_REACH. The goal, 99.9%."""
    eye = np.array([0.0, 0.0, 0.8125])
    cam = Camera(eye=eye, target=eye + [0.0, 1.0, 0.0], fov_y=120.0, width=W, height=H, near=0.01, far=10.0,
                 up=(1.0, 0.0, 0.0))
    gb = gbuffer(sphere_inside, cam, "float32", origin=cam.eye)
    rng = np.random.default_rng(0)
    p = rng.normal(size=(2000, 3))
    verts = p / np.linalg.norm(p, axis=1, keepdims=True) * rng.uniform(0.0, 0.95, (2000, 1)) ** (1 / 3)
    im = find_images(gb, eye, verts, search.search(gb, cam.eye, verts, "box"))
    pix, in_view, clear = exact_in_view(gb, eye, verts)
    want = in_view.sum(axis=1)
    assert np.all(im.count[clear] <= want[clear])
    assert np.mean((im.count == want)[clear]) >= 0.999
