"""`refsoft golden` and `refsoft check` for the comparison methods (the layered depth textures and
the environment map): the golden cases hold their textures and inputs, the oracle checked
against itself passes with nothing flagged, and the mutations a port of either method could
make are flagged, under both profiles."""

import json
import shutil

import numpy as np
import pytest

from refsoft import constants, keys
from refsoft.conformance.check import check
from refsoft.conformance.rules.envmap import lookup_tie
from refsoft.conformance.cubes import segment_distance
from refsoft.conformance.golden import CASES, case_by_name, write_golden
from refsoft.frame import FrameDriver
from refsoft.frame.driver import make_method
from refsoft.io import read_npz, write_npz
from refsoft.options import RenderOptions

by_profile = pytest.mark.parametrize("profile", constants.CHECK_PROFILES)

#: The golden cases of the comparison methods.
LDT_CASES = [c.name for c in CASES if c.options.get("method") == "ldt"]
ENVMAP_CASES = [c.name for c in CASES if c.options.get("method") == "envmap"]
METHOD_KINDS = ("ldt_texture", "ldt_region", "ldt_ray", "ldt_pixel", "ldt_counts", "envmap_cube", "envmap_pixel")


def _copy(golden, tmp_path, case):
    """A candidate folder holding one golden case's files (its traces-free outputs, as a port's)."""
    cand = tmp_path / "cand"
    shutil.copytree(golden / case, cand / case, ignore=shutil.ignore_patterns("inputs"))
    return cand


def _rewrite(path, mutate):
    arrays = read_npz(path)
    mutate(arrays)
    write_npz(path, **arrays)


def _render(case_name, options=None, method=None):
    """A candidate's frames and once-per-run files: the case rendered by the oracle with other
    options or another method object (an honest port with that difference)."""
    case = case_by_name(case_name)
    scene = case.load()
    opts = RenderOptions(**{**case.options, **(options or {})})
    driver = FrameDriver(scene, opts, method=method(scene, opts) if method else None)
    frames = {f: dict(driver.render_frame(f).arrays) for f in case.frames}
    once = driver.method.run_files() if hasattr(driver.method, "run_files") else {}
    return frames, once


def _candidate(golden, tmp_path, case, frames, once):
    cand = _copy(golden, tmp_path, case)
    for f, arrays in frames.items():
        write_npz(cand / case / f"frame_{f:04d}.npz", **arrays)
    for name, arrays in once.items():
        write_npz(cand / case / f"{name}.npz", **arrays)
    return cand


def _status(summary):
    """``{key: status}`` of the findings (the worst status of a key over the frames)."""
    order = {"pass": 0, "accepted": 1, "missing": 2, "fail": 3}
    out = {}
    for f in summary["_findings"]:
        if order[f.status] >= order.get(out.get(f.key), -1):
            out[f.key] = f.status
    return out


def _failed(summary):
    return {f.key for f in summary["_findings"] if f.status in ("fail", "missing")}


# --- the golden cases ----------------------------------------------------------------------------

def test_golden_cases_hold_textures_inputs_and_options(golden):
    manifest = json.loads((golden / "manifest.json").read_text())
    entries = {e["name"]: e for e in manifest["cases"]}
    assert len(LDT_CASES) >= 4 and len(ENVMAP_CASES) >= 2
    for name in LDT_CASES + ENVMAP_CASES:
        e = entries[name]
        method = e["options"]["method"]
        assert e["options"][f"{method}_resolution"] == 64
        case_json = json.loads((golden / name / "inputs" / "case.json").read_text())
        assert case_json["options"] == e["options"]  # the method and every one of its options
        case = case_by_name(name)
        scene = case.load()
        reflected = [j for j in range(1, len(scene.objects) + 1) if not scene.object_by_id(j).reflector]
        textures = sorted(p.name for p in (golden / name).glob("ldt_*.npz"))
        assert textures == (sorted(f"ldt_{j}.npz" for j in reflected) if method == "ldt" else [])
        for t in textures:
            assert f"{name}/{t}" in manifest["files"]
            z = read_npz(golden / name / t)
            assert set(z) == set(keys.LDT_TEXTURE_ARRAYS) and z["depth"].shape[-2:] == (64, 64)
        assert not list((golden / name).glob("traces_*.json"))  # no vertex search, no walks
        for f in case.frames:
            z = read_npz(golden / name / f"frame_{f:04d}.npz")
            want = keys.LDT_PIXEL_ARRAYS if method == "ldt" else (keys.ENVMAP_FACE, keys.ENVMAP_TEXEL)
            assert set(want) <= set(z)
    assert entries["genus3_ldt_float64"]["options"]["precision"] == "float64"
    assert entries["hollow_box_ldt"]["options"]["ldt_layers"] == "all"
    assert read_npz(golden / "hollow_box_ldt" / "ldt_2.npz")["depth"].shape[1] >= 2  # a hollow object: 2 layers
    # open sheets (the quad and the floor), hit from in front and never where a ray starts behind them
    assert all(bool(read_npz(golden / "quad_ldt" / f"ldt_{j}.npz")["open"]) for j in (2, 3))
    z = read_npz(golden / "quad_ldt" / "frame_0000.npz")
    on = z[keys.REFLECTED_ID] >= 0
    hits = on & ((z[keys.LDT_FLAGS] & 16) != 0)
    up = on & (z[keys.LDT_RAY_DIR][..., 1] > 0)
    assert hits.sum() > 100 and up.sum() > 100 and not np.any(z[keys.REFLECTED_ID][up] == 3)  # 3: the floor
    assert not np.any(z[keys.LDT_FLAGS][on] & 1)  # START_INSIDE: never on a sheet


def test_the_inputs_alone_give_the_textures_and_the_cube_matrices(golden):
    """An LDT case's inputs hold what the build and the search need beyond the world meshes: each
    reflected object's model-space mesh (the textures built from it are the golden ones, bit
    for bit) and per frame its model-to-world and world-to-cube matrices (the search's)."""
    from refsoft.conformance.export import read_inputs
    from refsoft.ldt import build_ldt
    from refsoft.scene.mesh import Mesh

    for name in LDT_CASES:
        case = case_by_name(name)
        opts = RenderOptions(**case.options)
        inp = read_inputs(golden / name / "inputs")
        scene = case.load()
        assert sorted(inp["models"]) == [j for j in range(1, len(scene.objects) + 1)
                                         if not scene.object_by_id(j).reflector]
        for j, (v, n, f) in inp["models"].items():
            mesh = Mesh(v, f, n)
            object.__setattr__(mesh, "normals", n)  # exactly the file's normals
            built = build_ldt(mesh, opts.ldt_resolution, 8 if opts.ldt_layers == "all" else 1).arrays()
            want = read_npz(golden / name / f"ldt_{j}.npz")
            assert all(np.asarray(built[k]).tobytes() == want[k].tobytes() for k in want), (name, j)
        driver = FrameDriver(scene, opts)
        for fr in inp["case"]["frames"]:
            state = next(iter(driver.render_frame(fr["frame"]).reflectors.values())).state
            ids = driver.method.stack.ids
            W = np.array([fr["world_to_cube"][str(j)] for j in ids])
            M = np.array([fr["transforms"][str(j)] for j in ids])
            assert W.tobytes() == state.W.tobytes(), name
            assert M.tobytes() == np.array([scene.transform_at(int(j), fr["frame"]).matrix() for j in ids]).tobytes()
    for name in ENVMAP_CASES + ["sphere"]:  # other methods need no models
        case_json = json.loads((golden / name / "inputs" / "case.json").read_text())
        assert not any("model" in o for o in case_json["objects"]) and "world_to_cube" not in case_json["frames"][0]


def test_regenerating_gives_identical_files(golden, tmp_path):
    names = ["hollow_box_ldt", "cube_edge_envmap"]
    again = tmp_path / "again"
    write_golden(again, names)
    m1 = json.loads((golden / "manifest.json").read_text())
    m2 = json.loads((again / "manifest.json").read_text())
    assert {k: v for k, v in m1["files"].items() if k.split("/")[0] in names} == m2["files"]


def test_cube_edge_scene_puts_every_reflected_direction_on_the_edge():
    """The tie scene does what it is for: every reflector pixel's direction has r_x == r_z,
    the largest component, bit for bit (so the face order alone decides the face)."""
    case = case_by_name("cube_edge_envmap")
    scene = case.load()
    frame = FrameDriver(scene, RenderOptions(**case.options)).render_frame(0)
    r = frame.reflectors[1].state.rays.direction
    a = np.abs(r)
    assert len(r) > 1000 and np.all(a[:, 0] == a[:, 2]) and np.all(a[:, 0] > a[:, 1])
    assert np.all(frame.reflectors[1].state.face == 4)  # +Z: z over x


@by_profile
def test_oracle_against_itself_passes_with_nothing_flagged(golden, tmp_path, profile):
    s = check(golden, golden, cases=LDT_CASES + ENVMAP_CASES, out=tmp_path / "r", profile=profile)
    assert s["passed"] and s["counts"]["accepted"] == 0 and s["counts"]["fail"] == 0
    assert set(METHOD_KINDS) <= set(s["by_kind"])
    n_textures = sum(len(list((golden / c).glob("ldt_*.npz"))) for c in LDT_CASES)
    texture_findings = [f for f in s["_findings"] if f.kind == "ldt_texture"]
    assert len(texture_findings) == n_textures * len(keys.LDT_TEXTURE_ARRAYS)
    assert {f.kind for f in s["_findings"] if f.key == "reflected_id"} == {"ldt_pixel", "envmap_pixel"}


# --- the mutation suite ----------------------------------------------------------------------------

@pytest.fixture(scope="module")
def face_table_flipped(golden, tmp_path_factory):
    """A port whose face table swaps +X and -X: its textures hold each face's layers under the
    other's index, and its pixels name the swapped faces."""
    case = "balls_ldt"
    cand = _copy(golden, tmp_path_factory.mktemp("flip"), case)
    swap = [1, 0, 2, 3, 4, 5]
    for p in (cand / case).glob("ldt_*.npz"):
        _rewrite(p, lambda a: a.update({k: a[k][swap] for k in ("depth", "back", "normal", "triangle", "count_raw",
                                                                "count", "mismatch")}))
    for p in (cand / case).glob("frame_*.npz"):
        def relabel(a):
            f = a[keys.LDT_FACE]
            assert np.isin(f, (0, 1)).sum() > 50  # the case's rays hit both X faces
            a[keys.LDT_FACE] = np.where(f == 0, 1, np.where(f == 1, 0, f)).astype(f.dtype)
        _rewrite(p, relabel)
    return case, cand


@by_profile
def test_mutation_face_table_flipped(golden, face_table_flipped, profile):
    case, cand = face_table_flipped
    s = check(golden, cand, cases=[case], profile=profile)
    st = _status(s)
    assert not s["passed"]
    assert st["ldt_2.triangle"] == st["ldt_3.triangle"] == st[keys.LDT_FACE] == "fail"
    assert st["ldt_2.back"] == "pass"  # consistently swapped, the pairing itself holds
    assert st[keys.LDT_TEXEL] == "pass" and st[keys.LDT_HIT_POSITION] == "pass"  # only the face's name differs


def _pairing_off_by_one(depth, count_raw):
    """The back depths of a port that pairs layer j with the opposite face's layer L' - 2 - j
    instead of L' - 1 - j (docs/ldt.md, "Back depths"), clamped into the layers."""
    six, L, R, _ = depth.shape
    back = np.ones(depth.shape, np.float32)
    for f in range(6):
        g = f ^ 1
        flip = (lambda a: a[..., ::-1, :]) if f // 2 == 1 else (lambda a: a[..., :, ::-1])
        other, lo = flip(depth[g]), flip(count_raw[g]).astype(np.int64)
        count = np.minimum(count_raw[f].astype(np.int64), lo)
        for j in range(L):
            k = np.clip(lo - 2 - j, 0, L - 1)
            d = np.take_along_axis(other, k[None], axis=0)[0]
            back[f, j] = np.where(j < count, np.float32(1) - d, np.float32(1))
    return back


@pytest.fixture(scope="module")
def pairing_off_by_one(golden, tmp_path_factory):
    """A port whose back depths pair one layer off: its textures and, from them, its searches."""
    case = "hollow_box_ldt"

    def method(scene, opts):
        m = make_method(scene, opts)
        m.build()
        for ldt in m.ldts.values():
            ldt.back = _pairing_off_by_one(ldt.depth, ldt.count_raw)
        m.stack = type(m.stack).of(m.ldts, m.precision)
        return m

    frames, once = _render(case, method=method)
    assert any((a["back"] != read_npz(golden / case / f"{n}.npz")["back"]).any() for n, a in once.items())
    return case, _candidate(golden, tmp_path_factory.mktemp("pairing"), case, frames, once)


@by_profile
def test_mutation_back_pairing_off_by_one(golden, pairing_off_by_one, profile):
    case, cand = pairing_off_by_one
    s = check(golden, cand, cases=[case], profile=profile)
    st = _status(s)
    assert not s["passed"] and st["ldt_2.back"] == "fail"
    assert st["ldt_2.depth"] == st["ldt_2.triangle"] == "pass"  # the peeling itself is right
    assert "fail" in {st[k] for k in (keys.REFLECTED_ID, keys.LDT_FACE, keys.LDT_LAYER, keys.LDT_TEXEL)}


@pytest.fixture(scope="module")
def linear_step_skipped(golden, tmp_path_factory):
    """A port whose linear search takes N - 1 steps (31 instead of 32): the kernel run so."""
    case = "balls_ldt"
    assert RenderOptions(**case_by_name(case).options).ldt_linear == 32
    frames, once = _render(case, {"ldt_linear": 31})
    return case, _candidate(golden, tmp_path_factory.mktemp("linear"), case, frames, once)


@by_profile
def test_mutation_linear_step_skipped(golden, linear_step_skipped, profile):
    case, cand = linear_step_skipped
    s = check(golden, cand, cases=[case], profile=profile)
    st = _status(s)
    assert not s["passed"]
    assert {k for k, v in st.items() if k.startswith("ldt_") and k[4].isdigit() and v != "pass"} == set()  # textures
    assert st[keys.LDT_LINEAR_SAMPLES] == "fail" and st[keys.LDT_HIT_POSITION] == "fail"
    line = [f for f in s["_findings"] if f.key == keys.LDT_HIT_POSITION and f.status == "fail"][0].line()
    assert "cube side" in line and "expected" in line


def _select_face_x_first(r):
    """Mesa's old swrast and Metal's order on ties: x over y over z."""
    a = np.abs(r)
    axis = np.where((a[:, 0] >= a[:, 1]) & (a[:, 0] >= a[:, 2]), 0, np.where(a[:, 1] >= a[:, 2], 1, 2))
    return (2 * axis + np.signbit(r[np.arange(len(r)), axis])).astype(np.int8)


@pytest.fixture(scope="module")
def envmap_ties_x_first(golden, tmp_path_factory):
    case = "cube_edge_envmap"
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr("refsoft.envmap.cube.select_face", _select_face_x_first)
        frames, once = _render(case)
    assert np.all(frames[0][keys.ENVMAP_FACE][frames[0][keys.REFLECTED_ID] >= 0] == 0)  # +X everywhere
    return case, _candidate(golden, tmp_path_factory.mktemp("xfirst"), case, frames, once)


@by_profile
def test_mutation_envmap_ties_x_over_z(golden, envmap_ties_x_first, profile):
    case, cand = envmap_ties_x_first
    s = check(golden, cand, cases=[case], profile=profile)
    st = _status(s)
    assert not s["passed"] and st[keys.ENVMAP_FACE] == "fail"
    assert st[keys.ENVMAP_ID(1)] == st[keys.ENVMAP_COLOR(1)] == "pass"  # the same cube map
    line = [f for f in s["_findings"] if f.key == keys.ENVMAP_FACE][0].line()
    assert "exactly on the cube's edge" in line


# --- ties, subsets, missing outputs -----------------------------------------------------------------

@by_profile
def test_ldt_ties_by_the_oracle_margin(golden, tmp_path, profile):
    """A different texel where the oracle's margin is within 8 ULP of 1.0 is a tie (accepted);
    the same change at a pixel with a large margin fails."""
    case = "hollow_box_ldt"
    z = read_npz(golden / case / "frame_0000.npz")
    hit = z[keys.LDT_FACE] >= 0
    margin = z[keys.LDT_MARGIN]
    tied = np.argwhere(hit & (margin <= constants.LDT_TIE_MARGIN))
    clear = np.argwhere(hit & (margin > 1e-3))
    assert len(tied) and len(clear)

    def moved(at):
        def mutate(a):
            a[keys.LDT_TEXEL][at[0], at[1], 1] += 1
        return mutate

    for at, want in ((tied[0], "accepted"), (clear[0], "fail")):
        cand = _copy(golden, tmp_path / want, case)
        _rewrite(cand / case / "frame_0000.npz", moved(at))
        s = check(golden, cand, cases=[case], profile=profile)
        assert _status(s)[keys.LDT_TEXEL] == want and s["passed"] == (want == "accepted")


@by_profile
def test_envmap_moved_texel_fails_away_from_texel_edges(golden, tmp_path, profile):
    """A lookup one column off, where the oracle's s R lies far from an integer, fails."""
    from refsoft.envmap.cube import lookup

    case = "touching_envmap"
    c = case_by_name(case)
    state = FrameDriver(c.load(), RenderOptions(**c.options)).render_frame(0).reflectors[1].state
    face, row, col, s_, _ = lookup(state.rays.direction, 64)
    frac = np.abs(s_ * 64 - np.round(s_ * 64))
    i = int(np.flatnonzero((frac > 0.25) & (col > 0) & (col < 63))[0])
    at = (int(state.rays.rows[i]), int(state.rays.cols[i]))
    cand = _copy(golden, tmp_path, case)
    _rewrite(cand / case / "frame_0000.npz", lambda a: a[keys.ENVMAP_TEXEL].__setitem__(at + (1,), col[i] + 1))
    s = check(golden, cand, cases=[case], profile=profile)
    f = [f for f in s["_findings"] if f.key == keys.ENVMAP_TEXEL][0]
    assert not s["passed"] and f.status == "fail" and f.count == 1 and "not the texel across an edge" in f.worst


def test_envmap_lookup_tie_rule():
    """The tie rule of a differing lookup (R = 64; the tie distance 8 * 2^-24 * 64 = 3.1e-5
    texels): the texel across an edge within it, the neighbouring face near the cube's edge but
    not on it."""
    R = 64
    reach = constants.ENVMAP_TIE_ULP * constants.TIE_EPS * R
    for x, want in ((33 + 0.3 * reach, True), (33 - 0.3 * reach, True), (33 + 3 * reach, False)):
        s = x / R
        col = int(np.floor(x))
        other = 32 if col == 33 else 33
        ray = np.array([2 * s - 1, 0.1, 1.0])  # +Z: s = (x / z + 1) / 2
        assert lookup_tie(ray, s, 0.45, 4, 35, col, 4, 35, other, R)[0] == want, x
        assert not lookup_tie(ray, s, 0.45, 4, 35, col, 4, 35, col + 2, R)[0]  # not across that edge
    t = 20.0 / R  # row R - 1 - 20 = 43 against its neighbour 44 across the edge at t R = 20
    assert lookup_tie(np.array([0.1, 0.2, 1.0]), 0.55, t, 4, 43, 35, 4, 44, 35, R)[0]
    assert not lookup_tie(np.array([0.1, 0.2, 1.0]), 0.55, t, 4, 43, 35, 4, 42, 35, R)[0]
    near = np.array([1.0, 0.3, 1.0 - 1e-7])  # |x| > |z| by one part in 10^7: +X, next to +Z
    ok, why = lookup_tie(near, 0.0, 0.3, 0, 20, 0, 4, 20, 63, R)
    assert ok and "cube's edge" in why
    assert not lookup_tie(np.array([1.0, 0.3, 0.9]), 0.05, 0.3, 0, 20, 3, 4, 20, 63, R)[0]  # far from the edge
    assert not lookup_tie(near, 0.0, 0.3, 0, 20, 0, 5, 20, 63, R)[0]  # -Z: not toward the direction
    ok, why = lookup_tie(np.array([1.0, 0.3, 1.0]), 1.0, 0.3, 4, 20, 63, 0, 20, 0, R)
    assert not ok and "face order" in why  # exactly on the edge: the order decides, z over x


def test_missing_textures_and_outputs_fail_unless_excluded(golden, tmp_path):
    case = "balls_ldt"
    cand = _copy(golden, tmp_path, case)
    (cand / case / "ldt_3.npz").unlink()
    for p in (cand / case).glob("frame_*.npz"):
        _rewrite(p, lambda a: a.pop(keys.LDT_BINARY_STEPS))
    s = check(golden, cand, cases=[case])
    st = _status(s)
    assert not s["passed"] and st["ldt_3.npz"] == "missing" and st[keys.LDT_BINARY_STEPS] == "missing"
    kinds = [k for k in constants.CHECK_KINDS if k not in ("ldt_texture", "ldt_counts")]
    s = check(golden, cand, cases=[case], kinds=kinds)
    assert s["passed"] and not {"ldt_texture", "ldt_counts"} & {f.kind for f in s["_findings"]}
    assert {"ldt_pixel", "ldt_ray", "ldt_region"} <= {f.kind for f in s["_findings"]}
    s = check(golden, cand, cases=[case], kinds=["ldt_texture"])
    assert not s["passed"] and {f.kind for f in s["_findings"]} == {"ldt_texture"}


def test_a_port_without_the_decision_arrays_is_judged_as_if_they_agreed(golden, tmp_path):
    case = "balls_ldt"
    cand = _copy(golden, tmp_path, case)
    s = check(golden, cand, cases=[case], kinds=["ldt_counts"])
    assert s["passed"] and {f.kind for f in s["_findings"]} == {"ldt_counts"}


def test_segment_distance_against_brute_force(rng):
    a = rng.uniform(-4, 36, (60, 2))
    b = a + rng.normal(0, 6, (60, 2))
    pixels = np.c_[rng.integers(0, 24, 300), rng.integers(0, 32, 300)]
    got = segment_distance(a, b, 32, 24, pixels, 2.0)
    p = np.c_[pixels[:, 1] + 0.5, 24 - pixels[:, 0] - 0.5]
    e = b - a
    t = np.clip(np.einsum("pij,ij->pi", p[:, None] - a[None], e) / np.einsum("ij,ij->i", e, e), 0, 1)
    brute = np.linalg.norm(a[None] + t[..., None] * e[None] - p[:, None], axis=-1).min(axis=1)
    near = brute <= 2.0
    assert near.sum() > 30 and (~near).sum() > 30
    assert np.allclose(got[near], brute[near], rtol=0, atol=1e-12) and np.all(np.isinf(got[~near]))


def _shifted_fragments(mesh, view_proj, width, height, pixels, triangles):
    """Each fragment as a GPU could interpolate it: at the pixel centre moved by half the gpu
    profile's sub-pixel distance along x (exact float64 interpolation)."""
    from refsoft.conformance.profiles import fragments

    return fragments(mesh, view_proj, width, height, pixels, triangles, offset=(0.5 * constants.GPU_SUBPIXEL_PX, 0.0))


def test_gpu_profile_accepts_interpolation_differences(golden, tmp_path):
    """Texture depths and normals, ray origins and directions interpolated at a sample point
    1/512 px away (as a GPU's own interpolation may): the default profile fails them, the gpu
    profile accepts them; the decisions and hits are the oracle's."""
    from refsoft.conformance.cubes import ldt_face_matrix
    from refsoft.raster import _setup, rasterize

    case = "balls_ldt"
    cand = _copy(golden, tmp_path, case)
    scene = case_by_name(case).load()
    for p in sorted((cand / case).glob("ldt_*.npz")):
        j = int(p.stem.split("_")[1])
        a = read_npz(p)
        mesh = scene.object_by_id(j).mesh
        for f in range(6):
            idx = np.argwhere(a["triangle"][f] >= 0)  # (layer, row, col)
            fr = _shifted_fragments(mesh, ldt_face_matrix(a["cube_center"], float(a["cube_half"]), f), 64, 64,
                                    idx[:, 1:], a["triangle"][f][tuple(idx.T)])
            a["depth"][f][tuple(idx.T)] = fr.depth.astype(np.float32)
            a["normal"][f][tuple(idx.T)] = fr.normal.astype(np.float32)
        from refsoft.ldt.build import pair_back_depths

        a["back"] = pair_back_depths(a["depth"], a["count_raw"], bool(a["open"]))[0]
        write_npz(p, **a)
    cam = scene.camera_at(0)
    mesh = scene.world_mesh(1, 0)
    tri = rasterize(_setup.transform_points(mesh.vertices, cam.view_proj()), mesh.faces, cam.width,
                    cam.height).triangle

    def reray(a):
        on = np.argwhere(a[keys.REFLECTED_ID] >= 0)
        fr = _shifted_fragments(mesh, cam.view_proj(), cam.width, cam.height, on, tri[on[:, 0], on[:, 1]])
        i = fr.position - cam.eye
        i /= np.linalg.norm(i, axis=1, keepdims=True)
        r = i - 2 * np.einsum("ij,ij->i", fr.normal, i)[:, None] * fr.normal
        a[keys.LDT_RAY_ORIGIN][on[:, 0], on[:, 1]] = fr.position.astype(np.float32)
        a[keys.LDT_RAY_DIR][on[:, 0], on[:, 1]] = r.astype(np.float32)

    _rewrite(cand / case / "frame_0000.npz", reray)
    keys_judged = ("ldt_2.depth", "ldt_2.normal", "ldt_3.depth", "ldt_3.normal", keys.LDT_RAY_ORIGIN, keys.LDT_RAY_DIR)
    exact = check(golden, cand, cases=[case], kinds=["ldt_texture", "ldt_ray"])
    st = {f.key: f.status for f in exact["_findings"] if f.frame == 0}
    assert {st[k] for k in keys_judged} == {"fail"}
    gpu = check(golden, cand, cases=[case], kinds=["ldt_texture", "ldt_ray"], profile="gpu")
    st = {f.key: f for f in gpu["_findings"] if f.frame == 0}
    assert gpu["passed"] and {st[k].status for k in keys_judged} == {"accepted"}
    assert "within GPU interpolation" in st["ldt_2.depth"].message
