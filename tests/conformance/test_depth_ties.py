"""Depth ties in the G-buffer (spec section 8): the golden frames hold the oracle's depth margin,
and `refsoft check` accepts a port's position and normal matching the next fragment only where
that margin is a tie (kitchen frame 2: the bowl's rim, where its inside and its outside meet)."""

import shutil

import numpy as np
import pytest

from naive import naive_depth_layers, naive_interpolate
from refsoft import constants
from refsoft.conformance.check import check
from refsoft.conformance.golden import case_by_name
from refsoft.io import read_npz, write_npz
from refsoft.raster import _setup
from refsoft.search.reflect import gbuffer_camera

BOUND = constants.DEPTH_TIE_K * constants.TIE_EPS


@pytest.fixture(scope="module")
def kitchen2():
    """Kitchen frame 2's bowl G-buffer by the NumPy reference: margin, and the winning and the
    next fragment's world positions and normals (float32, as saved)."""
    scene = case_by_name("kitchen").load()
    cam = gbuffer_camera(scene, 2)
    mesh = scene.world_mesh(1, 2, proxy=True)
    clip = _setup.transform_points(mesh.vertices, cam.view_proj())
    depth, _, which, depth2, _, which2, tris = naive_depth_layers(clip, mesh.faces, cam.width, cam.height)
    margin = np.where(which >= 0, depth2 - depth, np.inf).astype(np.float32)
    maps = []
    for w in (which, which2):
        rel = naive_interpolate(w, tris, mesh.vertices - cam.eye, mesh.faces, np.float32)
        pos = np.where((w >= 0)[..., None], rel.astype(np.float64) + cam.eye, 0.0).astype(np.float32)
        maps.append((pos, naive_interpolate(w, tris, mesh.normals, mesh.faces, np.float32, normalize=True)))
    return margin, maps


def test_golden_frames_hold_the_oracle_depth_margin(golden, kitchen2):
    margin, ((pos, nrm), _) = kitchen2
    G = read_npz(golden / "kitchen" / "frame_0002.npz")
    assert G["gbuffer_depth_margin_1"].dtype == np.float32
    np.testing.assert_array_equal(G["gbuffer_depth_margin_1"], margin)
    np.testing.assert_array_equal(G["gbuffer_position_1"], pos)  # the winner is the G-buffer's
    np.testing.assert_array_equal(G["gbuffer_normal_1"], nrm)
    ties = margin <= BOUND  # the frame has depth ties at the rim for the tests below to move, few of them
    assert ties.any() and ties.sum() < 0.01 * np.isfinite(margin).sum()


def _second_at(golden, tmp_path, pixels, maps):
    """A candidate whose G-buffer keeps the next fragment at ``pixels`` (kitchen frame 2)."""
    cand = tmp_path / "cand"
    cand.mkdir(parents=True)
    shutil.copytree(golden / "kitchen", cand / "kitchen")
    path = cand / "kitchen" / "frame_0002.npz"
    a = read_npz(path)
    del a["gbuffer_depth_margin_1"]  # the oracle's own, not a port's output
    (_, _), (pos2, nrm2) = maps
    for r, c in pixels:
        a["gbuffer_position_1"][r, c] = pos2[r, c]
        a["gbuffer_normal_1"][r, c] = nrm2[r, c]
    write_npz(path, **a)
    return cand


def test_the_next_fragment_is_accepted_at_a_tie_and_fails_elsewhere(golden, tmp_path, kitchen2):
    margin, maps = kitchen2
    (pos, nrm), (_, nrm2) = maps
    ties = np.argwhere(margin <= BOUND)
    angle = np.arccos(np.clip(np.einsum("ijk,ijk->ij", nrm.astype(np.float64), nrm2.astype(np.float64)), -1, 1))
    assert np.all(angle[tuple(ties.T)] > 1.0)  # the rim's inside against its outside: far beyond the float rule
    s = check(golden, _second_at(golden, tmp_path / "a", ties, maps), cases=["kitchen"], kinds=["gbuffer"])
    found = {f.key: f for f in s["_findings"] if f.frame == 2}
    assert s["passed"]
    for key in ("gbuffer_position_1", "gbuffer_normal_1"):
        assert found[key].status == "accepted" and f"{len(ties)} match the next fragment" in found[key].message
    # the next fragment where the margin is not a tie: the three smallest margins above the bound, and
    # some of the interior
    finite = np.argwhere(np.isfinite(margin) & (margin > BOUND))
    near = finite[np.argsort(margin[tuple(finite.T)], kind="stable")[:3]]
    off = np.concatenate([near, finite[::97]])
    s = check(golden, _second_at(golden, tmp_path / "b", off, maps), cases=["kitchen"], kinds=["gbuffer"])
    found = {f.key: f for f in s["_findings"] if f.frame == 2}
    assert not s["passed"]
    assert found["gbuffer_normal_1"].status == "fail" and found["gbuffer_normal_1"].count == len(off)
    assert found["gbuffer_position_1"].status == "fail"
