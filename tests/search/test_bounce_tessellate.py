"""Several bounces (spec section 5.1): a later level drawn by the virtual pass tessellates its
virtual triangles and cuts them at the silhouette as the first level does
(:func:`refsoft.search.levels.refined_level`), the new vertices searched on the level's G-buffer
with each pixel's own eye (:class:`refsoft.search.bounces.LevelSearch`)."""

import numpy as np
import pytest

from refsoft._parallel import one_thread
from refsoft.constants import CLIP_ITERATIONS
from refsoft.frame.driver import FrameDriver
from refsoft.options import RenderOptions
from refsoft.raster import gbuffer
from refsoft.scene.camera import Camera
from refsoft.scene.primitives import box, icosphere, plane_grid
from refsoft.search import HIDDEN, search
from refsoft.search.bounces import LevelSearch, gbuffer_of, make_bounce, search_bounce
from refsoft.search.levels import BOUNCE_DEPTH
from refsoft.search.silhouette import clip_at_silhouette
from refsoft.search.tessellate import tessellate

from test_bounce_search import _bounce, two_balls


@pytest.fixture(scope="module")
def ball():
    """A mirror ball's G-buffer at 96x72 and a box beside it (its triangles reflected)."""
    cam = Camera(eye=(0.0, 0.3, 4.0), target=(0, 0, 0), fov_y=40.0, width=96, height=72)
    gb = gbuffer(icosphere(4, 1.0), cam, "float32", origin=cam.eye)
    mesh = box((1.0, 1.0, 1.0), 3)
    verts = np.asarray(mesh.vertices, np.float64) + [1.3, 0.6, 1.2]
    return cam, gb, verts, np.asarray(mesh.normals, np.float64), mesh.faces.astype(np.int64)


def naive_edge_errors(P, N, mask, origin, E, verts, pixel, e0, e1):
    """The thesis's error of edges (verts[e0], verts[e1]) with each texel's own eye ``E``, one edge
    at a time: at the texel halfway between the ends' pixels (rounded down), ``1 - (N.b + 1) / 2``
    with ``b`` the unit bisector of the unit directions to the eye and to the edge's midpoint; 1
    where an end has no pixel or that texel is not covered."""
    out = np.ones(len(e0))
    unit = (lambda x: x / np.linalg.norm(x) if np.linalg.norm(x) > 0 else np.zeros(3))
    for i, (a, b) in enumerate(zip(e0, e1)):
        if (pixel[a] < 0).any() or (pixel[b] < 0).any():
            continue
        r, c = (pixel[a] + pixel[b]) // 2
        if not mask[r, c]:
            continue
        p = P[r, c].astype(np.float64) + origin
        bis = unit(unit(E[r, c] - p) + unit(0.5 * (verts[a] + verts[b]) - p))
        out[i] = 1.0 - (float(N[r, c].astype(np.float64) @ bis) + 1.0) / 2.0
    return out


def test_with_every_eye_the_cameras_a_later_levels_tessellation_is_the_first_levels(ball):
    """On a bounce whose every eye is the camera's, the tessellation with the level's own search
    and edge error gives the first level's vertices, pixels, flags and faces bit for bit (the
    midpoints searched by the bounce's walk from the same starts), and it splits triangles."""
    cam, gb, verts, normals, faces = ball
    b = _bounce(cam, gb, cam.eye)
    g = gbuffer_of(b, cam)
    res = search_bounce(b, g, verts, "cross")
    obj = np.ones(len(faces), np.int32)
    args = (g, cam.eye, verts, normals, faces, obj, res.pixel, res.flags, 1e-3, 2, "cross", "discard")
    ref = tessellate(*args)
    got = tessellate(*args, level=LevelSearch(b, g, "cross", None, "discard"))
    assert got.searched == ref.searched > 0 and len(got.faces) > len(faces)
    for name in ("vertices", "normals", "pixel", "flags", "faces", "face_obj"):
        assert np.array_equal(getattr(got, name), getattr(ref, name)), name


def test_a_later_levels_midpoints_are_searched_and_measured_from_each_pixels_eye(ball):
    """With another eye at every pixel the edge errors are the plain per-edge reference's, the new
    vertices' pixels are the bounce search's from their parents' halfway pixel, and they are not
    the ones the camera's eye gives (the eyes are read)."""
    cam, gb, verts, normals, faces = ball
    eye = (1.5, 1.0, 2.5)
    b = _bounce(cam, gb, eye)
    g = gbuffer_of(b, cam)
    res = search_bounce(b, g, verts, "cross")
    level = LevelSearch(b, g, "cross", None, "discard")
    e0, e1 = faces.reshape(-1), faces[:, [1, 2, 0]].reshape(-1)
    err = level.edge_errors(verts, res.pixel, e0, e1)
    ref = naive_edge_errors(g.position, g.normal, g.mask, g.origin, b.eye, verts, res.pixel, e0, e1)
    assert np.allclose(err, ref, rtol=0, atol=1e-12) and (err < 1).sum() >= 20
    t = tessellate(g, cam.eye, verts, normals, faces, np.ones(len(faces), np.int32), res.pixel, res.flags, 1e-3, 1,
                   level=level)
    new = slice(len(verts), None)
    assert t.searched > 0 and len(t.faces) > len(faces)
    # each new vertex is the midpoint of an edge; its walk is the bounce search's from the parents' halfway pixel
    from refsoft.search.tessellate import _midpoint_starts

    keys = np.unique(np.sort(np.c_[e0, e1], axis=1), axis=0)
    mids = 0.5 * (verts[keys[:, 0]] + verts[keys[:, 1]])
    row = {tuple(m): i for i, m in enumerate(mids)}
    which = np.array([row[tuple(v)] for v in t.vertices[new]])
    pa, pb = res.pixel[keys[which, 0]].astype(np.int64), res.pixel[keys[which, 1]].astype(np.int64)
    again = search_bounce(b, g, t.vertices[new], "cross", start=_midpoint_starts(g.mask, pa, pb))
    assert np.array_equal(again.pixel, t.pixel[new]) and np.array_equal(again.flags, t.flags[new])
    cam_level = LevelSearch(_bounce(cam, gb, cam.eye), g, "cross", None, "discard")
    assert np.any(cam_level.search(t.vertices[new], t.pixel[new]).pixel != t.pixel[new])


def test_with_every_eye_the_cameras_a_later_levels_cut_is_the_first_levels_bisection(ball):
    """The cut at the silhouette on a bounce whose every eye is the camera's: the first level's
    bisection (``predict`` off) bit for bit."""
    cam, gb, verts, normals, faces = ball
    rng = np.random.default_rng(5)
    d = rng.normal(size=(60, 3))
    near = d / np.linalg.norm(d, axis=1, keepdims=True) * rng.uniform(1.05, 1.8, (60, 1))
    allv = np.vstack([verts, near])
    tri = np.vstack([faces, len(verts) + np.arange(60).reshape(20, 3)])
    b = _bounce(cam, gb, cam.eye)
    g = gbuffer_of(b, cam)
    res = search_bounce(b, g, allv, "cross")
    nrm = np.vstack([normals, np.tile([0.0, 1.0, 0.0], (60, 1))])
    args = (g, cam.eye, allv, nrm, tri, np.ones(len(tri), np.int32), res.pixel, res.flags, "cross")
    ref = clip_at_silhouette(*args)
    got = clip_at_silhouette(*args, level=LevelSearch(b, g, "cross", None, "discard"), predict=True)
    assert ref.cut >= 5
    for name in ("vertices", "pixel", "flags", "faces", "face_obj", "t"):
        assert np.array_equal(getattr(got, name), getattr(ref, name)), name


def test_the_cut_on_a_flat_mirror_seen_from_another_eye_is_where_the_edge_crosses_the_plane():
    """Hand-checked: a flat mirror (the plane y = 0, seen by the camera from above) as a bounce
    whose pixels' eye is a point E above it. A point is HIDDEN exactly when it lies below the
    plane, whatever texel its walk ends on (every texel's tangent plane is the mirror's), so the
    edge from A (0.5 above) to B (0.3 below) is cut at t = 0.5 / 0.8 = 0.625 to within the
    bisection's 2**-CLIP_ITERATIONS; the cut point lies on the mirror, where it reflects itself:
    its walk ends beside the point's view pixel (within 2 pixels: for a point on the mirror the
    score depends on the direction to it alone, flat along the line towards the eye's foot). The triangle (A, C, B) with one hidden corner B is
    replaced by (A, C, X_CB) and (A, X_CB, X_BA), the cut points numbered after the corners in
    the order of their edges' (visible, hidden) ends: X_BA = 3, X_CB = 4."""
    cam = Camera(eye=(0.0, 3.0, 0.5), target=(0, 0, 0), fov_y=50.0, width=80, height=60)
    gb = gbuffer(plane_grid((4.0, 4.0), (4, 4)), cam, "float64", origin=cam.eye)
    b = _bounce(cam, gb, (0.3, 2.0, 0.4))
    g = gbuffer_of(b, cam, "float64")
    A, B, C = np.array([0.1, 0.5, 0.0]), np.array([0.2, -0.3, 0.1]), np.array([-0.2, 0.4, -0.1])
    verts = np.array([A, C, B])
    res = search_bounce(b, g, verts, "cross")
    assert res.flags.tolist()[2] & HIDDEN and not (res.flags[:2] & HIDDEN).any()
    c = clip_at_silhouette(g, cam.eye, verts, np.tile([0.0, 1.0, 0.0], (3, 1)), np.array([[0, 1, 2]]),
                           np.ones(1, np.int32), res.pixel, res.flags, "cross", level=LevelSearch(b, g))
    assert c.cut == 2 and c.faces.tolist() == [[0, 1, 4], [0, 4, 3]]
    ends = c.ends.tolist()
    t_a = c.t[ends.index([0, 2])]
    t_c = c.t[ends.index([1, 2])]
    tol = 2.0 ** -CLIP_ITERATIONS
    assert 0.625 - tol <= t_a <= 0.625 and 0.4 / 0.7 - tol <= t_c <= 0.4 / 0.7
    assert np.all(np.abs(c.vertices[:, 1]) <= 0.8 * tol) and not (c.flags & HIDDEN).any()
    from refsoft.truth.metrics import window_to_pixel

    view = window_to_pixel(c.vertices, gb.view_proj, gb.mask.shape)
    assert np.all(np.abs(c.pixel + [b.box[0], b.box[2]] - view) <= 2.0)


@pytest.fixture(scope="module")
def refined():
    """The two balls with three bounces under the paper preset with tessellation and the cut, and
    without them."""
    sc = two_balls()
    opts = RenderOptions.from_preset("paper", bounces=3, tessellate=1e-3, max_level=2, silhouette="clip")
    plain = RenderOptions.from_preset("paper", bounces=3)
    return sc, opts, FrameDriver(sc, opts).render_frame(0), FrameDriver(sc, plain).render_frame(0)


def test_a_later_level_drawn_by_the_virtual_pass_is_tessellated_and_cut(refined):
    """Every later level reports its tessellation (more triangles than the scene's: it split
    some) and its cut; the pictures differ from the untessellated ones there, and the first
    level's pixels with them are the first level's tessellated picture."""
    sc, opts, got, plain = refined
    later = [e for es in got.report["bounces"].values() for e in es if e["level"] > 1]
    n_faces = sum(o.mesh.n_faces for o in sc.objects if not o.reflector)
    assert {e["level"] for e in later} == {2, 3}
    assert all(e["tessellation"]["triangles"] > n_faces and e["tessellation"]["vertices_searched"] > 0 for e in later)
    assert all("silhouette" in e for e in later) and sum(e["silhouette"]["edges_cut"] for e in later) > 0
    assert not any("tessellation" in e for es in plain.report["bounces"].values() for e in es)
    deep = got.arrays[BOUNCE_DEPTH] >= 2
    assert np.array_equal(deep, plain.arrays[BOUNCE_DEPTH] >= 2)  # level 1 decides where level 2 is
    assert np.any(got.arrays["image"][deep] != plain.arrays["image"][deep])
    one = FrameDriver(sc, RenderOptions.from_preset("paper", bounces=1, tessellate=1e-3, max_level=2,
                                                    silhouette="clip")).render_frame(0)
    first = got.arrays[BOUNCE_DEPTH] == 1
    assert np.array_equal(got.arrays["image"][first], one.arrays["image"][first])


def test_a_tessellated_later_level_gives_the_same_bits_with_one_thread(refined):
    sc, opts, got, _ = refined
    with one_thread():
        again = FrameDriver(sc, opts).render_frame(0)
    for key, a in got.arrays.items():
        assert np.array_equal(a, again.arrays[key]), key
    counts = (lambda f: {r: [{k: v for k, v in e.items() if k != "ms"} for e in es]
                             for r, es in f.report["bounces"].items()})
    assert counts(again) == counts(got)  # the levels' searches, splits and cuts too
