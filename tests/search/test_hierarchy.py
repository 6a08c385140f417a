"""Szabo's ray-cone hierarchy search (refsoft.search.hierarchy): the pyramid bounds what it
claims to, the search returns the exhaustive argmax wherever the optimum's ancestors contain the
vertex, traces end where the kernel ends, and frames render with it."""

import numba
import numpy as np
import pytest

import naive
import refsoft
from refsoft import cli, search
from refsoft.search.reflect import reflector_gbuffer
from refsoft.scene import scene_vertices
from refsoft.frame import FrameDriver, RenderOptions
from refsoft.search import _packed as packed, hierarchy

W, H = 160, 120


@pytest.fixture(scope="module", params=["sphere", "ellipsoid"])
def case(request):
    scene = refsoft.load_scene(request.param, width=W, height=H)
    gb = reflector_gbuffer(scene, 1)
    verts, _ = scene_vertices(scene)
    G, mask, conv, origin = packed(gb, scene.camera.eye)
    return scene, gb, verts, (G, mask, conv, origin), hierarchy.build(G, mask, conv)


def _level(pyr, lvl):
    sph, cone, offsets, sizes = pyr
    n = sizes[lvl]
    return (sph[offsets[lvl]:offsets[lvl] + n * n].reshape(n, n, 4).astype(np.float64),
            cone[offsets[lvl]:offsets[lvl] + n * n].reshape(n, n, 4).astype(np.float64))


def test_pyramid_bounds_its_children(case):
    pyr = case[4]
    sizes = pyr[3]
    assert sizes[-1] == 1 and all(a == 2 * b for a, b in zip(sizes, sizes[1:]))
    for lvl in range(1, len(sizes)):
        s_up, c_up = _level(pyr, lvl)
        s_dn, c_dn = _level(pyr, lvl - 1)
        for dr in (0, 1):
            for dc in (0, 1):
                ch_s, ch_c = s_dn[dr::2, dc::2], c_dn[dr::2, dc::2]
                live = ch_s[..., 3] >= 0
                assert np.all(s_up[..., 3][live] >= 0)
                d = np.linalg.norm(ch_s[..., :3] - s_up[..., :3], axis=-1)
                assert np.all((d + ch_s[..., 3] <= s_up[..., 3] * (1 + 1e-5) + 1e-5)[live])  # spheres enclose
                # the angle between axes by atan2 (acos of a float32 dot near 1 is off by ~4e-4 rad)
                ang = np.arctan2(np.linalg.norm(np.cross(ch_c[..., :3], c_up[..., :3]), axis=-1),
                                 np.einsum("...k,...k", ch_c[..., :3], c_up[..., :3]))
                assert np.all((ang + ch_c[..., 3] <= c_up[..., 3] + 1e-6)[live])  # cones enclose


def _contains64(s, c, v):
    w = v - s[:3]
    dist = np.linalg.norm(w)
    if dist <= s[3]:
        return np.inf
    ang = np.arctan2(np.linalg.norm(np.cross(w, c[:3])), w @ c[:3])
    return c[3] + np.arcsin(min(s[3] / dist, 1.0)) - ang  # > 0: contained, by this angle


def test_equals_the_exhaustive_argmax_where_the_optimum_is_reachable(case):
    scene, gb, verts, (G, mask, conv, (r0, c0)), pyr = case
    res = search.search(gb, scene.camera.eye, verts, method="hierarchy")
    eye = scene.camera.eye - gb.origin
    P, N = gb.position[r0:r0 + mask.shape[0], c0:c0 + mask.shape[1]], gb.normal[r0:r0 + mask.shape[0], c0:c0 + mask.shape[1]]
    levels = [_level(pyr, lvl) for lvl in range(len(pyr[3]))]
    checked = 0
    for i in range(0, len(verts), 3):
        if res.flags[i] & search.HIDDEN:
            continue
        v = verts[i] - gb.origin
        s = np.where(mask, naive.naive_scores(P, N, eye, v, np.float32), -3)
        order = np.argsort(s, axis=None)
        best, second = s.flat[order[-1]], s.flat[order[-2]]
        if best - second < 1e-6:
            continue  # a near-tie: either pixel is right
        r, c = np.unravel_index(order[-1], s.shape)
        reach = min(_contains64(levels[l][0][r >> l, c >> l], levels[l][1][r >> l, c >> l], v.astype(np.float64))
                    for l in range(1, len(levels) - 1))
        if reach < 1e-4:
            continue  # an ancestor does not contain the vertex (clearly): a hole of the pyramid
        checked += 1
        assert list(res.pixel[i]) == [r + r0, c + c0], i
    assert checked > 300


def test_trace_ends_where_the_kernel_ends(case):
    scene, gb, verts, _, _ = case
    res = search.search(gb, scene.camera.eye, verts, method="hierarchy")
    for i in range(0, len(verts), 11):
        tr = search.trace_hierarchy(gb, scene.camera.eye, verts[i])
        if res.flags[i] & search.CAPPED:
            assert tr.pixel is None
            continue
        assert tr.pixel == [int(x) for x in res.pixel[i]] and tr.tests <= res.iterations[i]
        if not res.flags[i] & search.HIDDEN:  # no inverse walk adds to the count
            assert tr.tests == res.iterations[i]
        assert tr.steps[-1]["event"] == "chosen" and tr.steps[0]["level"] == len(case[4][3]) - 1


def test_options_and_break_level(case):
    scene, gb, verts, _, _ = case
    coarse = search.search(gb, scene.camera.eye, verts, method="hierarchy", break_level=2)
    fine = search.search(gb, scene.camera.eye, verts, method="hierarchy")
    assert np.all(gb.mask[coarse.pixel[:, 0], coarse.pixel[:, 1]])
    assert coarse.iterations.mean() != fine.iterations.mean()
    with pytest.raises(refsoft.RefsoftError, match="cone_factor"):
        search.search(gb, scene.camera.eye, verts, method="hierarchy", cone_factor=0.5)
    with pytest.raises(refsoft.RefsoftError, match="trace_hierarchy"):
        search.trace_search(gb, scene.camera.eye, verts[0], "hierarchy")


def test_frames_render_deterministically_with_the_hierarchy():
    scene = refsoft.load_scene("quad", width=96, height=72)
    opts = RenderOptions(method="hierarchy")
    a = [FrameDriver(scene, opts).render_frame(f).arrays for f in (0,)][0]
    numba.set_num_threads(1)
    try:
        b = FrameDriver(scene, opts).render_frame(0).arrays
    finally:
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    for k in a:
        assert np.array_equal(a[k], b[k]), k
    assert not np.any(a["flags_1"] & search.RESTARTED)
    assert np.all(np.isfinite(a["score_1"]))


def test_cli_trace_and_render_with_the_hierarchy(tmp_path, capsys):
    assert cli.main(["trace", "sphere", "--vertex", "100", "--method", "hierarchy", "--width", "80", "--height", "60",
                     "--out", str(tmp_path / "t")]) == 0
    out = capsys.readouterr().out
    assert "ray-cone hierarchy" in out and "chosen" in out and (tmp_path / "t" / "trace.png").exists()
    assert '"kind":"hierarchy"' in (tmp_path / "t" / "trace.html").read_text()
    assert cli.main(["render", "sphere", "--method", "hierarchy", "--width", "48", "--height", "36",
                     "--out", str(tmp_path / "r")]) == 0
