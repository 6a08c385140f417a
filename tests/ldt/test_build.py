"""The LDT build against exact ray casts per texel (tests/naive.py), layer counts of known shapes,
the face table against the GL cube-map rule, determinism."""

import numba
import numpy as np
import pytest

from naive import naive_gl_cube_lookup, naive_ldt
import refsoft
from refsoft.ldt import constants as C
from refsoft.ldt.build import LDT, build_ldt, face_coords, is_closed, mirrored
from refsoft.scene import primitives as P
from refsoft.scene.mesh import Mesh


def merged(*parts):
    """One mesh of several (mesh, flip) parts: flip reverses the winding and the normals."""
    v, f, n, off = [], [], [], 0
    for m, flip in parts:
        v.append(m.vertices)
        f.append((m.faces[:, [0, 2, 1]] if flip else m.faces) + off)
        n.append(-m.normals if flip else m.normals)
        off += m.n_vertices
    return Mesh(np.concatenate(v), np.concatenate(f), np.concatenate(n))


def hollow_box():
    """A closed box with a closed cubic cavity (the cavity's faces point into it). Its side 1.1
    keeps the cavity's silhouette edges off the texel centres at R = 32."""
    return merged((P.box((2.0, 2.0, 2.0)), False), (P.box((1.1, 1.1, 1.1)), True))


SHAPES = {"sphere": lambda: P.icosphere(2), "hollow_box": hollow_box, "torus": lambda: P.torus(1.0, 0.3, 32, 16)}


def check_against_ray_casts(mesh, R):
    ldt = build_ldt(mesh, R)
    ref = naive_ldt(mesh.vertices, mesh.faces, R, is_closed(mesh))
    ok = ~ref["ambiguous"]
    assert ok.mean() > 0.8
    np.testing.assert_array_equal(ldt.count_raw[ok], ref["count"][ok])
    np.testing.assert_allclose(ldt.cube_center, ref["centre"], rtol=0, atol=1e-15)
    assert ldt.cube_half == pytest.approx(ref["half"], rel=1e-15)
    for j in range(ldt.n_layers):
        m = ok & (ref["count"] > j)
        assert m.sum() > 20
        np.testing.assert_array_equal(ldt.triangle[:, j][m], ref["triangle"][:, j][m])
        # snapping moves vertices by at most 1/512 px: 0.01 texel of the surface's slope covers it
        tol = 0.01 * ref["slope"][:, j][m] + 4e-7
        assert np.all(np.abs(ldt.depth[:, j][m] - ref["depth"][:, j][m]) <= tol)
        # the back depths paired from the opposite face are the exact exits of the same line
        b = m & ~ldt.mismatch & (ldt.count > j)
        tol = 0.01 * ref["back_slope"][:, j][b] + 4e-7
        assert np.all(np.abs(ldt.back[:, j][b] - ref["back"][:, j][b]) <= tol)
        # empty values
        assert np.all(ldt.depth[:, j][ldt.count_raw <= j] == 1.0)
        assert np.all(ldt.triangle[:, j][ldt.count_raw <= j] == -1)
        assert np.all(ldt.normal[:, j][ldt.count_raw <= j] == 0.0)
        assert np.all(ldt.back[:, j][ldt.count <= j] == 1.0)
    return ldt


def test_sphere_has_one_layer():
    ldt = check_against_ray_casts(SHAPES["sphere"](), 32)
    assert ldt.n_layers == 1 and not ldt.open and not ldt.layers_capped
    assert ldt.mismatch.sum() == 0
    # the covered texels of each face form the sphere's disc: about pi/4 of (R-2)^2 of R^2
    share = (ldt.count == 1).mean(axis=(1, 2))
    assert np.all(np.abs(share - np.pi / 4 * (30 / 32) ** 2) < 0.02)


def test_hollow_box_has_two_layers_through_the_cavity():
    ldt = check_against_ray_casts(hollow_box(), 32)
    assert ldt.n_layers == 2 and ldt.mismatch.sum() == 0
    # texel centres inside the cavity's square (|q| < 0.55 / half) see 2 layers, the rest of the
    # box 1, the empty ring 0
    c = (np.arange(32) + 0.5) / 32 * 2 - 1
    a = np.abs(c) * ldt.cube_half
    inner = (a[:, None] < 0.55) & (a[None, :] < 0.55)
    outer = (a[:, None] < 1.0) & (a[None, :] < 1.0)
    for f in range(6):
        np.testing.assert_array_equal(ldt.count[f], np.where(inner, 2, np.where(outer, 1, 0)))
    # layer 2 is the cavity's far wall: depth (half + 0.55) / (2 half) from the face
    np.testing.assert_allclose(ldt.depth[:, 1][ldt.count == 2], 0.5 + 0.55 / (2 * ldt.cube_half), atol=1e-6)


def test_torus_layers_along_and_across_its_axis():
    ldt = check_against_ray_casts(SHAPES["torus"](), 32)
    # along the axis (+-Y, faces 2 and 3): one layer on the ring, none in the hole
    c = (np.arange(32) + 0.5) / 32 * 2 - 1
    rho = np.hypot(c[:, None], c[None, :]) * ldt.cube_half
    clear = (np.abs(rho - 1.0) > 0.3 + 0.06) | (np.abs(rho - 1.0) < 0.3 - 0.06)  # off the tessellated rims
    ring = np.abs(rho - 1.0) < 0.3
    for f in (2, 3):
        np.testing.assert_array_equal(ldt.count[f][clear], ring[clear].astype(np.uint8))
    # across the axis: two layers where a line crosses both sides of the ring
    assert ldt.count[[0, 1, 4, 5]].max() == 2 and ldt.count[[2, 3]].max() == 1
    assert ldt.n_layers == 2


def test_layer_cap_and_single_layer_build():
    boxes = merged(*[(Mesh(b.vertices + [3.0 * i, 0, 0], b.faces, b.normals), False)
                     for i, b in enumerate([P.box((1.0, 1.0, 1.0))] * 9)])
    capped = build_ldt(boxes, 64)
    assert capped.layers_capped and capped.n_layers == C.MAX_LAYERS
    assert capped.count_raw[0].max() == C.MAX_LAYERS and capped.count_raw[2].max() == 1
    one = build_ldt(hollow_box(), 32, max_layers=1)
    full = build_ldt(hollow_box(), 32)
    assert one.layers_capped and not full.layers_capped and one.n_layers == 1
    np.testing.assert_array_equal(one.depth[:, 0], full.depth[:, 0])
    # one layer: its back is the last exit of the line (the convex assumption)
    m = full.count == 2
    np.testing.assert_array_equal(one.back[:, 0][m], full.back[:, 1][m])


def test_open_mesh_is_one_layer_of_both_windings():
    sheet = P.plane_grid((2.0, 1.1), (4, 2))  # edges off the texel centres
    assert not is_closed(sheet)
    ldt = build_ldt(sheet, 32)
    assert ldt.open and ldt.n_layers == 1 and not ldt.mismatch.any()
    assert np.all(ldt.back == 1.0)
    # seen from +Y and -Y alike (no culling); edge-on from the other faces: nothing
    assert (ldt.count[2] == 1).sum() > 200 and np.array_equal(ldt.count[2], ldt.count[3][::-1, :])
    assert ldt.count[[0, 1, 4, 5]].max() == 0
    np.testing.assert_allclose(ldt.depth[2, 0][ldt.count[2] == 1], 0.5, atol=1e-7)


def test_inside_out_closed_mesh_is_reversed():
    s = P.icosphere(2)
    inside_out = Mesh(s.vertices, s.faces[:, [0, 2, 1]], s.normals)
    a, b = build_ldt(s, 32), build_ldt(inside_out, 32)
    for name in ("depth", "back", "count", "triangle", "normal"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


def test_face_table_is_the_gl_cube_map_rule():
    """On face f's plane the LDT texel is the cube-map texel of the direction from the centre."""
    rng = np.random.default_rng(3)
    for f in range(6):
        a, sigma = f // 2, 1.0 if f % 2 == 0 else -1.0
        q = rng.uniform(-0.999, 0.999, (200, 3))
        q[:, a] = sigma
        sc, tc = face_coords(q, f)
        for k in range(len(q)):
            g, s, t = naive_gl_cube_lookup(q[k])
            assert g == f
            assert (sc[k] + 1) / 2 == s and (tc[k] + 1) / 2 == t


@pytest.mark.parametrize("R", [32, 256])
def test_mirrored_texel_centres_coincide(R):
    """Texel (r, c) of face f and its mirror on f ^ 1 have their centres on one line (bit for bit,
    R a power of two)."""
    rows, cols = np.mgrid[0:R, 0:R]
    s = (cols + 0.5) / R
    t = (R - rows - 0.5) / R
    sc, tc = 2 * s - 1, 2 * t - 1
    for f in (0, 2, 4):
        sa, ss, ta, ts = C.FACE_TABLE[f]
        sb, sg, tb, tg = C.FACE_TABLE[f ^ 1]
        assert (sa, ta) == (sb, tb)
        line_f = (ss * sc, ts * tc)                     # q[sa], q[ta] of face f's texel centres
        line_g = (sg * mirrored(sc, f), tg * mirrored(tc, f))
        np.testing.assert_array_equal(line_f[0], line_g[0])
        np.testing.assert_array_equal(line_f[1], line_g[1])


def test_build_is_bit_identical_across_thread_counts():
    mesh = SHAPES["torus"]()
    numba.set_num_threads(1)
    try:
        one = build_ldt(mesh, 64)
    finally:
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    two = build_ldt(mesh, 64)
    for name in ("depth", "back", "normal", "triangle", "count_raw", "count", "mismatch"):
        np.testing.assert_array_equal(getattr(one, name), getattr(two, name))


def test_save_and_load(tmp_path):
    ldt = build_ldt(SHAPES["torus"](), 32)
    ldt.save(tmp_path / "ldt_1.npz")
    with np.load(tmp_path / "ldt_1.npz") as z:
        assert sorted(z.files) == sorted(["depth", "back", "normal", "triangle", "count_raw", "count", "mismatch",
                                          "cube_center", "cube_half", "open", "layers_capped"])
        assert z["depth"].dtype == np.float32 and z["normal"].shape == (6, 2, 32, 32, 3)
        assert z["count"].dtype == np.uint8 and z["triangle"].dtype == np.int32
    back = LDT.load(tmp_path / "ldt_1.npz")
    np.testing.assert_array_equal(back.back, ldt.back)
    assert back.cube_half == ldt.cube_half and back.open == ldt.open


def test_bad_inputs_are_refused():
    with pytest.raises(refsoft.RefsoftError, match="resolution"):
        build_ldt(P.icosphere(1), 3)
    with pytest.raises(refsoft.RefsoftError, match="max_layers"):
        build_ldt(P.icosphere(1), 32, max_layers=9)
    with pytest.raises(refsoft.RefsoftError, match="point"):
        build_ldt(Mesh(np.zeros((3, 3)), [[0, 1, 2]]), 32)
