"""The rasterizer's face culling (``rasterize(..., cull=...)``) against the slow reference, and
the default drawing both windings exactly as before."""

import numpy as np
import pytest

from naive import naive_rasterize, naive_rasterize_culled, naive_signed_areas
import refsoft
from refsoft import Camera, raster
from refsoft.raster import _setup


def soup(seed, n=60):
    """Random triangles around and across the near plane of a camera at the origin (-z)."""
    rng = np.random.default_rng(seed)
    centres = np.c_[rng.uniform(-2.5, 2.5, (n, 2)), rng.uniform(-6.0, 1.0, n)]
    verts = (centres[:, None, :] + rng.normal(0, 0.8, (n, 3, 3))).reshape(-1, 3)
    return verts, np.arange(3 * n).reshape(-1, 3)


CAM = Camera(eye=(0, 0, 0), target=(0, 0, -1), width=96, height=64, fov_y=60, near=0.5, far=20)


@pytest.mark.parametrize("cull", ["cw", "ccw"])
@pytest.mark.parametrize("seed", [1, 2])
def test_cull_matches_the_reference_bit_for_bit(cull, seed):
    verts, faces = soup(seed)
    clip = _setup.transform_points(verts, CAM.view_proj())
    frags = raster.rasterize(clip, faces, CAM.width, CAM.height, cull=cull)
    depth, face, _, tris = naive_rasterize_culled(clip, faces, CAM.width, CAM.height, cull=cull)
    np.testing.assert_array_equal(frags.triangle, face)
    np.testing.assert_array_equal(frags.depth, depth)
    signed = np.array(naive_signed_areas(clip, faces, CAM.width, CAM.height))
    assert (signed > 0).sum() > 20 and (signed < 0).sum() > 20  # both windings are present
    # clipped triangles (across the near plane) are among them
    assert any(not np.allclose(t["B"], np.eye(3)) for t in tris)
    # every drawn pixel's triangle has the kept winding, and some of each winding were drawn
    drawn = np.unique(frags.triangle[frags.mask])
    assert len(drawn) > 10
    sign_of_face = {}
    for t, s in zip(tris, signed):
        sign_of_face.setdefault(t["face"], set()).add(np.sign(s))
    for f in drawn:
        assert (-1 if cull == "cw" else 1) in sign_of_face[f]


def test_cull_with_peeling_matches_the_reference():
    verts, faces = soup(4)
    clip = _setup.transform_points(verts, CAM.view_proj())
    first = raster.rasterize(clip, faces, CAM.width, CAM.height, cull="cw")
    second = raster.rasterize(clip, faces, CAM.width, CAM.height, peel_depth=first.depth, cull="cw")
    d2, f2, _, _ = naive_rasterize_culled(clip, faces, CAM.width, CAM.height, peel=first.depth, cull="cw")
    np.testing.assert_array_equal(second.triangle, f2)
    np.testing.assert_array_equal(second.depth, d2)
    assert second.mask.sum() > 50


def test_the_two_windings_partition_the_triangles():
    """A triangle drawn alone is covered by exactly one of "cw" and "ccw", with the same pixels
    and depths as without culling."""
    verts, faces = soup(5, 30)
    clip = _setup.transform_points(verts, CAM.view_proj())
    for f in range(len(faces)):
        one = faces[f:f + 1]
        full = raster.rasterize(clip, one, CAM.width, CAM.height)
        cw = raster.rasterize(clip, one, CAM.width, CAM.height, cull="cw")
        ccw = raster.rasterize(clip, one, CAM.width, CAM.height, cull="ccw")
        assert not (cw.mask & ccw.mask).any()
        np.testing.assert_array_equal(cw.mask | ccw.mask, full.mask)
        np.testing.assert_array_equal(np.where(cw.mask, cw.depth, ccw.depth), full.depth)


@pytest.mark.parametrize("seed", [1, 3])
def test_no_cull_is_unchanged(seed):
    """cull=None is the default and equals the reference rasterizer without culling, bit for bit."""
    verts, faces = soup(seed)
    clip = _setup.transform_points(verts, CAM.view_proj())
    default = raster.rasterize(clip, faces, CAM.width, CAM.height)
    none = raster.rasterize(clip, faces, CAM.width, CAM.height, cull=None)
    depth, face, _, _ = naive_rasterize(clip, faces, CAM.width, CAM.height)
    for a in (default, none):
        np.testing.assert_array_equal(a.triangle, face)
        np.testing.assert_array_equal(a.depth, depth)
    for key in default.setup:
        np.testing.assert_array_equal(default.setup[key], none.setup[key])


def test_bad_cull_is_refused():
    verts, faces = soup(1, 3)
    clip = _setup.transform_points(verts, CAM.view_proj())
    with pytest.raises(refsoft.RefsoftError, match="cull"):
        raster.rasterize(clip, faces, CAM.width, CAM.height, cull="back")
