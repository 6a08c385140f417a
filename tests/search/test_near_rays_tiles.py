"""meet.near_rays (the rays' pruning tile by tile, kernel _bounces.rays_by_tiles) against
reach.near_rays (every ray tested against every triangle): the same candidates, the same ray
lists in the same order, the same with one thread."""

import numpy as np
import pytest

import refsoft
from refsoft._parallel import one_thread
from refsoft.frame.driver import FrameDriver
from refsoft.options import RenderOptions
from refsoft.search import meet, reach
from refsoft.search.exact_levels import combined


def _lists(cand):
    first, last, ray = cand.rays
    return [ray[a:b].tolist() for a, b in zip(first, last)]


def _same(a, b):
    assert np.array_equal(a.triangle, b.triangle)
    assert np.array_equal(a.object_id, b.object_id)
    assert np.array_equal(a.real, b.real) and np.array_equal(a.normals, b.normals)
    assert _lists(a) == _lists(b)


def _check(verts, normals, faces, fobj, grid):
    valid, origin, direction = grid
    want = reach.near_rays(verts, normals, faces, fobj, (origin[valid], direction[valid]))
    got = meet.near_rays(verts, normals, faces, fobj, grid)
    _same(got, want)
    return got


@pytest.fixture(scope="module")
def level_rays():
    """The rays of the concave bowl's level 1 (every pixel of it, from the moved origins) and of
    its level 2, as the render meets them with the bowl, 96x72, frame 0."""
    sc = refsoft.load_scene("concave", width=96, height=72)
    grids = []
    real = meet.near_rays

    def spy(verts, normals, faces, fobj, rays):
        grids.append(rays)
        return real(verts, normals, faces, fobj, rays)

    meet.near_rays = spy
    try:
        FrameDriver(sc, RenderOptions(bounces=2)).render_frame(0)
    finally:
        meet.near_rays = real
    return sc, grids


def test_the_tiles_keep_the_lists_of_every_ray_tested(level_rays):
    sc, grids = level_rays
    meshes = [sc.world_mesh(k, 0) for k in range(1, len(sc.objects) + 1)]
    assert len(grids) >= 3 and all(g[0].sum() > 100 for g in grids)
    bowl = combined(meshes, [1])
    for grid in grids:
        got = _check(*bowl, grid)
        assert len(got.triangle) > 100
    scene = combined(meshes, [k for k, o in enumerate(sc.objects, start=1) if not o.reflector])
    _check(*scene, grids[-1])


def test_rays_along_a_triangles_plane_and_scattered_rays():
    """Random rays over a grid, some through the triangles, a tile of rays lying in triangle 0's
    plane far from it (kept by the parallel rule wherever they pass), a zero direction."""
    rng = np.random.default_rng(3)
    h, w = 21, 27
    valid = rng.random((h, w)) < 0.8
    origin = rng.normal(size=(h, w, 3))
    direction = rng.normal(size=(h, w, 3)) * 0.5 - origin
    verts = rng.normal(size=(60, 3)) * 0.6
    faces = np.arange(60).reshape(20, 3)
    real = verts[faces]
    n = np.cross(real[0, 1] - real[0, 0], real[0, 2] - real[0, 0])
    n /= np.linalg.norm(n)
    along = np.cross(n, [0.3, 0.5, 0.8])
    along /= np.linalg.norm(along)
    side = np.cross(n, along)
    # the fine tile of rows 4-7, columns 4-7: every ray in the plane, 5 to 6 away, nearly parallel
    tile = (slice(4, 8), slice(4, 8))
    valid[tile] = True
    spread = rng.random((4, 4))
    origin[tile] = real[0, 0] + (5.0 + spread)[..., None] * side + rng.normal(size=(4, 4, 1)) * along
    direction[tile] = along + 0.01 * spread[..., None] * side
    direction[10, 10] = 0.0  # a zero direction
    normals = np.tile([0.0, 0.0, 1.0], (60, 1))
    got = _check(verts, normals, faces, np.ones(20, np.int32), (valid, origin, direction))
    index = np.cumsum(valid.ravel()).reshape(h, w) - 1
    assert got.triangle[0] == 0
    assert set(index[tile].ravel().tolist()) <= set(_lists(got)[0])  # kept though far: along its plane


def test_the_same_lists_with_one_thread(level_rays):
    sc, grids = level_rays
    meshes = [sc.world_mesh(k, 0) for k in range(1, len(sc.objects) + 1)]
    bowl = combined(meshes, [1])
    a = meet.near_rays(*bowl, grids[0])
    with one_thread():
        b = meet.near_rays(*bowl, grids[0])
    _same(a, b)
    assert np.array_equal(a.rays[0], b.rays[0]) and np.array_equal(a.rays[2], b.rays[2])
