"""The reflection-point search against plain references, analytic truth and its own contract."""

import os
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import refsoft
from naive import naive_scores, naive_search
from refsoft import Camera, Mesh, Scene, SceneObject, Transform, primitives, raster, search
from refsoft.truth.analytic import sphere_reflection_points
from refsoft.search.reflect import reflect, reflector_gbuffer
from refsoft.scene import scene_vertices
from refsoft._parallel import parallel_range
from refsoft.search import _kernels

W, H = 320, 240


@pytest.fixture(scope="module")
def sphere_case():
    scene = refsoft.load_scene("sphere", width=W, height=H)
    verts, owner = scene_vertices(scene)
    gb = reflector_gbuffer(scene, 1)
    return scene, verts, gb


def ellipsoid_scene(scale=(1.4, 1.0, 0.8), rotate=(0, 30, 0)):
    base = refsoft.load_scene("sphere", width=W, height=H)
    ell = SceneObject("ellipsoid", primitives.icosphere(5), (0.9, 0.9, 0.9),
                      Transform((0, 0, 0), rotate, scale), reflector=True)
    return Scene((ell,) + base.objects[1:], base.camera, None, "ellipsoid")


def exhaustive(gb, eye, verts, inverse=False):
    """Best score over the whole G-buffer per vertex (the kernel's own score, checked elsewhere)."""
    dt = gb.position.dtype.type
    G, mask, conv, (r0, c0) = search._packed(gb, eye)
    best = np.empty(len(verts), dtype=dt)
    where = np.empty((len(verts), 2), dtype=np.int64)
    field = np.full(mask.shape, -np.inf, dtype=dt)
    for i, v in enumerate(verts):
        parallel_range(_kernels.score_field, len(mask), G, mask, (v - gb.origin).astype(dt), inverse, conv, field)
        k = int(np.argmax(field))
        best[i] = field.flat[k]
        where[i] = divmod(k, field.shape[1])
    where += [r0, c0]
    return best, where


# --------------------------------------------------------------------------- kernel vs reference
@pytest.mark.parametrize("neighbourhood", ["cross", "box"])
@pytest.mark.parametrize("inverse", ["plane", "search"])
@pytest.mark.parametrize("precision", ["float32", "float64"])
def test_kernel_equals_plain_reference(sphere_case, neighbourhood, inverse, precision):
    scene, verts, _ = sphere_case
    gb = reflector_gbuffer(scene, 1, precision=precision)
    dt = gb.position.dtype.type
    rng = np.random.default_rng(3)
    sample = rng.choice(len(verts), 150, replace=False)
    res = search.search(gb, scene.camera.eye, verts[sample], neighbourhood, inverse)
    start = search.start_pixel(gb.mask)
    eye = (scene.camera.eye - gb.origin).astype(dt)
    hidden_seen = 0
    for j, i in enumerate(sample):
        pix, s, m, it, fl = naive_search(gb.position, gb.normal, gb.mask, eye, (verts[i] - gb.origin).astype(dt),
                                         start, neighbourhood, res.cap, dt, inverse == "search")
        assert tuple(res.pixel[j]) == pix
        assert res.iterations[j] == it and res.flags[j] == fl
        assert res.score[j] == s and res.margin[j] == m  # bit for bit
        hidden_seen += fl & 1
    assert hidden_seen > 0  # the sample exercises hidden vertices too


def test_score_is_float32_arithmetic_bit_for_bit(sphere_case):
    scene, verts, gb = sphere_case
    eye = (scene.camera.eye - gb.origin).astype(np.float32)
    P, N = gb.position[gb.mask], gb.normal[gb.mask]
    G, mask, conv, (r0, c0) = search._packed(gb, scene.camera.eye)
    differs = 0
    for inverse in (False, True):
        for v in verts[::400]:
            vr = (v - gb.origin).astype(np.float32)
            field = np.full(gb.mask.shape, np.nan, dtype=np.float32)
            parallel_range(_kernels.score_field, len(mask), G, mask, vr, inverse, conv,
                           field[r0:r0 + mask.shape[0], c0:c0 + mask.shape[1]])
            ref = naive_scores(P, N, eye, vr, np.float32, inverse)
            np.testing.assert_array_equal(field[gb.mask], ref)
            in64 = naive_scores(P.astype(np.float64), N.astype(np.float64), eye.astype(np.float64),
                                vr.astype(np.float64), np.float64, inverse).astype(np.float32)
            differs += int(np.sum(in64 != ref))
    assert differs > 100  # float64 arithmetic rounded to float32 is not what the kernel computes


# --------------------------------------------------------------------------- global optimum
def _optimum_share(scene, neighbourhood, rim=0):
    """Share of visible vertices whose search ends on the exhaustive optimum; with ``rim`` > 0,
    only vertices whose optimum lies at least ``rim`` pixels inside the reflector's mask."""
    from scipy import ndimage

    verts, _ = scene_vertices(scene)
    gb = reflector_gbuffer(scene, 1)
    res = search.search(gb, scene.camera.eye, verts, neighbourhood)
    visible = np.nonzero((res.flags & (search.HIDDEN | search.CULLED)) == 0)[0]
    best, where = exhaustive(gb, scene.camera.eye, verts[visible])
    inside = ndimage.distance_transform_edt(gb.mask)[where[:, 0], where[:, 1]] >= rim
    visible, best, where = visible[inside], best[inside], where[inside]
    hit = res.score[visible] == best
    for k in np.nonzero(~hit)[0][:10]:
        d = np.hypot(*(res.pixel[visible[k]] - where[k]))
        print(f"{neighbourhood} miss: vertex {visible[k]} found {tuple(res.pixel[visible[k]])} "
              f"score {res.score[visible[k]]:.7f} margin {res.margin[visible[k]]:.2e}, optimum {tuple(where[k])} "
              f"score {best[k]:.7f}, {d:.1f} px away")
    print(f"{scene.name} {neighbourhood} (rim {rim}): {hit.mean():.5f} of {len(visible)} vertices at the optimum")
    return hit.mean(), len(visible)


@pytest.mark.parametrize("neighbourhood", ["cross", "box"])
def test_sphere_search_finds_the_global_optimum(neighbourhood):
    share, n = _optimum_share(refsoft.load_scene("sphere", width=W, height=H), neighbourhood)
    assert n > 2000
    assert share >= 0.999


# On an ellipsoid the discrete score field has ridges: along the silhouette's staircase (where
# BORDER is flagged) and, inside, along the long axis when it runs diagonally on screen, where
# four-neighbour steps stop. Vertices whose optimum lies on the rim (within 3 px of an uncovered
# pixel) are left out of the floors; docs/method.md reports them (measured: box 94.9-99.9%,
# cross 80-98% over all visible vertices of the ellipsoids below).
@pytest.mark.parametrize("neighbourhood, floor", [("box", 0.999), ("cross", 0.99)])
def test_ellipsoid_search_finds_the_global_optimum(neighbourhood, floor):
    share, n = _optimum_share(ellipsoid_scene(), neighbourhood, rim=3)
    assert n > 2000
    assert share >= floor


@pytest.mark.parametrize("scale, rotate", [((1.5, 0.9, 0.9), (0, 0, 20)), ((1.7, 0.8, 0.6), (0, 35, 20))])
def test_box_copes_with_diagonal_ridges_where_cross_does_not(scale, rotate):
    scene = ellipsoid_scene(scale, rotate)
    box, n = _optimum_share(scene, "box", rim=3)
    cross, _ = _optimum_share(scene, "cross", rim=3)
    assert n > 2000
    assert box >= 0.999
    assert cross < box  # the reason to offer box (measured: cross 0.97 and 0.87 here)


# --------------------------------------------------------------------------- planar mirror
def test_planar_mirror_virtual_vertices_are_exact_mirror_images():
    cam = Camera(eye=(0.5, 1.0, 4.0), target=(0, 0, -2), width=W, height=H, fov_y=50)
    mirror = SceneObject("mirror", primitives.plane_grid((8.0, 6.0), (8, 6)), (0.9, 0.9, 0.9),
                         Transform((0, 0, -2.0), (90.0, 0, 0)), reflector=True, open=True)  # faces +z
    thing = SceneObject("thing", primitives.icosphere(3, 0.5), (1, 0, 0), Transform((0.6, -0.2, 0.5)))
    box = SceneObject("box", primitives.box((0.6, 0.6, 0.6), 3), (0, 0, 1), Transform((-0.8, 0.3, 0.2)))
    scene = Scene((mirror, thing, box), cam, None, "planar")
    verts, _, refl = reflect(scene)
    r = refl[1]
    ok = (r.result.flags & (search.HIDDEN | search.CULLED | search.BORDER)) == 0
    assert ok.sum() > 0.9 * len(verts)
    n = np.array([0.0, 0.0, 1.0])
    exact = verts - 2 * ((verts - [0, 0, -2.0]) @ n)[:, None] * n
    err = np.abs(r.virtual.astype(np.float64) - exact)[ok]
    assert err.max() < 1e-5 * np.abs(exact).max() * 8  # a few float32 ULP of the eye-relative values
    win = cam.project(exact[ok])
    centre = np.c_[r.result.pixel[ok, 1] + 0.5, H - r.result.pixel[ok, 0] - 0.5]
    dist = np.hypot(*(win[:, :2] - centre).T)
    assert dist.max() <= 1.0, dist.max()


# --------------------------------------------------------------------------- analytic sphere
def test_sphere_reflection_pixel_within_one_pixel_of_exact(sphere_case):
    scene, verts, gb = sphere_case
    res = search.search(gb, scene.camera.eye, verts)
    exact = sphere_reflection_points([0, 0, 0], 1.0, scene.camera.eye, verts)
    visible = np.all(np.isfinite(exact), axis=1) & ((res.flags & search.HIDDEN) == 0)
    assert visible.sum() > 2500
    win = scene.camera.project(exact[visible])
    # the pixel holding the exact point's projection, and the found pixel: at most 1 apart
    exact_pixel = np.c_[H - 1 - np.floor(win[:, 1]), np.floor(win[:, 0])].astype(int)
    assert np.abs(exact_pixel - res.pixel[visible]).max() <= 1
    centre = np.c_[res.pixel[visible, 1] + 0.5, H - res.pixel[visible, 0] - 0.5]
    dist = np.hypot(*(win[:, :2] - centre).T)
    print(f"distance to the exact reflection point: max {dist.max():.3f} px, mean {dist.mean():.3f} px")
    # from the pixel centre: within 1 px except at grazing angles on the silhouette, where the
    # tessellated sphere's rim lies inside the true one (those are flagged BORDER)
    inner = (res.flags[visible] & search.BORDER) == 0
    assert dist[inner].max() <= 1.0


@pytest.mark.parametrize("neighbourhood, floor", [("box", 1.0), ("cross", 0.9)])
def test_inverse_search_finds_where_the_eye_sees_the_hidden_vertex(sphere_case, neighbourhood, floor):
    scene, verts, gb = sphere_case
    res = search.search(gb, scene.camera.eye, verts, neighbourhood, inverse="search")
    hidden = (res.flags & search.HIDDEN) != 0
    # the eye ray towards V meets the ball where V projects; keep V's whose projection is on it
    win = scene.camera.project(verts)
    col, row = np.floor(win[:, 0]).astype(int), H - 1 - np.floor(win[:, 1]).astype(int)
    inside = (col >= 1) & (col < W - 1) & (row >= 1) & (row < H - 1)
    sel = hidden & inside
    sel[sel] = gb.mask[row[sel], col[sel]]
    idx = np.nonzero(sel)[0]
    assert len(idx) > 50
    best, _ = exhaustive(gb, scene.camera.eye, verts[idx], inverse=True)
    at_optimum = res.score[idx] == best
    # the inverse score's optimum is where the eye sees V: the found pixel holds V's projection
    # or touches it (measured: at most 1.17 px from the pixel centre, on the rim)
    off = np.abs(np.c_[row[idx], col[idx]] - res.pixel[idx]).max(axis=1)
    assert np.all(off[at_optimum] <= 1), off[at_optimum].max()
    # four-neighbour steps stop on the inverse score's diagonal ridges more often (measured 0.945)
    print(f"{neighbourhood}: {at_optimum.mean():.3f} of {len(idx)} hidden vertices reach the inverse optimum")
    assert at_optimum.mean() >= floor
    v = search.virtual_vertices(gb, res, verts)
    np.testing.assert_allclose(v[idx], verts[idx], atol=1e-5)  # V' = V in search mode


def test_hidden_vertex_modes(sphere_case):
    scene, verts, gb = sphere_case
    res = search.search(gb, scene.camera.eye, verts, inverse="plane")
    hidden = (res.flags & search.HIDDEN) != 0
    plane = search.virtual_vertices(gb, res, verts)
    disc = search.virtual_vertices(gb, search.SearchResult(res.pixel, res.score, res.margin, res.iterations,
                                                           res.flags, "cross", "discard", res.cap), verts)
    p = gb.position[res.pixel[:, 0], res.pixel[:, 1]].astype(np.float64) + gb.origin
    n = gb.normal[res.pixel[:, 0], res.pixel[:, 1]].astype(np.float64)
    d = verts - p
    dn = np.sum(d * n, axis=1)
    eq1 = p + 2 * n * dn[:, None] - d
    mirror = verts - 2 * dn[:, None] * n
    np.testing.assert_allclose(plane[hidden], eq1[hidden], atol=2e-5)
    np.testing.assert_allclose(plane[~hidden], mirror[~hidden], atol=2e-5)
    np.testing.assert_allclose(disc, mirror, atol=2e-5)
    assert hidden.sum() > 50


# --------------------------------------------------------------------------- coherence
def test_static_coherence_takes_one_iteration(sphere_case):
    scene, verts, gb = sphere_case
    cold = search.search(gb, scene.camera.eye, verts)
    warm = search.search(gb, scene.camera.eye, verts, previous=cold.pixel)
    assert np.all(warm.iterations == 1)
    np.testing.assert_array_equal(warm.pixel, cold.pixel)
    assert np.all((warm.flags & search.RESTARTED) == 0)


def test_coherent_equals_cold_where_the_optimum_is_unique():
    scene = refsoft.load_scene("sphere", width=W, height=H)
    verts, _ = scene_vertices(scene)
    first = search.search(reflector_gbuffer(scene, 1), scene.camera.eye, verts)
    from dataclasses import replace
    moved = replace(scene, camera=replace(scene.camera, eye=scene.camera.eye + [0.15, 0.05, -0.1]))
    gb = reflector_gbuffer(moved, 1)
    cold = search.search(gb, moved.camera.eye, verts)
    warm = search.search(gb, moved.camera.eye, verts, previous=first.pixel)
    assert warm.iterations.mean() < 0.5 * cold.iterations.mean()
    best, _ = exhaustive(gb, moved.camera.eye, verts)
    unique = (cold.score == best) & (warm.score == best) & (cold.margin > 0) & ((cold.flags & search.HIDDEN) == 0)
    assert unique.sum() > 2000
    np.testing.assert_array_equal(warm.pixel[unique], cold.pixel[unique])


def test_restart_when_previous_pixel_is_uncovered(sphere_case):
    scene, verts, gb = sphere_case
    prev = np.zeros((len(verts), 2), dtype=np.int32)  # (0, 0) is background
    res = search.search(gb, scene.camera.eye, verts, previous=prev)
    cold = search.search(gb, scene.camera.eye, verts)
    assert np.all(res.flags & search.RESTARTED)
    np.testing.assert_array_equal(res.pixel, cold.pixel)
    with pytest.raises(refsoft.RefsoftError, match="outside"):
        search.search(gb, scene.camera.eye, verts, previous=np.full((len(verts), 2), 10**6))


@pytest.mark.parametrize("dtype", [np.int32, np.int64, np.int16, np.uint16])
def test_previous_pixels_of_every_kind_and_dtype(sphere_case, dtype):
    """Each vertex's own previous pixel: none (-1, -1), still covered, or no longer covered
    (restart), in any integer dtype: the same results as searching each group alone."""
    scene, verts, gb = sphere_case
    cold = search.search(gb, scene.camera.eye, verts)
    kind = np.arange(len(verts)) % 3
    prev = np.where((kind == 0)[:, None], -1, np.where((kind == 1)[:, None], cold.pixel, 0))
    if dtype == np.uint16:
        prev = np.where(prev < 0, 0, prev)  # no (-1, -1) in an unsigned dtype: the background
        kind = np.where(kind == 0, 2, kind)
    res = search.search(gb, scene.camera.eye, verts, previous=prev.astype(dtype))
    for k, ref in ((0, cold), (1, search.search(gb, scene.camera.eye, verts, previous=cold.pixel)), (2, cold)):
        sel = kind == k
        for name in ("pixel", "score", "margin", "iterations"):
            np.testing.assert_array_equal(getattr(res, name)[sel], getattr(ref, name)[sel], err_msg=f"{k} {name}")
        np.testing.assert_array_equal(res.flags[sel], ref.flags[sel] | (search.RESTARTED if k == 2 else 0))
    bad = prev.astype(np.int64)
    bad[7] = (0, -3)
    with pytest.raises(refsoft.RefsoftError, match="vertex 7 is outside"):
        search.search(gb, scene.camera.eye, verts, previous=bad)


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 3000), st.integers(0, 2000), st.integers(0, 2**32 - 1))
def test_search_order_is_the_stable_argsort(n_keys, n, seed):
    keys = np.random.default_rng(seed).integers(0, n_keys, n)
    order, rank = np.full(n, -1, np.int64), np.full(n, -1, np.int64)
    _kernels.order_by_key(keys, np.zeros(n_keys + 1, np.int64), order, rank)
    np.testing.assert_array_equal(order, np.argsort(keys, kind="stable"))
    np.testing.assert_array_equal(rank[order], np.arange(n))


# --------------------------------------------------------------------------- termination
def _gbuffer(P, N, mask):
    h, w = mask.shape
    return raster.GBuffer(np.asarray(P, np.float32), np.asarray(N, np.float32), mask, np.ones((h, w), np.float32),
                          np.where(mask, 0, -1).astype(np.int32), np.eye(4), np.zeros(3))


def test_adversarial_gbuffers_terminate_without_nan():
    rng = np.random.default_rng(0)
    h, w = 24, 32
    verts = rng.normal(size=(200, 3)) * 3
    eye = np.array([0.0, 0.0, 5.0])
    cases = {}
    # a plateau: every pixel the same point and normal (all scores equal: never moves)
    cases["plateau"] = (np.zeros((h, w, 3)), np.tile([0, 0, 1.0], (h, w, 1)), np.ones((h, w), bool))
    one = np.zeros((h, w), bool)
    one[5, 7] = True
    cases["one pixel"] = (rng.normal(size=(h, w, 3)), np.tile([0, 0, 1.0], (h, w, 1)), one)
    cut = np.zeros((h, w), bool)
    cut[:, :10] = True
    yy, xx = np.mgrid[0:h, 0:w]
    sph = np.stack([(xx - 3) / 10, (yy - 12) / 10, np.ones_like(xx, dtype=float)], -1)
    cases["cut by the border"] = (sph, sph / np.linalg.norm(sph, axis=-1, keepdims=True), cut)
    cases["random normals"] = (rng.normal(size=(h, w, 3)), rng.normal(size=(h, w, 3)), rng.random((h, w)) > 0.3)
    cases["zero normals"] = (rng.normal(size=(h, w, 3)), np.zeros((h, w, 3)), np.ones((h, w), bool))
    cases["vertex on a texel"] = (np.zeros((h, w, 3)), np.tile([0, 0, 1.0], (h, w, 1)), np.ones((h, w), bool))
    for name, (P, N, mask) in cases.items():
        gb = _gbuffer(P, N, mask)
        vv = np.zeros((1, 3)) if name == "vertex on a texel" else verts
        for nb in ("cross", "box"):
            for inv in ("plane", "search"):
                res = search.search(gb, eye, vv, nb, inv)
                assert np.all(np.isfinite(res.score)) and np.all(np.isfinite(res.margin)), name
                capped = (res.flags & search.CAPPED) != 0
                limit = 2 * res.cap
                assert np.all(res.iterations[~capped] <= limit) and np.all(res.iterations <= limit), name
                assert np.all(mask[res.pixel[:, 0], res.pixel[:, 1]]), name
                assert np.all(np.isfinite(search.virtual_vertices(gb, res, vv))), name
                if name == "plateau":
                    assert np.all(res.iterations <= 2) and np.all(res.pixel == search.start_pixel(mask))
                if name == "cut by the border":
                    assert np.all(res.flags[res.pixel[:, 1] == 0] & search.BORDER)
    empty = _gbuffer(np.zeros((h, w, 3)), np.zeros((h, w, 3)), np.zeros((h, w), bool))
    res = search.search(empty, eye, verts)
    assert np.all(res.flags == search.CULLED) and np.all(res.pixel == -1) and np.all(res.iterations == 0)
    np.testing.assert_array_equal(search.virtual_vertices(empty, res, verts), verts.astype(np.float32))


def test_cap_is_respected_and_flagged(sphere_case):
    scene, verts, gb = sphere_case
    res = search.search(gb, scene.camera.eye, verts, cap=3)
    capped = (res.flags & search.CAPPED) != 0
    assert capped.sum() > 100
    assert np.all(res.iterations[(res.flags & search.HIDDEN) == 0] <= 3)
    assert np.all(res.iterations <= 6)


def test_start_pixel_rule():
    m = np.zeros((5, 7), bool)
    m[0, 0] = m[4, 6] = True
    # bbox centre (2, 3) is uncovered; (0, 0) and (4, 6) are equally far: the smaller row wins
    assert search.start_pixel(m) == (0, 0)
    m[2, 3] = True
    assert search.start_pixel(m) == (2, 3)
    assert search.start_pixel(np.zeros((3, 3), bool)) is None


@settings(max_examples=200, deadline=None)
@given(st.integers(1, 12), st.integers(1, 12), st.integers(0, 2**32 - 1), st.floats(0.02, 0.6))
def test_start_pixel_equals_the_plain_rule(h, w, seed, density):
    from naive import naive_start_pixel

    m = np.random.default_rng(seed).random((h, w)) < density
    assert search.start_pixel(m) == naive_start_pixel(m)


# --------------------------------------------------------------------------- traces
def test_trace_ends_where_the_kernel_ends_for_every_vertex(sphere_case):
    scene, verts, gb = sphere_case
    for inverse in ("plane", "search"):
        res = search.search(gb, scene.camera.eye, verts, "cross", inverse)
        for i in range(0, len(verts), 1 if inverse == "plane" else 7):
            tr = search.trace_search(gb, scene.camera.eye, verts[i], "cross", inverse)
            assert tr.pixel == list(res.pixel[i]) and tr.iterations == res.iterations[i]
            assert tr.flags == res.flags[i] and tr.score == float(res.score[i])
            assert len(tr.steps) == tr.iterations


def test_trace_records_every_candidate():
    scene = refsoft.load_scene("sphere", width=W, height=H)
    gb = reflector_gbuffer(scene, 1)
    verts, _ = scene_vertices(scene)
    tr = search.trace_search(gb, scene.camera.eye, verts[1234], "box")
    first = tr.steps[0]
    assert [c["name"] for c in first["candidates"]] == ["current", "left", "up", "right", "down", "up-left",
                                                       "up-right", "down-right", "down-left"]
    assert tr.start == list(search.start_pixel(gb.mask))
    for a, b in zip(tr.steps, tr.steps[1:]):
        assert a["move_to"] == b["pixel"]
        best = max(c["score"] for c in a["candidates"] if c["score"] is not None)
        assert [c for c in a["candidates"] if c["pixel"] == a["move_to"]][0]["score"] == best
    assert tr.steps[-1]["move_to"] is None and tr.stop == "converged"
    table = tr.table()
    assert "up-left" in table and "result: pixel" in table
    import json
    assert json.loads(tr.to_json())["result"]["iterations"] == tr.iterations


# --------------------------------------------------------------------------- scene level
def test_widened_frustum_captures_a_clipped_reflector():
    base = refsoft.load_scene("sphere", width=W, height=H)
    from dataclasses import replace
    cam = replace(base.camera, target=(2.5, 0.0, 0.0))  # the ball is cut by the left border
    scene = replace(base, camera=cam)
    _, _, narrow = reflect(scene)
    _, _, wide = reflect(scene, widen=1.5)
    gbn, gbw = narrow[1].gbuffer, wide[1].gbuffer
    assert gbw.mask.shape == (360, 480)
    assert gbn.mask[:, 0].any() and not gbw.mask[:, 0].any()
    border_n = (narrow[1].result.flags & search.BORDER) != 0
    border_w = (wide[1].result.flags & search.BORDER) != 0
    assert border_w.sum() < border_n.sum()


def test_multiple_reflectors_are_independent_and_use_closed_proxies():
    base = refsoft.load_scene("sphere", width=W, height=H)
    bowl = primitives.uv_sphere(16, 32, 0.5)
    open_bowl = Mesh(bowl.vertices, bowl.faces[: len(bowl.faces) // 2], bowl.normals)  # upper half only
    second = SceneObject("bowl", open_bowl, (0.8, 0.8, 0.8), Transform((-1.6, 0.8, 0.0)), reflector=True,
                         closed_proxy=bowl)
    scene = Scene(base.objects + (second,), base.camera, None, "two")
    v, owner, both = reflect(scene)
    _, _, alone = reflect(scene, reflectors=[1])
    np.testing.assert_array_equal(both[1].result.pixel, alone[1].result.pixel)
    np.testing.assert_array_equal(both[1].virtual, alone[1].virtual)
    assert set(both) == {1, 7} and 7 not in owner and 1 not in owner
    proxy_gb = raster.gbuffer(scene.world_mesh(7, proxy=True), scene.camera, origin=scene.camera.eye)
    np.testing.assert_array_equal(both[7].gbuffer.mask, proxy_gb.mask)
    open_gb = raster.gbuffer(scene.world_mesh(7), scene.camera)
    assert proxy_gb.mask.sum() > open_gb.mask.sum()


# --------------------------------------------------------------------------- determinism
SCRIPT = r"""
import hashlib, numpy as np, refsoft
from refsoft.search.reflect import reflect
from refsoft.search.refine import refine
s = refsoft.load_scene("sphere", width=200, height=150)
h = hashlib.sha256()
for nb in ("cross", "box"):
    for inv in ("plane", "search"):
        v, o, r = reflect(s, neighbourhood=nb, inverse=inv)
        res = r[1].result
        refined = refine(r[1].gbuffer, s.camera.eye, v, res)
        for a in (res.pixel, res.score, res.margin, res.iterations, res.flags, r[1].virtual) + refined:
            h.update(np.ascontiguousarray(a).tobytes())
print(h.hexdigest())
"""


def test_search_bit_identical_across_thread_counts():
    out = []
    for threads in (1, 2, 2):
        env = dict(os.environ, NUMBA_NUM_THREADS=str(threads))
        r = subprocess.run([sys.executable, "-c", SCRIPT], env=env, capture_output=True, text=True, check=True)
        out.append(r.stdout.strip().splitlines()[-1])
    assert len(out[0]) == 64 and out[0] == out[1] == out[2]


def test_bookkeeping_on_one_thread_changes_nothing(sphere_case, monkeypatch):
    """A search of at most SERIAL_MAX_VERTICES vertices orders its vertices and results on the
    calling thread alone (``parallel_range(..., serial=True)``): the same results as when those
    passes are split among threads, and the thread count is left as it was, also when the search
    refuses its input."""
    from refsoft._parallel import thread_count

    scene, verts, gb = sphere_case
    before = thread_count()
    prev = np.tile([[H // 2, W // 2]], (len(verts), 1))
    serial = [search.search(gb, scene.camera.eye, verts, "box", "search", p) for p in (None, prev)]
    assert thread_count() == before
    monkeypatch.setattr(search, "SERIAL_MAX_VERTICES", 0)
    for p, one in zip((None, prev), serial):
        both = search.search(gb, scene.camera.eye, verts, "box", "search", p)
        for a, b in zip(astuple_arrays(one), astuple_arrays(both)):
            np.testing.assert_array_equal(a, b)
    monkeypatch.undo()
    with pytest.raises(refsoft.RefsoftError):
        search.search(gb, scene.camera.eye, verts, previous=np.full((len(verts), 2), H + 5))
    assert thread_count() == before


def astuple_arrays(res):
    return res.pixel, res.score, res.margin, res.iterations, res.flags


@pytest.mark.parametrize("kwargs, message", [
    (dict(neighbourhood="hex"), "neighbourhood must be one of"),
    (dict(inverse="mirror"), "inverse must be one of"),
    (dict(cap=0), "cap must be a positive integer"),
    (dict(cap=2.5), "cap must be a positive integer"),
    (dict(eye=(0, 0)), "eye must be 3 numbers"),
    (dict(eye=(0, np.nan, 0)), "non-finite"),
])
def test_bad_search_options(sphere_case, kwargs, message):
    scene, verts, gb = sphere_case
    args = dict(eye=scene.camera.eye, neighbourhood="cross", inverse="plane", cap=None)
    args.update(kwargs)
    with pytest.raises(refsoft.RefsoftError, match=message):
        search.search(gb, args["eye"], verts[:5], args["neighbourhood"], args["inverse"], cap=args["cap"])
    with pytest.raises(refsoft.RefsoftError, match=message):
        search.trace_search(gb, args["eye"], verts[0], args["neighbourhood"], args["inverse"], cap=args["cap"])
    with pytest.raises(refsoft.RefsoftError, match="vertices must have shape"):
        search.search(gb, scene.camera.eye, verts[:, :2])
    with pytest.raises(refsoft.RefsoftError, match="GBuffer"):
        search.search(gb.position, scene.camera.eye, verts)


def test_results_do_not_depend_on_vertex_order(sphere_case):
    """The kernel searches in a cache-friendly order and scatters back: a permuted input gives
    the permuted output, bit for bit (cold and coherent)."""
    scene, verts, gb = sphere_case
    perm = np.random.default_rng(1).permutation(len(verts))
    a = search.search(gb, scene.camera.eye, verts)
    b = search.search(gb, scene.camera.eye, verts[perm])
    for x, y in ((a.pixel, b.pixel), (a.score, b.score), (a.margin, b.margin), (a.iterations, b.iterations),
                 (a.flags, b.flags)):
        np.testing.assert_array_equal(x[perm], y)
    c = search.search(gb, scene.camera.eye, verts, previous=a.pixel)
    d = search.search(gb, scene.camera.eye, verts[perm], previous=a.pixel[perm])
    np.testing.assert_array_equal(c.pixel[perm], d.pixel)
    np.testing.assert_array_equal(c.iterations[perm], d.iterations)


def _recording_search(gb, eye, verts, neighbourhood, inverse, cap, starts=None):
    """Every vertex searched by the recording walk (search_one with a record buffer, as
    trace_search calls it), one call per vertex: pixel, score, margin, iterations, flags."""
    G, mask, conv, (r0, c0) = search._packed(gb, eye)
    dt = gb.position.dtype
    n_cand = search.NEIGHBOURHOODS[neighbourhood]
    sr, sc = search.start_pixel(gb.mask)
    record = np.zeros((1, _kernels.RECORD_WIDTH), dtype=dt)
    scratch, seen = np.zeros((2, 9), dtype=dt), np.zeros((2, 9), dtype=bool)
    out = []
    for i, v in enumerate(verts):
        vr = (v - gb.origin).astype(dt)
        r, c = (sr, sc) if starts is None else starts[i]
        res = _kernels.search_one(G, mask, vr, r - r0, c - c0, n_cand, cap, inverse == "search", conv, record,
                                  scratch, seen)
        out.append((res[0] + r0, res[1] + c0, res[2], res[3], res[4], res[5]))
    return out


@pytest.mark.parametrize("name", ["sphere", "ellipsoid", "torus", "concave"])
def test_kernel_equals_the_recording_walk(name):
    """The parallel kernel (no record buffer) against the walk that records (the trace's):
    every output, bit for bit, for every vertex; also capped searches. A faster walk for the
    unrecorded case must keep this passing."""
    scene = refsoft.load_scene(name, width=160, height=120)
    verts, _ = scene_vertices(scene)
    gb = reflector_gbuffer(scene, scene.reflector_ids[0])
    eye = scene.camera.eye
    for nb, inverse, cap in (("cross", "plane", None), ("cross", "search", None), ("cross", "search", 3),
                             ("box", "plane", None), ("box", "search", None), ("box", "search", 3)):
        res = search.search(gb, eye, verts, nb, inverse, cap=cap)
        ref = _recording_search(gb, eye, verts, nb, inverse, res.cap)
        got = list(zip(res.pixel[:, 0], res.pixel[:, 1], res.score, res.margin, res.iterations, res.flags))
        bad = [i for i, (a, b) in enumerate(zip(got, ref)) if tuple(a) != tuple(b)]
        assert not bad, f"{len(bad)} vertices differ, first {bad[0]}: {got[bad[0]]} vs {ref[bad[0]]}"
        if cap == 3:
            assert np.any(res.flags & search.CAPPED)
        if inverse == "search" and name != "concave":  # inside a bowl nothing is hidden
            assert np.any(res.flags & search.HIDDEN)


@pytest.mark.parametrize("rule", ["mirror", "unfold"])
@pytest.mark.parametrize("precision", ["float32", "float64"])
@pytest.mark.parametrize("inverse", ["plane", "search", "discard"])
def test_virtual_vertex_kernel_equals_numpy_bit_for_bit(precision, inverse, rule):
    from naive import naive_virtual_vertices

    from refsoft.search.refine import refine

    for name in ("sphere", "ellipsoid", "concave"):
        scene = refsoft.load_scene(name, width=96, height=72)
        verts, _ = scene_vertices(scene)
        cam = scene.camera
        gb = raster.gbuffer(scene.world_mesh(1, proxy=True), cam, precision, origin=cam.eye)
        res = search.search(gb, cam.eye, verts, "cross", inverse)
        if name == "sphere":
            assert np.any(res.flags & search.HIDDEN)
        got = search.virtual_vertices(gb, res, verts, relative=True, rule=rule, eye=cam.eye)
        assert got.dtype == np.dtype(precision)
        np.testing.assert_array_equal(got, naive_virtual_vertices(gb, res, verts, rule=rule, eye=cam.eye))
        p, n, _ = refine(gb, cam.eye, verts, res)
        np.testing.assert_array_equal(
            search.virtual_vertices(gb, res, verts, relative=True, surface=(p, n), rule=rule, eye=cam.eye),
            naive_virtual_vertices(gb, res, verts, surface=(p, n), rule=rule, eye=cam.eye))
    # culled vertices (an empty G-buffer) give V itself
    empty = raster.gbuffer(primitives.icosphere(1, 0.1), Camera(eye=(0, 0, -5), target=(0, 0, -10)), precision)
    res = search.search(empty, (0, 0, -5), verts[:4], "cross", inverse)
    np.testing.assert_array_equal(search.virtual_vertices(empty, res, verts[:4], rule=rule, eye=(0, 0, -5)),
                                  verts[:4].astype(precision))
