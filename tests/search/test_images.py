"""Every reflection point of every vertex (refsoft.search.images, spec section 4.8): the pruned
enumeration gives the images of the plain reference that judges every covered texel
(tests/naive_images.py), pixel for pixel and in the same order, on small G-buffers of a ball
seen from outside, a bowl seen from inside, a torus (saddle and convex parts) and an open sheet;
the walk's pixel comes first; the results do not depend on the thread count."""

import numba
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import naive_images
from refsoft import search
from refsoft._parallel import one_thread
from refsoft.errors import RefsoftError
from refsoft.raster import gbuffer
from refsoft.scene.builtin.shapes import bowl
from refsoft.scene.camera import Camera
from refsoft.scene.primitives import icosphere, plane_grid, torus
from refsoft.search.images import SEVERAL, Images, find_images, mirrored

W, H = 48, 36


def _mesh(kind):
    if kind == "ball":
        return icosphere(3, 1.0)
    if kind == "bowl":
        return bowl(1.5, 16, 48, inside=True)[0]
    if kind == "torus":
        return torus(1.2, 0.45, 48, 24, major_angle_deg=180.0)
    return plane_grid((3.0, 3.0), (4, 4))  # the open sheet, y = 0, normals +y


EYES = {"ball": (0.0, 0.8, 4.0), "bowl": (0.0, 3.0, 2.2), "torus": (0.2, 2.0, 4.0), "sheet": (0.0, 2.0, 3.0)}


@pytest.fixture(scope="module", params=["ball", "bowl", "torus", "sheet"])
def case(request):
    kind = request.param
    eye = EYES[kind]
    cam = Camera(eye=eye, target=(0.0, -0.3 if kind == "bowl" else 0.0, 0.0), fov_y=45.0, width=W, height=H)
    gb = gbuffer(_mesh(kind), cam, "float32", origin=cam.eye)
    rng = np.random.default_rng(7)
    verts = rng.uniform(-1.5, 1.5, (40, 3))
    if kind == "bowl":
        verts[:, 1] = rng.uniform(-1.4, 1.0, 40)  # inside the bowl and above it
    if kind == "sheet":
        verts[:20, 1] = -np.abs(verts[:20, 1]) - 0.05  # behind the sheet: no image
        verts[20:, 1] = np.abs(verts[20:, 1]) + 0.05
    res = search.search(gb, cam.eye, verts, "box")
    return kind, gb, np.asarray(eye, dtype=np.float64), verts, res


def _reference(gb, eye, verts, res):
    dt = gb.position.dtype
    return naive_images.count_images(gb.position, gb.normal, gb.mask, (eye - gb.origin).astype(dt),
                                     (verts - gb.origin).astype(dt), res.pixel)


def _rows(im: Images, i):
    return [tuple(int(x) for x in p) for p in im.pixel[im.offset[i]:im.offset[i + 1]]]


def test_images_are_the_references(case):
    kind, gb, eye, verts, res = case
    im = find_images(gb, eye, verts, res)
    ref = _reference(gb, eye, verts, res)
    assert [_rows(im, i) for i in range(len(verts))] == ref
    counts = im.count
    if kind == "ball":
        assert counts.max() <= 1  # a convex mirror: at most one image
    if kind == "sheet":
        assert np.all(counts[:20] == 0)  # behind an open mirror everywhere: none
        assert np.all(counts[20:] <= 1)
    if kind in ("bowl", "torus"):
        assert counts.max() >= 2  # these vertices include some with several images


def test_walk_pixel_first_and_record(case):
    kind, gb, eye, verts, res = case
    im = find_images(gb, eye, verts, res)
    assert im.offset.dtype == np.int64 and im.pixel.dtype == np.int32 and im.sheet.dtype == np.int32
    assert im.virtual.dtype == np.float64 and im.virtual.shape == (len(im.pixel), 3)
    assert np.all(im.sheet == -1) and len(im) == len(verts)
    assert np.array_equal(im.vertex, np.repeat(np.arange(len(verts)), im.count))
    # where the walk's pixel has an image, it is the vertex's first: the texel where Newton's
    # iteration from the walk's pixel converged (tests/naive_images.py's converge)
    P, N, mask = gb.position, gb.normal, gb.mask
    e_rel = (eye - gb.origin).astype(P.dtype)
    _, U = naive_images.scores(P, N, mask, e_rel, (verts[0] - gb.origin).astype(P.dtype))
    for i in range(len(verts)):
        rows = _rows(im, i)
        r, c = (int(x) for x in res.pixel[i])
        v_rel = (verts[i] - gb.origin).astype(P.dtype)
        got = None
        if r >= 0 and mask[r, c]:
            d, n = (v_rel - P[r, c]).astype(P.dtype), N[r, c]
            if ((d[0] * n[0] + d[1] * n[1]) + d[2] * n[2]) > 0 and naive_images.reaches(P, N, U, mask, v_rel, r, c):
                got = naive_images.converge(P, N, U, mask, v_rel, r, c)
        if got is not None:
            assert rows[0] == got[0]
    # the virtual vertex is the mirror across the image's tangent plane (float64, world space)
    r, c = im.pixel[:, 0], im.pixel[:, 1]
    p = gb.position[r, c].astype(np.float64) + gb.origin
    n = gb.normal[r, c].astype(np.float64)
    v = verts[im.vertex]
    assert np.allclose(im.virtual, v - 2 * np.sum((v - p) * n, axis=1)[:, None] * n, rtol=0, atol=1e-12)
    assert np.array_equal(mirrored(gb, v, im.pixel), im.virtual)


def test_same_bits_for_every_thread_count(case):
    kind, gb, eye, verts, res = case
    with one_thread():
        a = find_images(gb, eye, verts, res)
    n = numba.config.NUMBA_NUM_THREADS
    b = find_images(gb, eye, verts, res)
    assert n >= 1
    for x, y in ((a.offset, b.offset), (a.pixel, b.pixel), (a.virtual, b.virtual)):
        assert np.array_equal(x, y)


@pytest.fixture(scope="module")
def bowl_buffer():
    cam = Camera(eye=(0.0, 3.0, 2.2), target=(0.0, -0.3, 0.0), fov_y=45.0, width=W, height=H)
    return gbuffer(_mesh("bowl"), cam, "float32", origin=cam.eye), np.array(cam.eye)


@settings(max_examples=15, deadline=None)
@given(st.floats(-1.3, 1.3), st.floats(-1.4, 1.2), st.floats(-1.3, 1.3))
def test_bowl_any_vertex(bowl_buffer, x, y, z):
    gb, eye = bowl_buffer
    verts = np.array([[x, y, z]])
    res = search.search(gb, eye, verts, "cross")
    im = find_images(gb, eye, verts, res)
    assert [_rows(im, 0)] == _reference(gb, eye, verts, res)


def test_bad_inputs(case):
    kind, gb, eye, verts, res = case
    with pytest.raises(RefsoftError, match="result has"):
        find_images(gb, eye, verts[:3], res)
    with pytest.raises(RefsoftError, match="SearchResult"):
        find_images(gb, eye, verts, res.pixel)
    with pytest.raises(RefsoftError, match="reach"):
        find_images(gb, eye, verts, res, reach=-1.0)
    assert SEVERAL == 32


def test_trace_replays_the_kernel(case):
    from refsoft.search.images import VERDICTS, trace_images

    kind, gb, eye, verts, res = case
    im = find_images(gb, eye, verts, res)
    for i in range(0, len(verts), 4):
        tr = trace_images(gb, eye, verts[i], res.pixel[i])
        assert [tuple(p) for p in tr.images] == _rows(im, i)
        assert tr.visited + tr.pruned >= 1 and tr.judged >= sum(m["verdict"] == "accepted" for m in tr.maxima)
        assert all(m["verdict"] in VERDICTS for m in tr.maxima)
        accepted = {tuple(m["image"]) for m in tr.maxima if m["verdict"] == "accepted"}
        walks = {tuple(tr.images[0])} if tr.walk_is_image else set()
        assert set(_rows(im, i)) - walks <= accepted  # the others are accepted maxima's images
        if tr.walk_is_image:  # the walk's image: within IMAGE_REACH texels of the walk's pixel
            assert all(abs(a - b) <= 4.0 for a, b in zip(tr.images[0], res.pixel[i]))
        assert all(abs(a - b) <= 4.0 for m in tr.maxima if m["verdict"] == "accepted"
                   for a, b in zip(m["texel"], m["image"]))  # converged within IMAGE_REACH texels
        assert "every image" in tr.table() and tr.to_dict()["images"] == tr.images
