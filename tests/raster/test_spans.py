"""The per-row spans of the coverage kernel (refsoft.raster._kernels._span and the float64 path of
raster_tiles) and the run-by-run shading pass against per-pixel references, on small and
degenerate triangles."""

import numpy as np
import pytest
from naive import naive_object_ids, naive_rasterize, naive_shade

from refsoft import constants, raster
from refsoft.raster import _kernels, _setup

from test_raster_vs_naive import CAMERAS, random_soup


def _span_reference(g, f, q, ja, jb):
    """The j in [ja, jb] where g + j f >= q, tested one by one in exact integers."""
    ok = [j for j in range(ja, jb + 1) if g + j * f >= q]
    return (ok[0], ok[-1]) if ok else None


def test_span_equals_the_per_column_test(rng):
    cases = []
    for _ in range(3000):
        f = int(rng.integers(-3, 4)) * 256 * int(rng.choice([1, 7, 1 << 10, 1 << 24]))
        # edge values near a column boundary, exactly on one, and far from any
        j0 = int(rng.integers(-20, 36))
        g = -j0 * f + int(rng.choice([0, 0, 1, -1, 2, -2, int(rng.integers(-1 << 50, 1 << 50))]))
        cases.append((g, f, int(rng.integers(0, 2)), 0, int(rng.integers(0, 16))))
    cases += [(0, 0, 0, 0, 15), (0, 0, 1, 0, 15), (-1, 0, 0, 0, 3), ((1 << 51) - 1, -256, 1, 0, 15),
              (-(1 << 51) + 1, 256, 0, 0, 15), (256 * 5, -256, 0, 0, 15), (256 * 5, -256, 1, 0, 15)]
    for g, f, q, ja, jb in cases:
        a, b = _kernels._span(float(g), float(f), float(q), float(ja), float(jb))
        expected = _span_reference(g, f, q, ja, jb)
        if expected is None:
            assert a > b, (g, f, q, ja, jb)
        else:
            assert (a, b) == expected, (g, f, q, ja, jb)


def _clip_of_window(xy, z, width, height):
    """Clip coordinates (w = 1) of window positions given in 1/256 px (exact: sizes are powers
    of two)."""
    xy = np.asarray(xy, dtype=np.float64) / 256.0
    return np.c_[xy[:, 0] / (0.5 * width) - 1.0, xy[:, 1] / (0.5 * height) - 1.0, z, np.ones(len(xy))]


def _awkward_triangles(rng, width, height):
    """Tiny, thin, near-horizontal and near-vertical triangles, edges through pixel centres
    (shared edges: one inclusive, one exclusive), in both windings, in 1/256 px."""
    tris = []
    for _ in range(40):
        c = rng.integers(0, [width * 256, height * 256])
        tris.append(c + rng.integers(-300, 300, (3, 2)))  # tiny
    for _ in range(30):
        a = rng.integers(0, [width * 256, height * 256])
        b = rng.integers(0, [width * 256, height * 256])
        tris.append(np.array([a, b, b + rng.integers(-2, 3, 2)]))  # needles of any slope
        tris.append(np.array([a, [b[0], a[1]], [b[0], a[1] + rng.integers(1, 200)]]))  # near-horizontal
        tris.append(np.array([a, [a[0], b[1]], [a[0] + rng.integers(1, 200), b[1]]]))  # near-vertical
    for _ in range(30):
        # vertices on pixel centres: edges pass through centres; two triangles share each diagonal
        p = (rng.integers(0, [width, height], (2, 2)) * 256 + 128)
        q = np.array([p[0], [p[1][0], p[0][1]], p[1], [p[0][0], p[1][1]]])
        tris.append(q[[0, 1, 2]])
        tris.append(q[[0, 2, 3]] if rng.uniform() < 0.5 else q[[2, 0, 3]])
    xy = np.concatenate(tris).reshape(-1, 2)
    z = rng.uniform(-0.9, 0.9, len(xy))
    return _clip_of_window(xy, z, width, height), np.arange(len(xy)).reshape(-1, 3)


@pytest.mark.parametrize("region", [None, (3, 41, 5, 60)])
def test_awkward_triangles_match_the_reference(rng, region):
    width, height = 64, 48
    clip, faces = _awkward_triangles(rng, width, height)
    frags = raster.rasterize(clip, faces, width, height, region=region)
    depth, face, _, _ = naive_rasterize(clip, faces, width, height)
    r0, r1, c0, c1 = region or (0, height, 0, width)
    assert (frags.triangle >= 0).sum() > 300
    np.testing.assert_array_equal(frags.triangle, face[r0:r1, c0:c1])
    np.testing.assert_array_equal(frags.depth, depth[r0:r1, c0:c1])


def test_triangles_beyond_the_exact_range_match_the_reference(rng):
    """Vertices far outside the viewport (beyond EXACT_COORD, inside the guard band) take the
    integer path; their neighbours the float64 one: the two agree with the reference."""
    width, height = 64, 48
    far = _kernels.EXACT_COORD * 3
    small = list(rng.integers(0, [width * 256, height * 256], (30, 2)))
    for big in ([[-far, -far // 2], [far, 10 * 256], [20 * 256, far]],
                [[-far, far], [30 * 256, -far], [far, far // 3]]):
        xy = big + small
        z = np.r_[0.5, 0.2, 0.8, rng.uniform(-0.9, 0.9, len(small))]
        clip = _clip_of_window(xy, z, width, height)
        faces = np.arange(len(xy)).reshape(-1, 3)
        frags = raster.rasterize(clip, faces, width, height)
        depth, face, _, _ = naive_rasterize(clip, faces, width, height)
        assert (frags.triangle == 0).any() and (frags.triangle > 0).any()
        np.testing.assert_array_equal(frags.triangle, face)
        np.testing.assert_array_equal(frags.depth, depth)


def test_peeled_awkward_triangles_match_the_reference(rng):
    width, height = 64, 48
    clip, faces = _awkward_triangles(rng, width, height)
    first = raster.rasterize(clip, faces, width, height)
    frags = raster.rasterize(clip, faces, width, height, peel_depth=first.depth)
    depth, face, _, _ = naive_rasterize(clip, faces, width, height, peel=first.depth)
    assert (frags.triangle >= 0).sum() > 50
    np.testing.assert_array_equal(frags.triangle, face)
    np.testing.assert_array_equal(frags.depth, depth)


def test_shading_of_clipped_triangles_equals_interpolate_then_the_reference(rng):
    """Runs of clipped triangles (barycentrics through their matrix) and unclipped ones of both
    windings, as raster.interpolate and the per-pixel shading reference give them."""
    cam = CAMERAS["perspective"]
    verts, faces = random_soup(rng, 60)
    normals = rng.normal(size=verts.shape)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    clip = _setup.transform_points(verts, cam.view_proj())
    frags = raster.rasterize(clip, faces, cam.width, cam.height)
    assert (frags.setup["slot"][frags.index[frags.index >= 0]] >= 0).sum() > 100  # clipped pixels
    sizes = [20, 25, 15]
    face_offset = np.cumsum([0] + sizes).astype(np.int64)
    face_object = np.repeat(np.arange(1, 4, dtype=np.int32), sizes)
    table = rng.uniform(0.0, 1.0, (4, 3)).astype(np.float32)
    nrm = raster.interpolate(frags, normals, faces, np.float32, normalize=True)
    ids, local = naive_object_ids(frags.triangle, face_offset)
    expected = naive_shade(nrm, ids, table, constants.LIGHT_DIRECTION.astype(np.float32),
                           np.float32(constants.AMBIENT), np.float32(constants.DIFFUSE))
    color, got_ids, got_local = raster.shade_fragments(frags, normals, faces, face_object, face_offset, table)
    np.testing.assert_array_equal(color, expected)
    np.testing.assert_array_equal(got_ids, ids)
    np.testing.assert_array_equal(got_local, local)
