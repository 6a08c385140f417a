"""The per-pixel LDT search kernel against the written-out reference (tests/naive.py), pixel for
pixel; determinism; a head-on hit."""

import numba
import numpy as np
import pytest

from naive import naive_ldt_pixel
from refsoft import Camera, FrameDriver, RenderOptions, Scene, SceneObject, Transform
from refsoft.ldt import constants as C
from refsoft.ldt.build import build_ldt
from refsoft.ldt.method import LayeredDepthTextures
from refsoft.ldt.search import Stack, cube_matrices, search
from refsoft.scene import primitives as P


def small_scene(width=48, height=36):
    """A mirror ball reflecting a tilted torus (two layers), a box whose cube overlaps the torus's,
    an open sheet cutting into the mirror (rays start behind it: the crossing rule), and a ball
    sunk into the mirror (rays start inside its cube, a few within a texel of it: START_INSIDE)."""
    objs = [SceneObject("mirror", P.icosphere(3), (0.9, 0.9, 0.9), reflector=True),
            SceneObject("torus", P.torus(0.6, 0.2, 24, 12), (0.9, 0.3, 0.2), Transform((1.4, 0.3, 0.9), (0, 30, 60))),
            SceneObject("box", P.box((0.5, 0.7, 0.4)), (0.2, 0.3, 0.9), Transform((1.3, -0.5, 1.5), (10, 30, 0))),
            SceneObject("sheet", P.plane_grid((1.2, 0.8), (2, 2)), (0.8, 0.8, 0.2),
                        Transform((-0.8, 0.0, 0.9), (20, 30, 60))),
            SceneObject("sunk", P.icosphere(2, 0.5), (0.2, 0.9, 0.4), Transform((-0.4, -0.9, 0.6)))]
    cam = Camera(eye=(0.0, 0.3, 4.0), target=(0, 0, 0), width=width, height=height, fov_y=34)
    return Scene(objs, cam, name="ldt-small")


def run(method):
    frame = FrameDriver(method.scene, RenderOptions(preset="paper"), method=method).render_frame(0)
    return frame, frame.reflectors[1].state


CONFIGS = {
    "float32 cone three 32": dict(precision="float32", regions="cone", faces="three", linear=32),
    "float64 none entry texel": dict(precision="float64", regions="none", faces="entry", linear="texel"),
    "float32 none three 5": dict(precision="float32", regions="none", faces="three", linear=5),
}


@pytest.mark.parametrize("name", sorted(CONFIGS))
def test_kernel_equals_the_reference_pixel_for_pixel(name):
    cfg = CONFIGS[name]
    method = LayeredDepthTextures(small_scene(), resolution=32, **cfg)
    _, st = run(method)
    dt = np.float32 if cfg["precision"] == "float32" else np.float64
    s, res = method.stack, st.result
    W = st.W.astype(dt)
    n_lin = 0 if cfg["linear"] == "texel" else cfg["linear"]
    max_faces = 3 if cfg["faces"] == "three" else 1
    eye = method.scene.camera.eye.astype(dt)
    assert len(st.rows) > 300 and res.ray.dtype == dt
    flags = 0
    for i in range(len(st.rows)):
        ref = naive_ldt_pixel(st.P[i], st.N[i], eye, st.triangle[i], st.region, cfg["regions"] == "cone", W,
                              s.depth, s.back, s.count, s.mismatch, s.open, s.resolution, n_lin, C.TAU, max_faces, dt)
        got = (res.ray[i].tolist(), res.distance[i], res.object[i], res.face[i], res.layer[i], tuple(res.texel[i]),
               res.residual[i], res.margin[i], res.flags[i], res.linear_samples[i], res.binary_steps[i],
               res.faces_searched[i], res.objects_tested[i], res.object_distance[i].tolist(), res.hit[i].tolist())
        want = ([float(x) for x in ref["ray"]], ref["distance"], ref["object"], ref["face"], ref["layer"],
                tuple(ref["texel"]), ref["residual"], ref["margin"], ref["flags"], ref["samples"], ref["steps"],
                ref["faces"], ref["objects"], [float(x) for x in ref["object_distance"]], [float(x) for x in ref["hit"]])
        assert got == want, f"pixel {i} ({st.rows[i]}, {st.cols[i]})"
        flags |= int(ref["flags"])
    # the case is not trivial: several objects hit, layer 2 used, the flags exercised
    hit = res.object >= 0
    assert hit.mean() > 0.05 and len(np.unique(res.object[hit])) >= 3
    assert flags & C.OPEN_OBJECT and flags & C.ORIGIN_IN_CUBE and flags & C.START_INSIDE
    if cfg["regions"] == "cone":
        assert flags & C.REGION_CULLED
    assert res.binary_steps.max() > 0
    if cfg["faces"] == "three":
        assert (res.layer[hit] == 1).sum() >= 5 and flags & C.NO_FACE_WITHIN_TAU


def test_search_is_bit_identical_across_thread_counts():
    method = LayeredDepthTextures(small_scene(), resolution=32)
    _, st = run(method)
    args = (st.P, st.N, method.scene.camera.eye, st.triangle, st.region, st.W, method.stack)
    numba.set_num_threads(1)
    try:
        one = search(*args)
    finally:
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    two = search(*args)
    for name in one.__dataclass_fields__:
        np.testing.assert_array_equal(getattr(one, name), getattr(two, name))


@pytest.mark.parametrize("precision", ["float32", "float64"])
def test_head_on_hit_is_accepted_within_an_eighth_of_a_texel(precision):
    """A ray straight down the -z axis onto a sphere's pole: the +Z face, layer 0, residual below
    1/8 texel, at the sphere's surface."""
    ldt = build_ldt(P.icosphere(4), 64)
    stack = Stack.of({1: ldt}, precision)
    W = cube_matrices(stack, {1: Transform()})
    dt = np.float32 if precision == "float32" else np.float64
    # the eye behind P: I = -z; a normal of +z... reflects I to +z, so use N along the ray's bisector
    eye = np.array([0.05, 0.03, 6.0])
    Pt = np.array([[0.05, 0.03, 3.0]])
    N = np.array([[0.0, 1.0, 0.0]])           # I . N = 0: r = I = -z, straight at the sphere
    res = search(Pt, N, eye, [0], np.ones((1, 1), bool), W, stack, regions="none", precision=precision)
    assert res.object[0] == 0 and res.face[0] == 4 and res.layer[0] == 0
    assert 0 <= res.residual[0] < 0.125
    z = np.sqrt(1 - 0.05 ** 2 - 0.03 ** 2)
    assert abs(res.hit[0, 2] - z) < 2 * ldt.cube_half / 64  # within a texel's depth (faceting)
    assert res.flags[0] & ~np.uint8(0) == 0 and res.objects_tested[0] == 1 and res.faces_searched[0] == 1


@pytest.mark.parametrize("precision", ["float32", "float64"])
def test_axis_aligned_rays_with_zero_components(precision):
    """An orthographic view straight down onto a flat mirror facing +z: r = +z exactly, so u_x = u_y
    = 0 and the slab test takes its parallel branch; the kernel equals the reference, the sphere
    above is hit at its underside and points outside its cube in x miss."""
    ldt = build_ldt(P.icosphere(3, 0.5), 32)
    stack = Stack.of({1: ldt}, precision)
    W = cube_matrices(stack, {1: Transform((0.0, 0.0, 2.0))})
    dt = np.float32 if precision == "float32" else np.float64
    xs = np.linspace(-0.7, 0.7, 15)
    Pt = np.stack([xs, 0.5 * xs, np.zeros_like(xs)], axis=1)
    N = np.tile([0.0, 0.0, 1.0], (len(xs), 1))
    view = np.array([0.0, 0.0, -1.0])
    res = search(Pt, N, np.zeros(3), np.zeros(len(xs), int), np.ones((1, 1), bool), W, stack, view_dir=view,
                 regions="none", precision=precision)
    assert np.all(res.ray == np.array([0, 0, 1], dt))
    for i in range(len(xs)):
        ref = naive_ldt_pixel(Pt[i], N[i], np.zeros(3), 0, None, False, W.astype(dt), stack.depth, stack.back,
                              stack.count, stack.mismatch, stack.open, 32, 32, C.TAU, 3, dt, view_dir=view)
        assert (res.distance[i], res.face[i], tuple(res.texel[i]), res.objects_tested[i]) == \
            (ref["distance"], ref["face"], tuple(ref["texel"]), ref["objects"])
    r = np.hypot(xs, 0.5 * xs)
    inside = r < 0.45
    assert np.all(res.object[inside] == 0) and np.all(res.face[inside] == 5)  # the -Z face looks along +z
    expect = 2.0 - np.sqrt(0.25 - r[inside] ** 2)
    # nearest-texel depth: within a texel times (1 + the surface's slope to the face)
    texel = 2 * ldt.cube_half / 32
    slope = r[inside] / np.sqrt(0.25 - r[inside] ** 2)
    assert np.all(np.abs(res.distance[inside] - expect) < texel * (1 + slope))
    outside_cube = np.abs(xs) > ldt.cube_half
    assert outside_cube.any() and np.all(res.objects_tested[outside_cube] == 0)
