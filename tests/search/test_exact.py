"""The exact drawing of a reflector's virtual triangles (refsoft/search/exact.py, ``draw="exact"``):
its choice of candidates against a NumPy version, its picture against the acceptance over every
triangle and against the ray-traced truth, and its bits across thread counts."""

import numba
import numpy as np
import pytest

import refsoft
from refsoft import constants
from refsoft.frame import FrameDriver, RenderOptions
from refsoft.search import CULLED, HIDDEN, acceptance, exact
from refsoft.search.method import VertexSearch
from refsoft.truth import TruthRenderer, metrics


# --- the candidates -------------------------------------------------------------------------------
def _reaching_numpy(clip, faces, flags, lost, box, width, height):
    """The rule of ``_exact.reaching`` written with NumPy: a triangle is left out where a vertex
    is flagged ``lost``, or where all three vertices are in front of the eye, finite on screen,
    and its bounds widened by the dilation and a pixel stay off the box."""
    r0, r1, c0, c1 = box
    w = clip[:, 3]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        x = (clip[:, 0] / w + 1.0) * 0.5 * width
        y = (1.0 - clip[:, 1] / w) * 0.5 * height
    keep = []
    for t, f in enumerate(faces):
        if any(flags[i] & lost for i in f):
            continue
        if not all(w[i] > 0 for i in f):
            keep.append(t)
            continue
        xs, ys = x[f], y[f]
        with np.errstate(invalid="ignore", over="ignore"):
            edge = max(np.hypot(xs[i] - xs[(i + 1) % 3], ys[i] - ys[(i + 1) % 3]) for i in range(3))
        if not np.isfinite(edge):
            keep.append(t)
            continue
        reach = constants.SEVERAL_DILATE_PIXELS + constants.SEVERAL_DILATE_FRACTION * edge + 1.0
        if xs.max() + reach < c0 or xs.min() - reach > c1 or ys.max() + reach < r0 or ys.min() - reach > r1:
            continue
        keep.append(t)
    return np.array(keep, np.int64)


class _Camera:
    width, height = 64, 48


def test_candidates_are_the_triangles_whose_dilated_bounds_reach_the_box(rng):
    n, m = 300, 900
    clip = rng.normal(size=(n, 4)) * 2.0
    clip[:, 3] = rng.uniform(-0.2, 2.0, n)  # some vertices behind the eye plane
    clip[:7, 0] = np.inf
    faces = rng.integers(0, n, (m, 3))
    flags = np.where(rng.random(n) < 0.05, HIDDEN, 0).astype(np.uint8)
    flags[rng.random(n) < 0.03] |= CULLED
    box = (10, 30, 20, 50)
    got = exact.candidate_triangles(clip, faces, flags, CULLED | HIDDEN, box, _Camera)
    want = _reaching_numpy(clip, faces, flags, CULLED | HIDDEN, box, 64, 48)
    np.testing.assert_array_equal(got, want)
    assert 50 < len(want) < m - 50  # both rules were exercised
    # without HIDDEN among the flags that leave a triangle out, more are kept
    assert len(exact.candidate_triangles(clip, faces, flags, CULLED, box, _Camera)) > len(got)


# --- the picture ----------------------------------------------------------------------------------
class _Spy(VertexSearch):
    """The vertex search, keeping the arguments of its last exact drawing."""

    def reflect(self, view, k, stencil):
        seen = {}
        real_pass = exact.exact_pass

        def spy(*args):
            seen["args"] = args
            seen["out"] = real_pass(*args)
            return seen["out"]

        import refsoft.search.method as method

        method.exact_pass = spy
        try:
            out = super().reflect(view, k, stencil)
        finally:
            method.exact_pass = real_pass
        self.seen = seen
        return out


@pytest.fixture(scope="module")
def kitchen():
    """The kitchen's last frame at 160x120, both drawings, and the truth."""
    scene = refsoft.load_scene("kitchen", width=160, height=120)
    frame = scene.n_frames - 1
    got = {"exact": FrameDriver(scene, RenderOptions()).render_frame(frame).arrays,
           "raster": FrameDriver(scene, RenderOptions(draw="raster")).render_frame(frame).arrays}
    truth = TruthRenderer(scene, exact=False).render_frame(frame).arrays
    return got, truth


def test_leaving_out_triangles_off_the_box_changes_no_pixel():
    """The drawing equals the acceptance over every triangle without a lost vertex: the
    candidates left out could not cover a pixel of the box (a flat mirror, whose mirrored virtual
    vertices reach past its outline, where the box leaves many out; unfolded ones all lie on rays
    through the stencil)."""
    scene = refsoft.load_scene("planar", width=128, height=96)
    # short edges split too (span 1): more triangles, hundreds of them beyond the box
    opts = RenderOptions(virtual="mirror", tessellate_span=1)
    spy = _Spy(scene, opts)
    FrameDriver(scene, opts, method=spy).render_frame(0)
    scene_, part, real, camera, mesh, triangle, stencil, box, inverse = spy.seen["args"]
    virtual, normals, faces, face_obj, flags = part
    every = np.flatnonzero(((flags[faces] & (CULLED | HIDDEN)) == 0).all(axis=1))
    f = faces[every]
    cand = acceptance.Candidates(virtual[f], real[f], normals[f], face_obj[every], every, 0)
    colors = np.vstack([np.zeros(3), [o.color for o in scene.objects]]).astype(np.float32)
    want = acceptance.draw(cand, camera, mesh, triangle, stencil, box, colors)
    got = spy.seen["out"]
    assert len(every) - got[3]["candidates"] >= 100  # some were left out
    assert want[2].sum() > 1000
    for a, b in zip(got[:3], want[:3]):
        assert a.tobytes() == b.tobytes()


def test_exact_drawing_removes_the_holes_and_agrees_more_with_the_truth(kitchen):
    """Along the reflected outlines the raster's straight virtual edges leave holes; met
    exactly, the pixels agree with the truth (measured at 160x120, frame 23: raster 99.60%, 11
    holes; exact 99.91%, none)."""
    got, truth = kitchen
    agree = {k: 1 - metrics.disagreement(a["reflected_id"], truth["reflected_id"]) for k, a in got.items()}
    holes = {k: int(metrics.holes(a["reflected_id"], truth["reflected_id"]).sum()) for k, a in got.items()}
    assert holes["raster"] > 0 and holes["exact"] == 0, holes
    assert agree["exact"] >= agree["raster"] + 0.003, agree


def test_exact_drawing_is_the_same_on_one_thread_and_on_several():
    scene = refsoft.load_scene("sphere", width=96, height=72)
    got = []
    for threads in (1, numba.config.NUMBA_NUM_THREADS):
        numba.set_num_threads(threads)
        try:
            got.append(FrameDriver(scene, RenderOptions(draw="exact")).render_frame(0).arrays)
        finally:
            numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    for name in ("image", "reflected_id"):
        assert got[0][name].tobytes() == got[1][name].tobytes(), name


def test_draw_is_checked():
    with pytest.raises(refsoft.RefsoftError, match="draw must be one of"):
        RenderOptions(draw="ray")
    assert RenderOptions(preset="paper").draw == "raster"
    assert RenderOptions().draw == "exact"


# --- drawn exactly along the outlines (draw="edges") ------------------------------------------------
def _band_naive(rid, covered, stencil, width):
    """edge_band written pixel by pixel: seeds where a 4-neighbour in the stencil differs in
    object or coverage, or lies outside the stencil or the box; then every stencil pixel within
    ``width`` 8-neighbour steps (Chebyshev distance) of a seed."""
    h, w = stencil.shape
    seeds = []
    for r in range(h):
        for c in range(w):
            if not stencil[r, c]:
                continue
            for dr, dc in ((0, 1), (1, 0), (0, -1), (-1, 0)):
                rr, cc = r + dr, c + dc
                if not (0 <= rr < h and 0 <= cc < w) or not stencil[rr, cc] \
                        or rid[rr, cc] != rid[r, c] or covered[rr, cc] != covered[r, c]:
                    seeds.append((r, c))
                    break
    band = np.zeros((h, w), bool)
    for r, c in seeds:
        band[max(r - width, 0):r + width + 1, max(c - width, 0):c + width + 1] = True
    return band & stencil


def test_the_band_is_the_pixels_near_a_change_or_the_outline(rng):
    h, w = 30, 41
    yy, xx = np.mgrid[:h, :w]
    stencil = (yy - 15) ** 2 + (xx - 20) ** 2 < 13 ** 2
    rid = np.where(xx + yy // 3 < 25, 2, 5).astype(np.int32)
    rid[rng.random((h, w)) < 0.01] = 7
    covered = rng.random((h, w)) > 0.02
    for width in (0, 1, 2):
        got = exact.edge_band(rid, covered, stencil, width)
        np.testing.assert_array_equal(got, _band_naive(rid, covered, stencil, width))
    assert 0 < got.sum() < stencil.sum()


def test_a_band_leaves_out_only_triangles_that_cover_none_of_its_pixels(rng):
    n, m = 300, 900
    clip = rng.normal(size=(n, 4)) * 0.6
    clip[:, 3] = rng.uniform(0.5, 2.0, n)
    faces = rng.integers(0, n, (m, 3))
    flags = np.zeros(n, np.uint8)
    box = (10, 30, 20, 50)
    band = np.zeros((20, 30), bool)
    band[5:7, 3:9] = True
    everyone = exact.candidate_triangles(clip, faces, flags, CULLED, box, _Camera)
    got = exact.candidate_triangles(clip, faces, flags, CULLED, box, _Camera, band)
    assert set(got) <= set(everyone) and 0 < len(got) < len(everyone)
    # a triangle left out: its bounds widened as the acceptance's dilation hold no band pixel
    w = clip[:, 3]
    x = (clip[:, 0] / w + 1.0) * 0.5 * _Camera.width
    y = (1.0 - clip[:, 1] / w) * 0.5 * _Camera.height
    rows, cols = np.nonzero(band)
    centres_y, centres_x = rows + box[0] + 0.5, cols + box[2] + 0.5
    for t in sorted(set(everyone) - set(got)):
        xs, ys = x[faces[t]], y[faces[t]]
        edge = max(np.hypot(xs[i] - xs[(i + 1) % 3], ys[i] - ys[(i + 1) % 3]) for i in range(3))
        reach = constants.SEVERAL_DILATE_PIXELS + constants.SEVERAL_DILATE_FRACTION * edge
        inside = ((centres_x >= xs.min() - reach) & (centres_x <= xs.max() + reach)
                  & (centres_y >= ys.min() - reach) & (centres_y <= ys.max() + reach))
        assert not inside.any(), t


def test_edges_draw_the_band_as_the_exact_drawing_and_the_rest_as_the_raster(monkeypatch):
    scene = refsoft.load_scene("sphere", width=128, height=96)
    # the edges meet the band with the drawing's own triangles, not the exact drawing's second
    # candidates (search/virtual.py with_mirror_copies): the exact drawing here without them
    import refsoft.search.method as method

    monkeypatch.setattr(method, "with_mirror_copies", lambda part, real, mirror, camera: (part, real))
    got = {d: FrameDriver(scene, RenderOptions(draw=d)).render_frame(0) for d in ("raster", "exact", "edges")}
    r0 = got["edges"].report["exact"]["1"]
    assert 0 < r0["band_pixels"]
    ids = {d: f.arrays["reflected_id"] for d, f in got.items()}
    image = {d: f.arrays["image"] for d, f in got.items()}
    differ = (ids["raster"] != ids["exact"]) | np.any(image["raster"] != image["exact"], axis=2)
    from_exact = np.all(image["edges"] == image["exact"], axis=2) & (ids["edges"] == ids["exact"])
    from_raster = np.all(image["edges"] == image["raster"], axis=2) & (ids["edges"] == ids["raster"])
    assert np.all(from_exact | from_raster)  # every pixel is one drawing's or the other's
    # where the two drawings give another object, the edges give the exact one's
    assert np.all(ids["edges"][ids["raster"] != ids["exact"]] == ids["exact"][ids["raster"] != ids["exact"]])
    assert differ.any()


def test_shading_kernel_matches_the_numpy_shading(rng):
    """The exact drawing's shading kernel gives acceptance.shade_winners' colours and objects bit
    for bit: random winners, barycentrics and normals (some zero: ambient only), several objects,
    uncovered pixels and pixels without a ray."""
    from types import SimpleNamespace

    h, w, n, c = 23, 31, 50, 40
    best_c = np.where(rng.random((h, w)) < 0.7, rng.integers(0, c, (h, w)), -1).astype(np.int64)
    uv = rng.random((h, w, 2))
    uv /= np.maximum(1.0, uv.sum(axis=2))[..., None]
    normals = rng.normal(size=(n, 3))
    normals[::7] = 0.0
    corner = rng.integers(0, n, (c, 3))
    obj = rng.integers(1, 5, c).astype(np.int32)
    scene = SimpleNamespace(objects=[SimpleNamespace(color=tuple(rng.random(3))) for _ in range(4)])
    valid = rng.random((h, w)) < 0.9
    got = exact.shade(best_c, uv, corner, normals, obj, scene, valid)
    colors = np.vstack([np.zeros(3), [o.color for o in scene.objects]]).astype(np.float32)
    won = best_c[best_c >= 0]
    want = acceptance.shade_winners(best_c, uv, normals[corner[won]], obj[won], colors, valid)
    for a, b in zip(got[:3], want[:3]):
        assert a.dtype == b.dtype and a.tobytes() == b.tobytes()
    assert got[3] == want[3]
    assert (got[1] > 0).sum() == (best_c >= 0).sum()


def _gathered_numpy(keep, faces, face_obj, points, clip, camera, box):
    """What ``exact._gathered`` gives, with NumPy: fancy indexing, and the screen bounds of
    ``acceptance._screen_numpy`` (the NumPy rule ``_several.screen_bounds`` follows)."""
    f = faces[keep]
    return f, face_obj[keep], points[f], acceptance._screen_numpy(clip[f], camera, box)


def test_gather_kernel_is_numpy_indexing_and_the_numpy_screen_bounds(rng):
    """``_exact.gather`` (through ``exact._gathered``) gives each kept triangle's corners, object,
    real corners, view positions, dilated bounds and dilation as NumPy does, bit for bit, on one
    thread and on several: vertices behind the eye plane and positions that are not finite
    among them."""
    from refsoft._parallel import one_thread

    n, m = 300, 2000
    clip = rng.normal(size=(n, 4)) * 2.0
    clip[:, 3] = rng.uniform(-0.2, 2.0, n)
    clip[:5, 0] = np.inf
    clip[5:8, 1] = np.nan
    faces = rng.integers(0, n, (m, 3))
    face_obj = rng.integers(1, 9, m).astype(np.int32)
    points = rng.normal(size=(n, 3))
    keep = np.flatnonzero(rng.random(m) < 0.6)
    box = (10, 30, 20, 50)
    want = _gathered_numpy(keep, faces, face_obj, points, clip, _Camera, box)
    assert 0 < np.sum(want[3][2] < 0) < len(keep) // 2  # candidates behind the eye plane
    for several in (True, False):
        with one_thread(not several):
            clip_ = np.ascontiguousarray(clip)
            got = exact._gathered(keep, faces, face_obj, points, clip_, exact._projected(clip_, _Camera), _Camera, box)
        for a, b in zip(got[:3] + got[3], want[:3] + want[3]):
            assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
