"""Fill rule, analytic G-buffer, perspective correctness, near-plane clipping, determinism."""

import hashlib
import os
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from refsoft import Camera, Mesh, primitives, raster
from refsoft.raster import _setup

W = H = 64


def window_to_clip(points_xy):
    """Window coordinates (x right, y up, pixels) to clip coordinates with w = 1, z = 0."""
    p = np.asarray(points_xy, dtype=np.float64)
    return np.c_[p[:, 0] * (2.0 / W) - 1.0, p[:, 1] * (2.0 / H) - 1.0, np.zeros(len(p)), np.ones(len(p))]


def coverage_count(points_xy, faces):
    """How many triangles cover each pixel, rasterizing each triangle on its own."""
    clip = window_to_clip(points_xy)
    count = np.zeros((H, W), dtype=np.int32)
    for f in faces:
        frags = raster.rasterize(clip, np.asarray([f]), W, H)
        count += frags.mask
    return count


def cross2(a, b):
    return a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]


def pixel_centres():
    rows, cols = np.mgrid[0:H, 0:W]
    return cols + 0.5, H - rows - 0.5


# ---------------------------------------------------------------------------- fill rule
@settings(max_examples=25, deadline=None)
@given(st.integers(2, 6), st.integers(2, 6), st.data())
def test_grid_union_covered_exactly_once(nx, ny, data):
    x0, y0 = 8.5, 8.5  # boundary through pixel centres: ties on all four outer edges
    cell = 7.0
    xs = x0 + cell * np.arange(nx + 1)
    ys = y0 + cell * np.arange(ny + 1)
    gx, gy = np.meshgrid(xs, ys)
    jitter = np.array(data.draw(st.lists(st.integers(-2, 2), min_size=2 * gx.size, max_size=2 * gx.size)))
    jitter = jitter.reshape(2, *gx.shape) * 0.5
    inner = np.zeros(gx.shape, dtype=bool)
    inner[1:-1, 1:-1] = True
    gx = gx + np.where(inner, jitter[0], 0.0)
    gy = gy + np.where(inner, jitter[1], 0.0)
    pts = np.c_[gx.ravel(), gy.ravel()]
    diag = data.draw(st.lists(st.booleans(), min_size=nx * ny, max_size=nx * ny))
    faces = []
    for j in range(ny):
        for i in range(nx):
            a, b, c, d = j * (nx + 1) + i, j * (nx + 1) + i + 1, (j + 1) * (nx + 1) + i + 1, (j + 1) * (nx + 1) + i
            faces += [[a, b, c], [a, c, d]] if diag[j * nx + i] else [[a, b, d], [b, c, d]]
    faces = np.array(faces)
    tri = pts[faces]
    area = cross2(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    assume(np.all(area > 0))  # jitter kept every triangle counter-clockwise (no fold-overs)
    count = coverage_count(pts, faces)
    cx, cy = pixel_centres()
    x1, y1 = xs[-1], ys[-1]
    # GL rule on the outer rectangle: left and bottom edges included, right and top excluded.
    expected = (cx >= x0) & (cx < x1) & (cy >= y0) & (cy < y1)
    np.testing.assert_array_equal(count, expected.astype(np.int32))


@settings(max_examples=25, deadline=None)
@given(st.integers(4, 12), st.data())
def test_fan_covered_exactly_once(k, data):
    # equally spaced angles jittered by up to 30% of the spacing: gaps stay in (0, pi)
    jitter = np.array(data.draw(st.lists(st.floats(-0.3, 0.3), min_size=k, max_size=k)))
    angles = (np.arange(k) + jitter) * (2 * np.pi / k) + data.draw(st.floats(0, 1))
    ring = np.c_[32 + 24 * np.cos(angles), 32 + 24 * np.sin(angles)]
    ring = np.round(ring * 2) / 2  # half-pixel positions: many edges pass through pixel centres
    centre = np.array([[32.5, 31.5]])
    pts = np.r_[centre, ring]
    faces = np.array([[0, 1 + i, 1 + (i + 1) % k] for i in range(k)])
    tri = pts[faces]
    assume(np.all(cross2(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]) > 0))
    count = coverage_count(pts, faces)
    assert count.max() <= 1
    # strictly inside the convex ring polygon -> exactly once; strictly outside -> never
    cx, cy = pixel_centres()
    inside = np.ones((H, W), dtype=bool)
    outside = np.zeros((H, W), dtype=bool)
    for i in range(k):
        a, b = ring[i], ring[(i + 1) % k]
        e = (b[0] - a[0]) * (cy - a[1]) - (b[1] - a[1]) * (cx - a[0])
        inside &= e > 0
        outside |= e < 0
    assert np.all(count[inside] == 1)
    assert np.all(count[outside] == 0)
    assert inside.sum() > 50


@pytest.mark.parametrize("flip_winding", [False, True])
def test_pixel_centres_exactly_on_edges(flip_winding):
    # Pixel (row, col) has its centre at x = col + 0.5, y = H - row - 0.5.
    def draw(tri):
        tri = np.asarray(tri, dtype=np.float64)
        if flip_winding:
            tri = tri[::-1]
        return coverage_count(tri, [[0, 1, 2]])

    def px(x, y):
        return H - 1 - int(np.floor(y)), int(np.floor(x))

    # Vertical edge at x = 10.5; the triangle to its right: a left edge, included.
    right_of = draw([[10.5, 2.0], [30.0, 20.0], [10.5, 40.0]])
    assert right_of[px(10.5, 20.5)] == 1
    # The same edge with the triangle to its left: a right edge, excluded.
    left_of = draw([[10.5, 2.0], [10.5, 40.0], [-8.0, 20.0]])
    assert left_of[px(10.5, 20.5)] == 0
    assert left_of[px(9.5, 20.5)] == 1
    # Horizontal edge at y = 5.5; the triangle above: a bottom edge, included.
    above = draw([[2.0, 5.5], [40.0, 5.5], [20.0, 30.0]])
    assert above[px(20.5, 5.5)] == 1
    # The triangle below it: a top edge, excluded.
    below = draw([[2.0, 5.5], [20.0, -20.0], [40.0, 5.5]])
    assert below[px(20.5, 5.5)] == 0
    assert below[px(20.5, 4.5)] == 1
    # A pixel centre exactly on a vertex shared by a left and a bottom edge is covered once.
    corner = draw([[10.5, 5.5], [40.0, 5.5], [10.5, 40.0]])
    assert corner[px(10.5, 5.5)] == 1
    top_right = draw([[40.5, 40.5], [10.0, 40.5], [40.5, 10.0]])
    assert top_right[px(40.5, 40.5)] == 0


def test_zero_area_triangle_draws_nothing():
    assert coverage_count([[1.5, 1.5], [20.5, 20.5], [40.5, 40.5]], [[0, 1, 2]]).sum() == 0


# ---------------------------------------------------------------------------- analytic sphere
def test_icosphere_gbuffer_against_ray_sphere():
    mesh = primitives.icosphere(6, 1.0)
    cam = Camera(eye=(0.3, 0.4, 3.5), target=(0, 0, 0), width=160, height=120, fov_y=45)
    gb = raster.gbuffer(mesh, cam)
    origins, dirs = cam.pixel_rays()
    # analytic ray-sphere
    b = np.sum(origins * dirs, axis=-1)
    c = np.sum(origins * origins, axis=-1) - 1.0
    disc = b * b - c
    hit = disc >= 0
    t = -b - np.sqrt(np.where(hit, disc, 0))
    p = origins + t[..., None] * dirs
    # the mesh lies inside the sphere: every covered pixel's ray hits the sphere
    assert np.all(hit[gb.mask])
    assert gb.mask.sum() > 0.95 * hit.sum()
    # deepest facet below the sphere (sagitta) bounds the position error along the ray
    tri = mesh.vertices[mesh.faces]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    sagitta = 1.0 - np.min(np.sum(n * tri[:, 0], axis=1))
    assert sagitta < 2e-4
    cos_view = -np.sum(dirs * p, axis=-1)
    m = gb.mask & (cos_view > 0.3)
    err = np.linalg.norm(gb.position[m].astype(np.float64) - p[m], axis=1)
    # Snapping moves each projected vertex by up to 1/512 px, which moves the facet sideways by
    # up to that many world units (pixel footprint at the eye distance); at incidence angle
    # theta both offsets grow by 1/cos(theta) along the ray. Plus float32 rounding (1e-5).
    pixel_world = 2 * np.linalg.norm(cam.eye) * np.tan(np.radians(cam.fov_y) / 2) / cam.height
    bound = (sagitta + 2 * pixel_world / 512) / cos_view[m] + 1e-5
    assert np.all(err <= bound), (err / bound).max()
    # interpolated normals: within 1e-3 rad of the true normal at the analytic hit
    cosang = np.clip(np.sum(gb.normal[m].astype(np.float64) * p[m], axis=1), -1, 1)
    assert np.arccos(cosang).max() < 1e-3
    # unit length, and zero where not covered
    np.testing.assert_allclose(np.linalg.norm(gb.normal[gb.mask], axis=1), 1.0, atol=1e-6)
    assert np.all(gb.normal[~gb.mask] == 0) and np.all(gb.position[~gb.mask] == 0)
    assert np.all(gb.depth[~gb.mask] == 1.0) and np.all(gb.triangle[~gb.mask] == -1)


# ---------------------------------------------------------------------------- perspective
def test_perspective_correct_uv_on_oblique_quad():
    cam = Camera(eye=(0, 0, 0), target=(0, 0, -1), width=128, height=96, fov_y=60, near=0.1, far=50)
    p00, p10, p01 = np.array([-2.0, -1.0, -1.5]), np.array([2.0, -1.0, -9.0]), np.array([-2.0, 1.5, -1.5])
    p11 = p10 + p01 - p00
    verts = np.array([p00, p10, p11, p01])
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=np.float64)
    faces = np.array([[0, 1, 2], [0, 2, 3]])
    clip = _setup.transform_points(verts, cam.view_proj())
    frags = raster.rasterize(clip, faces, cam.width, cam.height)
    got = raster.interpolate(frags, uv, faces, np.float64)
    origins, dirs = cam.pixel_rays()
    e1, e2 = p10 - p00, p01 - p00
    normal = np.cross(e1, e2)
    t = np.sum((p00 - origins) * normal, axis=-1) / np.sum(dirs * normal, axis=-1)
    q = origins + t[..., None] * dirs - p00
    # solve q = u e1 + v e2 (least squares on the plane)
    G = np.array([[e1 @ e1, e1 @ e2], [e1 @ e2, e2 @ e2]])
    rhs = np.stack([q @ e1, q @ e2], axis=-1)
    exact = rhs @ np.linalg.inv(G).T
    m = frags.mask
    assert m.sum() > 2000
    err = np.abs(got[m] - exact[m]).max()
    # Vertex snapping to 1/256 px is the only error source in float64.
    assert err < 1e-4, err
    # Screen-linear interpolation would be visibly wrong here (the test can tell them apart).
    win = cam.project(verts)[:, :2]
    rows, cols = np.nonzero(m)
    pc = np.c_[cols + 0.5, cam.height - rows - 0.5]
    tri_idx = frags.triangle[m]
    affine = np.empty_like(exact[m])
    for k, f in enumerate(faces):
        sel = tri_idx == k
        a, b, c = win[f]
        T = np.c_[b - a, c - a]
        lam = np.linalg.solve(T, (pc[sel] - a).T).T
        affine[sel] = uv[f[0]] + lam[:, :1] * (uv[f[1]] - uv[f[0]]) + lam[:, 1:] * (uv[f[2]] - uv[f[0]])
    assert np.abs(affine - exact[m]).max() > 0.05


# ---------------------------------------------------------------------------- near plane
def _ray_triangle(origins, dirs, a, b, c):
    e1, e2 = b - a, c - a
    pv = np.cross(dirs, e2)
    det = pv @ e1
    inv = 1.0 / det
    tv = origins - a
    u = np.sum(tv * pv, axis=-1) * inv
    qv = np.cross(tv, e1)
    v = np.sum(dirs * qv, axis=-1) * inv
    t = (qv @ e2) * inv
    return (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0), t, u, v


@pytest.mark.parametrize("tri", [
    [[-1.0, -0.5, -3.0], [1.0, -0.5, -3.0], [0.0, 0.8, 2.0]],      # one vertex behind the eye
    [[-3.0, -0.5, 1.0], [3.0, -0.5, 1.0], [0.0, 0.6, -4.0]],       # two vertices behind the eye
    [[-0.05, -0.03, -0.05], [0.06, -0.04, -0.12], [0.0, 0.06, -0.09]],  # straddling the near plane up close
])
def test_near_plane_clipping_draws_the_right_part(tri):
    cam = Camera(eye=(0, 0, 0), target=(0, 0, -1), width=120, height=90, fov_y=70, near=0.07, far=50)
    verts = np.asarray(tri)
    mesh = Mesh(verts, [[0, 1, 2]])
    gb = raster.gbuffer(mesh, cam, "float64")
    origins, dirs = cam.pixel_rays()
    hit, t, _, _ = _ray_triangle(origins, dirs, *verts)
    z_view = (origins + t[..., None] * dirs)[..., 2]
    expected = hit & (z_view <= -cam.near)
    assert expected.sum() > 50
    diff = gb.mask != expected
    # disagreements only on the boundary of the expected region (pixel centres within snapping)
    pad = np.pad(expected, 1, mode="edge")
    mixed = np.zeros_like(expected)
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            mixed |= pad[1 + dr:1 + dr + cam.height, 1 + dc:1 + dc + cam.width] != expected
    assert np.all(mixed[diff]), np.argwhere(diff & ~mixed)
    assert diff.sum() <= 0.02 * expected.sum() + 5
    assert np.all(np.isfinite(gb.position)) and np.all(np.isfinite(gb.normal))
    # every drawn position lies in front of the near plane (within float rounding)
    assert np.all(gb.position[gb.mask][:, 2] <= -cam.near + 1e-9)


def test_triangle_entirely_behind_the_eye_draws_nothing():
    cam = Camera(eye=(0, 0, 0), target=(0, 0, -1), width=64, height=48)
    mesh = Mesh([[-1, -1, 1.0], [1, -1, 1.0], [0, 1, 2.0]], [[0, 1, 2]])
    gb = raster.gbuffer(mesh, cam)
    assert not gb.mask.any()


def test_triangle_far_outside_the_viewport_is_guard_band_clipped_exactly():
    """A huge triangle (far past the guard band) still covers the whole view, no overflow."""
    cam = Camera(eye=(0, 0, 0), target=(0, 0, -1), width=64, height=48, near=0.1)
    big = 1e9
    mesh = Mesh([[-big, -big, -1.0], [big, -big, -1.0], [0, big, -1.0]], [[0, 1, 2]])
    gb = raster.gbuffer(mesh, cam, "float64")
    assert gb.mask.all()
    np.testing.assert_allclose(gb.position[..., 2], -1.0, rtol=1e-6)


# ---------------------------------------------------------------------------- determinism
DETERMINISM_SCRIPT = r"""
import hashlib, numpy as np, refsoft
s = refsoft.load_scene("sphere", width=200, height=150)
h = hashlib.sha256()
gb = refsoft.raster.gbuffer(s.world_mesh(1), s.camera)
cp = refsoft.raster.color_pass([s.world_mesh(i + 1) for i in range(len(s.objects))],
                               [o.color for o in s.objects], s.camera)
for a in (gb.position, gb.normal, gb.mask, gb.depth, gb.triangle, cp.image, cp.object_id, cp.depth):
    h.update(np.ascontiguousarray(a).tobytes())
print(h.hexdigest())
"""


def _digest(threads):
    env = dict(os.environ, NUMBA_NUM_THREADS=str(threads))
    out = subprocess.run([sys.executable, "-c", DETERMINISM_SCRIPT], env=env, capture_output=True, text=True,
                         check=True)
    return out.stdout.strip().splitlines()[-1]


def test_bit_identical_across_runs_and_thread_counts():
    one, two, again = _digest(1), _digest(2), _digest(2)
    assert len(one) == 64
    assert one == two == again
