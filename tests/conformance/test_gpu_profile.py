"""`refsoft check --profile gpu` (spec section 8, docs/precision.md): the rates its G-buffer
tolerances scale with are the exact interpolation's derivatives; a candidate perturbed within
the gpu tolerances passes it and fails the default profile, one beyond fails both; and a
candidate whose G-buffer is interpolated as a GPU does (float32, unsnapped vertices), with the
rest of the frame computed from it, passes the gpu profile and fails the default one."""

import shutil

import numpy as np
import pytest

from naive import naive_gl_interpolate
from refsoft import constants
from refsoft.conformance.check import check
from refsoft.conformance.golden import case_by_name
from refsoft.conformance.precision import score_condition, tie_bound
from refsoft.conformance.profiles import fragments
from refsoft.conformance.stages import reference_driver
from refsoft.io import read_npz, write_npz
from refsoft.raster import GBuffer
from refsoft.scene import scene_vertices
from refsoft.search import CULLED, scores_at
from refsoft.search.reflect import gbuffer_camera, reflector_gbuffer

S = constants.GPU_SUBPIXEL_PX


@pytest.fixture(scope="module")
def sphere():
    scene = case_by_name("sphere").load()
    gb = reflector_gbuffer(scene, 1, 0)
    mesh = scene.world_mesh(1, 0, proxy=True)
    pix = np.argwhere(gb.mask)
    h, w = gb.mask.shape
    return scene, gb, mesh, pix, fragments(mesh, gb.view_proj, w, h, pix, gb.triangle[pix[:, 0], pix[:, 1]])


def _ray_plane(mesh, gb, pix, tri, dx=0.0, dy=0.0):
    """World points where the eye ray through each pixel centre (moved by dx, dy window pixels)
    meets its triangle's plane, and their window depth (plain float64 NumPy)."""
    h, w = gb.mask.shape
    inv = np.linalg.inv(gb.view_proj)
    X = (pix[:, 1] + 0.5 + dx) * 2 / w - 1
    Y = (h - pix[:, 0] - 0.5 + dy) * 2 / h - 1
    ends = [np.c_[X, Y, np.full_like(X, z), np.ones_like(X)] @ inv.T for z in (-1.0, 1.0)]
    a, b = (e[:, :3] / e[:, 3:] for e in ends)
    v = mesh.vertices[mesh.faces[tri]]
    n = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    t = np.einsum("ij,ij->i", v[:, 0] - a, n) / np.einsum("ij,ij->i", b - a, n)
    p = a + t[:, None] * (b - a)
    clip = np.c_[p, np.ones(len(p))] @ gb.view_proj.T
    return p, 0.5 * clip[:, 2] / clip[:, 3] + 0.5


def test_fragments_are_the_exact_interpolation_and_its_rates(sphere):
    _, gb, mesh, pix, fr = sphere
    tri = gb.triangle[pix[:, 0], pix[:, 1]]
    p, z = _ray_plane(mesh, gb, pix, tri)
    np.testing.assert_allclose(fr.position, p, rtol=0, atol=1e-12)
    np.testing.assert_allclose(fr.depth, z, rtol=0, atol=1e-12)
    d = 1e-4  # central differences along window x and y
    rate_p, rate_z, rate_n = 0.0, 0.0, 0.0
    for dx, dy in ((d, 0.0), (0.0, d)):
        (p1, z1), (p0, z0) = _ray_plane(mesh, gb, pix, tri, dx, dy), _ray_plane(mesh, gb, pix, tri, -dx, -dy)
        rate_p = rate_p + np.linalg.norm(p1 - p0, axis=1) / (2 * d)
        rate_z = rate_z + np.abs(z1 - z0) / (2 * d)
        n1 = fragments(mesh, gb.view_proj, 128, 96, pix, tri, (dx, dy)).normal
        n0 = fragments(mesh, gb.view_proj, 128, 96, pix, tri, (-dx, -dy)).normal
        rate_n = rate_n + np.arctan2(np.linalg.norm(np.cross(n1, n0), axis=1), np.einsum("ij,ij->i", n1, n0)) / (2 * d)
    np.testing.assert_allclose(fr.position_rate, rate_p, rtol=1e-5)
    np.testing.assert_allclose(fr.depth_rate, rate_z, rtol=1e-5)
    np.testing.assert_allclose(fr.normal_rate, rate_n, rtol=1e-4)
    assert fr.position_rate.max() > 10 * np.median(fr.position_rate)  # edge-on at the silhouette


def _copy(golden, tmp_path, case, frame, mutate):
    cand = tmp_path / "cand"
    cand.mkdir(parents=True)
    shutil.copytree(golden / case, cand / case)
    path = cand / case / f"frame_{frame:04d}.npz"
    a = read_npz(path)
    mutate(a)
    write_npz(path, **a)
    return cand


def _status(s, key):
    return [f.status for f in s["_findings"] if f.key == key]


@pytest.mark.parametrize("scale, gpu_passes", [(0.5, True), (3.0, False)])
def test_gbuffer_perturbed_within_and_beyond_the_gpu_bound(golden, tmp_path, sphere, scale, gpu_passes):
    """Every covered position moved by ``scale`` times the gpu bound (GPU_SUBPIXEL_PX times its
    rate, plus the float rule's slack), every normal turned likewise."""
    _, gb, _, pix, fr = sphere
    rng = np.random.default_rng(5)
    r, c = pix.T

    def mutate(a):
        p = a["gbuffer_position_1"].astype(np.float64)
        u = rng.normal(size=(len(pix), 3))
        u /= np.linalg.norm(u, axis=1, keepdims=True)
        p[r, c] += scale * (S * fr.position_rate + 1e-5)[:, None] * u
        a["gbuffer_position_1"] = p.astype(np.float32)
        n = a["gbuffer_normal_1"].astype(np.float64)
        t = np.cross(n[r, c], rng.normal(size=(len(pix), 3)))
        t /= np.linalg.norm(t, axis=1, keepdims=True)
        turn = scale * (constants.NORMAL_ANGLE_TOL + S * fr.normal_rate)
        n[r, c] = n[r, c] * np.cos(turn)[:, None] + t * np.sin(turn)[:, None]
        a["gbuffer_normal_1"] = n.astype(np.float32)

    cand = _copy(golden, tmp_path, "sphere", 0, mutate)
    for profile, passes in (("default", False), ("gpu", gpu_passes)):
        s = check(golden, cand, cases=["sphere"], kinds=["coverage", "gbuffer"], profile=profile)
        assert s["passed"] == passes and s["profile"] == profile
        for key in ("gbuffer_position_1", "gbuffer_normal_1"):
            assert _status(s, key) == ["accepted" if passes else "fail"]


@pytest.fixture(scope="module")
def sphere_scores(golden):
    """The sphere case's live vertices, their golden pixels, |U + B| there, and each vertex's
    oracle score at its four crosshair neighbours (NO_SCORE where uncovered)."""
    scene, gb = case_by_name("sphere").load(), None
    gb = reflector_gbuffer(scene, 1, 0)
    verts, _ = scene_vertices(scene, 0)
    eye = scene.camera.eye
    G = read_npz(golden / "sphere" / "frame_0000.npz")
    live = np.flatnonzero((G["flags_1"] & CULLED) == 0)
    pix = G["reflection_pixel_1"][live]
    cond = score_condition(gb, eye, verts[live], pix)
    s0 = scores_at(gb, eye, verts[live], pix).astype(np.float64)
    moves = np.array([(0, -1), (-1, 0), (0, 1), (1, 0)])
    diff = np.stack([s0 - scores_at(gb, eye, verts[live], np.clip(pix + m, 0, [95, 127])).astype(np.float64)
                     for m in moves], axis=1)
    return live, pix, cond, diff, moves


@pytest.mark.parametrize("scale, gpu_passes", [(0.5, True), (2.0, False)])
def test_scores_perturbed_within_and_beyond_the_gpu_bound(golden, tmp_path, sphere_scores, scale, gpu_passes):
    live, _, cond, _, _ = sphere_scores
    bound = tie_bound(cond, constants.GPU_TIE_K / 2)  # one score's share of the gpu tie bound
    assert np.all(0.5 * bound > 4 * np.spacing(np.float32(1.0)))  # beyond the default's 4 ULP

    def mutate(a):
        a["score_1"][live] = (a["score_1"][live].astype(np.float64) + scale * bound).astype(np.float32)

    cand = _copy(golden, tmp_path, "sphere", 0, mutate)
    for profile, passes in (("default", False), ("gpu", gpu_passes)):
        s = check(golden, cand, cases=["sphere"], kinds=["score"], profile=profile)
        assert s["passed"] == passes and _status(s, "score_1") == ["accepted" if passes else "fail"]


@pytest.mark.parametrize("within", [True, False])
def test_pixel_ties_within_and_beyond_the_gpu_bound(golden, tmp_path, sphere_scores, within):
    """Ten vertices end on a neighbour whose oracle score is lower by more than the default tie
    bound and at most the gpu one (a tie under gpu only), or by more than the gpu bound."""
    live, pix, cond, diff, moves = sphere_scores
    lo, hi = tie_bound(cond)[:, None], tie_bound(cond, constants.GPU_TIE_K)[:, None]
    ok = (diff > lo) & (diff <= hi) if within else (diff > hi) & (diff < 1.0)
    rows = np.flatnonzero(ok.any(axis=1))[:10]
    assert len(rows) == 10
    j = np.argmax(ok[rows], axis=1)

    def mutate(a):
        a["reflection_pixel_1"][live[rows]] = pix[rows] + moves[j]

    cand = _copy(golden, tmp_path, "sphere", 0, mutate)
    for profile, passes in (("default", False), ("gpu", within)):
        s = check(golden, cand, cases=["sphere"], kinds=["pixel"], profile=profile)
        assert s["passed"] == passes and _status(s, "reflection_pixel_1") == ["accepted" if passes else "fail"]


def test_a_gpu_interpolated_gbuffer_passes_gpu_and_fails_default(golden, tmp_path):
    """The sphere and three coherent frames of the ellipsoid with G-buffers interpolated as a GPU
    does (tests/naive.py), and every later stage computed from them."""
    cand = tmp_path / "cand"
    for name in ("sphere", "ellipsoid"):
        case = case_by_name(name)
        scene = case.load()
        driver = reference_driver(scene, case.options)
        (cand / name).mkdir(parents=True)
        for f in case.frames:
            cam = gbuffer_camera(scene, f)
            gb = reflector_gbuffer(scene, 1, f)
            mesh = scene.world_mesh(1, f, proxy=True)
            clip = np.c_[mesh.vertices, np.ones(mesh.n_vertices)] @ cam.view_proj().T
            rel = naive_gl_interpolate(clip, mesh.faces, gb.triangle, mesh.vertices - cam.eye, cam.width, cam.height)
            nrm = naive_gl_interpolate(clip, mesh.faces, gb.triangle, mesh.normals, cam.width, cam.height, True)
            assert not np.array_equal(rel, gb.position)
            driver.method.given = {1: GBuffer(rel, nrm, gb.mask, gb.depth, gb.triangle, gb.view_proj, gb.origin)}
            write_npz(cand / name / f"frame_{f:04d}.npz", **driver.render_frame(f).arrays)
    s = check(golden, cand, cases=["sphere", "ellipsoid"], profile="gpu")
    assert s["passed"], [f.line() for f in s["_findings"] if f.status == "fail"]
    assert {f.key for f in s["_findings"] if f.status == "accepted"} >= {"gbuffer_position_1", "gbuffer_normal_1"}
    s = check(golden, cand, cases=["sphere", "ellipsoid"])
    assert not s["passed"]
    assert {"gbuffer_position_1", "gbuffer_normal_1"} <= {f.key for f in s["_findings"] if f.status == "fail"}
