"""Every image drawn on a mirror that is not convex (refsoft/search/several.py, spec section 4.8),
against the slow per-pixel ray tracer of tests/naive_several.py on a tiny concave scene (a bowl, a
floor and a small box at 64x48)."""

import numpy as np
import pytest

from refsoft import Camera, Scene, SceneObject, Transform, constants, primitives
from refsoft._parallel import one_thread
from refsoft.errors import RefsoftError
from refsoft.frame import FrameDriver, RenderOptions
from refsoft.scene.builtin.shapes import bowl
from refsoft.search import acceptance, reach, several
from refsoft.search.images import Images
from refsoft.search.method import VertexSearch
from refsoft.search.virtual import reflected_mesh

import naive_several as naive

W, H = 64, 48
#: Share of the mirror's pixels whose object id agrees with the naive ray tracer (measured 98.9 %
#: on frame 0; one point below).
AGREEMENT_FLOOR = 0.979


def _scene():
    inner, _ = bowl(1.5, 32, 96, inside=True)
    objs = (
        SceneObject("bowl_inside", inner, (0.85, 0.85, 0.85), Transform((0, 0, 0)), reflector=True, open=True),
        SceneObject("blue_box", primitives.box((0.35, 0.35, 0.35), 3), (0.2, 0.3, 0.9),
                    Transform((-0.5, 0.8, -0.3), (20, 30, 0))),
        SceneObject("floor", primitives.plane_grid((10.0, 10.0), (20, 20)), (0.35, 0.55, 0.35),
                    Transform((0, -1.6, 0))),
    )
    cam = Camera(eye=(0.0, 3.0, 2.2), target=(0.0, -0.5, 0.0), fov_y=45.0, width=W, height=H)
    return Scene(objs, cam, None, "tiny_concave")


class _Spy(VertexSearch):
    """The vertex search, keeping what its last reflect saw."""

    def reflect(self, view, k, stencil):
        self.seen = (view, k, stencil)
        out = super().reflect(view, k, stencil)
        self.seen += (out,)
        return out


def _render(scene, images="all"):
    opt = RenderOptions(images=images)
    driver = FrameDriver(scene, opt, method=_Spy(scene, opt))
    frame = driver.render_frame(0)
    return frame, driver.method.seen


def _images(out, view):
    return out.state.images


@pytest.fixture(scope="module")
def drawn():
    """The tiny scene drawn with every image, and the naive truth."""
    scene = _scene()
    frame, (view, k, stencil, out) = _render(scene)
    truth = naive.trace_reflections(scene, view.meshes, view.camera, stencil, view.meshes[k - 1],
                                    view.view.triangle)
    return scene, frame, view, k, stencil, out, truth


def test_object_ids_agree_with_naive_ray_tracer(drawn):
    scene, frame, view, k, stencil, out, truth = drawn
    rid = frame.arrays["reflected_id"]
    agree = np.mean(rid[stencil] == truth[stencil])
    assert agree >= AGREEMENT_FLOOR, agree
    rep = out.report["several"]
    assert rep["pixels_accepted"] == int(np.sum(rid[stencil] > 0))
    assert rep["candidates"] > 0 and rep["pixels_empty"] == int(np.sum(stencil & (rid == 0))) > 0


def test_every_drawn_pixel_sees_what_it_draws(drawn):
    """Acceptance is exact: where the drawing shows an object, its reflected ray hits it (the
    naive tracer's nearest hit is that object); nothing is drawn where the tracer sees nothing."""
    scene, frame, view, k, stencil, out, truth = drawn
    rid = frame.arrays["reflected_id"]
    shown = stencil & (rid > 0)
    assert np.all(truth[shown] == rid[shown])
    assert not np.any(rid[stencil & (truth == 0)])


def _candidate_check(view, k, stencil, real, virtual):
    """Draw one candidate; return the pixels drawn, the pixels its dilated screen triangle covers
    and the pixels whose reflected ray hits its real triangle (naive)."""
    cand = acceptance.Candidates(virtual[None], real[None], np.tile([0.0, 1.0, 0.0], (1, 3, 1)), np.array([2], np.int32),
                              np.array([0]), 0)
    box = (0, H, 0, W)
    colors = np.ones((4, 3), np.float32)
    _, rid, covered, counts = acceptance.draw(cand, view.camera, view.meshes[k - 1], view.view.triangle, stencil, box,
                                           colors)
    rows, cols, o, d = naive.reflected_rays(view.camera, stencil, view.meshes[k - 1], view.view.triangle)
    hits = np.zeros((H, W), bool)
    hits[rows, cols] = naive.first_hits(o, d, real[None]) == 0
    screen, _, dil = acceptance._screen(virtual[None], view.camera, box)
    inside = np.zeros((H, W), bool)
    a, b, c = screen[0]
    area = _cross(b - a, c - a)
    for r, cc in zip(*np.nonzero(stencil)):
        p = np.array([cc + 0.5, r + 0.5])
        ok = True
        for x, y in ((a, b), (b, c), (c, a)):
            ok &= np.sign(area) * _cross(y - x, p - x) >= -dil[0] * np.hypot(*(y - x))
        inside[r, cc] = ok
    return covered, inside, hits, counts


def _cross(u, v):
    return u[0] * v[1] - u[1] * v[0]


def _floor_triangle_across_the_gap(view, k, images, faces, verts):
    """A floor triangle whose corners' images lie far apart on the screen (across the ring's
    middle), its real corners and the virtual triangle of one image per corner."""
    off = images.offset
    best = None
    for f in faces:
        if np.any(off[f + 1] == off[f]):
            continue
        px = images.pixel[off[f]]
        span = np.max(np.abs(px[:, None] - px[None]))
        if best is None or span > best[0]:
            best = (span, f)
    f = best[1]
    return best[0], verts[f], images.virtual[off[f]]


def test_triangle_spanning_the_tear_is_not_drawn_across_the_gap(drawn):
    scene, frame, view, k, stencil, out, truth = drawn
    comb = reflected_mesh(scene, view.meshes)[1]
    images = _images(out, view)
    span, real, virtual = _floor_triangle_across_the_gap(view, k, images, comb.faces, view.vertices)
    assert span > 10  # its images lie on either side of the gap
    covered, inside, hits, counts = _candidate_check(view, k, stencil, real, virtual)
    assert np.sum(inside & ~hits) > 20  # the virtual triangle covers the gap...
    assert not np.any(covered & ~hits)  # ...where nothing is drawn
    assert np.array_equal(covered, inside & hits)  # it draws exactly the part that reflects there
    assert counts["pixels_empty"] == int(np.sum(stencil & ~hits))


def test_triangle_crossing_a_fold_draws_only_its_reflecting_part(drawn):
    """A big floor triangle (12 x 6 units under the 3-unit bowl: it reflects on both sides of the
    ring, and the bowl's rim folds the mapping) given as a candidate whose screen triangle is its
    own projection: it is drawn exactly where its reflected rays hit it, nowhere else it covers."""
    scene, frame, view, k, stencil, out, truth = drawn
    real = np.array([[-3.0, -1.6, -3.0], [3.0, -1.6, -3.0], [0.0, -1.6, 3.0]])
    rows, cols = np.nonzero(stencil)
    covered, inside, hits, counts = _candidate_check(view, k, stencil, real, real.copy())
    assert np.array_equal(covered, inside & hits)
    assert np.any(covered) and np.any(inside & ~hits)


def test_bit_identical_across_runs_and_threads(drawn):
    scene, frame, *_ = drawn
    again, _ = _render(scene)
    with one_thread():
        single, _ = _render(scene)
    for other in (again, single):
        for key in ("image", "reflected_id"):
            assert np.array_equal(frame.arrays[key], other.arrays[key]), key


def test_sheets_are_linked_components_rooted_at_their_smallest_image():
    images = Images(np.array([0, 2, 3, 5], np.int64), np.zeros((5, 2), np.int32), np.zeros((5, 3)),
                    np.full(5, -1, np.int32))
    got = several.sheets(images, np.array([[4, 2], [1, 4], [0, 3]]))
    assert got.sheet.tolist() == [0, 1, 1, 0, 1]
    assert several.sheets(images, np.zeros((0, 2), np.int64)).sheet.tolist() == [0, 1, 2, 3, 4]


def test_links_are_mutual_walks(drawn):
    """Linked images: the walk from one ends on the other, both ways; every scene edge whose ends
    have one image each on the bowl's smooth middle is linked."""
    scene, frame, view, k, stencil, out, truth = drawn
    gb, eye = out.state.gbuffer, view.camera.eye
    comb = reflected_mesh(scene, view.meshes)[1]
    images = _images(out, view)
    edges = several._edges(comb.faces.astype(np.int64))
    pairs = several.links(gb, eye, view.vertices, images, edges)
    assert len(pairs)
    vert = images.vertex
    owned = {tuple(sorted(e)) for e in edges.tolist()}
    assert all(tuple(sorted((vert[i], vert[j]))) in owned for i, j in pairs.tolist())
    from refsoft.search import search

    i, j = pairs[:, 0], pairs[:, 1]
    fwd = search(gb, eye, view.vertices[vert[j]], "cross", "plane", images.pixel[i]).pixel
    assert np.all(np.max(np.abs(fwd - images.pixel[j]), axis=1) <= 1)


def test_bad_level_is_refused(drawn):
    scene, frame, view, k, stencil, out, truth = drawn
    with pytest.raises(RefsoftError, match="max_level"):
        several.candidates(out.state.gbuffer, view.camera.eye, view.vertices[:3], np.zeros((3, 3)),
                           np.array([[0, 1, 2]]), np.array([2]), out.state.images, None, max_level=-1)


def test_one_image_and_convex_mirrors_do_not_use_it():
    """With ``images="one"`` (the paper preset) or on a convex mirror (the convex skip) the
    virtual pass draws (tests/conformance guards their bits)."""
    scene = _scene()
    frame, (view, k, stencil, out) = _render(scene, "one")
    assert "several" not in out.report and "several" not in frame.report
    ball = Scene((SceneObject("ball", primitives.icosphere(2, 1.0), (0.9, 0.9, 0.9), Transform((0, 0, 0)),
                              reflector=True),) + scene.objects[1:], scene.camera, None, "tiny_ball")
    frame, (view, k, stencil, out) = _render(ball)
    assert stencil.any() and "several" not in out.report


@pytest.mark.parametrize("max_level", [0, 1, 3])
def test_candidates_match_the_plain_python_pool(drawn, max_level):
    """The vectorized candidates (triples, matching, subdivision, rim triples, assembly) are the
    plain per-face Python version's (tests/naive_several_pool.py) bit for bit, in the same order."""
    import naive_several_pool

    scene, frame, view, k, stencil, out, truth = drawn
    gb, eye, images, find = several.image_source(scene, view, k, out.state, RenderOptions(images="all"))
    comb = reflected_mesh(scene, view.meshes)[1]
    args = (gb, eye, view.vertices, comb.normals, comb.faces, comb.face_object, images, find)
    got, got_sheets = several.candidates(*args, max_level=max_level)
    want, want_sheets = naive_several_pool.candidates(*args, max_level=max_level)
    assert len(want.triangle) and (max_level == 0 or want.subdivided > 0)
    for name in ("virtual", "real", "normals", "object_id", "triangle"):
        a, b = getattr(got, name), getattr(want, name)
        assert a.dtype == b.dtype and np.array_equal(a, b), name
    assert got.subdivided == want.subdivided
    assert np.array_equal(got_sheets.sheet, want_sheets.sheet)


def test_triples_and_matching_match_the_plain_python_pool():
    """Linked triples (the kernel, with the per-face cap, on one thread and several) and the
    matching on random links, against the plain per-face loops, including corners without an
    image and faces over the cap."""
    import naive_several_pool

    rng = np.random.default_rng(7)
    count = rng.integers(0, 6, 40)
    count[:8] = (5, 5, 5, 5, 1, 2, 1, 3)  # fully linked below: faces over the cap, faces matched
    offset = np.concatenate([[0], np.cumsum(count)]).astype(np.int64)
    m = int(offset[-1])
    images = Images(offset, np.zeros((m, 2), np.int32), np.zeros((m, 3)), np.full(m, -1, np.int32))
    pairs = rng.integers(0, m, (4 * m, 2))
    full = np.arange(offset[8])
    pairs = np.concatenate([pairs, np.stack(np.meshgrid(full, full), axis=2).reshape(-1, 2)])
    faces = np.concatenate([[[0, 1, 2], [1, 2, 3], [4, 5, 6], [5, 6, 7], [4, 6, 7]],
                            rng.integers(0, 40, (300, 3))]).astype(np.int64)
    verts = np.zeros((40, 3))
    new, old = several._Pool(verts, verts, images), naive_several_pool._Pool(verts, verts, images)
    new.add_links(pairs)
    old.add_links(pairs)
    t, owner = new.triples(faces)
    want = [old.triples(f, linked=True) for f in faces]
    assert len(want[0]) == constants.SEVERAL_MAX_TRIPLES
    assert t.tolist() == [list(x) for w in want for x in w]
    assert owner.tolist() == [i for i, w in enumerate(want) for _ in w]
    with one_thread():
        t1, owner1 = new.triples(faces)
    assert np.array_equal(t1, t) and np.array_equal(owner1, owner)
    matched = new.matched(faces, t, owner)
    assert matched.tolist() == [old.matched(f, w) for f, w in zip(faces, want)]
    assert 0 < matched.sum() < len(faces)


def test_acceptance_kernel_matches_the_plain_loop():
    """The acceptance kernel (candidates outer, valid spans, bisected edges, one ray test per run
    of equal real triangles), and its variant without runs, give the plain pixel-by-candidate
    loop's outputs bit for bit, on one thread and on several: overlapping triangles at several heights, runs of equal ones with
    different screen triangles, unusable projections and slivers."""
    import naive_several_pool

    from refsoft._parallel import parallel_range
    from refsoft.search._several import accept, accept_untracked

    rng = np.random.default_rng(3)
    h, w, r0, c0 = 14, 18, 5, 7
    valid = rng.random((h, w)) < 0.8
    valid[3] = False
    origin = np.concatenate([rng.uniform(-1, 1, (h, w, 2)), np.full((h, w, 1), 2.0)], axis=2)
    direction = np.concatenate([rng.normal(0, 0.2, (h, w, 2)), np.full((h, w, 1), -1.0)], axis=2)
    real = np.concatenate([rng.uniform(-1.5, 1.5, (30, 3, 2)), rng.uniform(-0.5, 0.5, (30, 1, 1)).repeat(3, 1)],
                          axis=2)
    real = np.repeat(real, rng.integers(1, 4, 30), axis=0)  # runs of equal real triangles
    n = len(real)
    screen = rng.uniform([c0 - 3, r0 - 3], [c0 + w + 3, r0 + h + 3], (n, 3, 2))
    screen[::7, 2] = screen[::7, 0]  # slivers
    dilate = rng.uniform(0.5, 3.0, n)
    dilate[::5] = -1.0  # unusable projections: the whole bbox
    lo, hi = np.floor(screen.min(axis=1) - dilate[:, None]), np.ceil(screen.max(axis=1) + dilate[:, None])
    bbox = np.stack([lo[:, 1] - r0, hi[:, 1] - r0, lo[:, 0], hi[:, 0]], axis=1).astype(np.int64)
    want = naive_several_pool.accept(r0, c0, valid, origin, direction, screen, bbox, dilate, real)
    assert (want[1] >= 0).sum() > 20 and (want[2] > 0).any()
    for threads in (True, False):
        got = (np.full((h, w), np.inf), np.full((h, w), -1, np.int64), np.zeros((h, w, 2)), np.zeros((h, w), bool))
        args = (accept, h, r0, c0, valid, acceptance._spans(valid), origin, direction, screen, bbox, dilate, real,
                acceptance._runs(real), *got, np.full((h, w), -1, np.int64))
        if threads:
            parallel_range(*args)
        else:
            with one_thread():
                parallel_range(*args)
        for a, b in zip(got, want):
            assert np.array_equal(a, b)
        # without runs and without `tested` (the exact drawing's kernel): the same winners
        plain = (np.full((h, w), np.inf), np.full((h, w), -1, np.int64), np.zeros((h, w, 2)))
        args = (accept_untracked, h, r0, c0, valid, acceptance._spans(valid), origin, direction, screen, bbox, dilate,
                real, acceptance._ray_bounds(valid, origin, direction), constants.EXACT_TRACE_MARGIN, *plain)
        if threads:
            parallel_range(*args)
        else:
            with one_thread():
                parallel_range(*args)
        for a, b in zip(plain, want[:3]):
            assert np.array_equal(a, b)


def test_rays_near_matches_the_plain_numpy_version():
    """The kernel keeping the rays that may hit each triangle (on one thread and several) gives
    the NumPy reference's lists: rays through, beside and behind triangles, rays in a triangle's
    plane, a degenerate triangle and a non-finite one (kept: nothing proves them off)."""
    import naive_several as naive_ref

    from refsoft._parallel import parallel_range
    from refsoft.search._several import rays_near

    rng = np.random.default_rng(11)
    real = rng.uniform(-1.0, 1.0, (40, 3, 3))
    real[:, :, 2] = rng.uniform(-0.3, 0.3, (40, 1))  # roughly facing the rays
    real[5] = [[0, 0, 0], [1, 0, 0], [2, 0, 0]]  # degenerate
    real[6, 1, 0] = np.nan
    origin = np.concatenate([rng.uniform(-1.2, 1.2, (300, 2)), np.full((300, 1), 2.0)], axis=1)
    direction = np.concatenate([rng.normal(0, 0.1, (300, 2)), np.full((300, 1), -1.0)], axis=1)
    origin[::9, 2] = -2.0  # behind: t < 0
    direction[::13] = [1.0, 0.0, 0.0]  # in the plane of flat triangles
    first = rng.integers(0, 150, 40)
    last = first + rng.integers(0, 150, 40)
    ray = rng.permutation(300).astype(np.int64)
    margin, parallel = constants.SEVERAL_PRUNE_MARGIN, constants.SEVERAL_PRUNE_PARALLEL
    want = naive_ref.rays_near(real, origin, direction, first, last, ray, margin, parallel)
    kept = sum(len(w) for w in want)
    assert 0 < kept < np.sum(last - first) and want[5] == ray[first[5]:last[5]].tolist()
    assert want[6] == ray[first[6]:last[6]].tolist()
    lists = reach.Reach(origin, direction)
    every = lists.test(real, *lists.every(len(real)))
    assert lists.ray()[every[0][0]:every[1][0]].tolist() == naive_ref.rays_near(
        real[:1], origin, direction, [0], [300], np.arange(300), margin, parallel)[0]
    for threads in (True, False):
        with one_thread(not threads):
            lists = reach.Reach(origin, direction)
            lists.lists.append(ray)  # lists after the first (every ray) are tested in turn
            lists.size += len(ray)
            start, end = lists.test(real, first + 300, last + 300)
        assert [lists.ray()[a:b].tolist() for a, b in zip(start, end)] == want


@pytest.mark.parametrize("max_level", [0, 1, 3])
def test_pruned_candidates_draw_the_same_bits(drawn, max_level):
    """Candidates given the reflected rays leave out those no ray comes near (and their parts,
    whose midpoints' images are then not found): what is left is a subsequence of the full
    candidates, and the drawing is the same bits."""
    scene, frame, view, k, stencil, out, truth = drawn
    gb, eye, images, find = several.image_source(scene, view, k, out.state, RenderOptions(images="all"))
    comb = reflected_mesh(scene, view.meshes)[1]
    args = (gb, eye, view.vertices, comb.normals, comb.faces, comb.face_object, images, find)
    box = (0, H, 0, W)
    rays = acceptance.pixel_rays(view.camera, view.meshes[k - 1], view.view.triangle, stencil, box)
    valid, origin, direction = rays
    points = []

    def counted(p):
        points.append(len(p))
        return find(p)

    full, _ = several.candidates(*args[:-1], counted, max_level=max_level)
    n_full, points[:] = sum(points), []
    pruned, _ = several.candidates(*args[:-1], counted, max_level=max_level, rays=(origin[valid], direction[valid]))
    assert 0 < len(pruned.triangle) < len(full.triangle)
    assert max_level == 0 or 0 < sum(points) < n_full
    # a subsequence: every pruned candidate is the next equal full one
    rows = np.concatenate([full.virtual.reshape(len(full.triangle), -1), full.real.reshape(len(full.triangle), -1)], 1)
    want = np.concatenate([pruned.virtual.reshape(len(pruned.triangle), -1),
                           pruned.real.reshape(len(pruned.triangle), -1)], 1)
    at = 0
    for row in want:
        while at < len(rows) and not np.array_equal(rows[at], row):
            at += 1
        assert at < len(rows)
        at += 1
    colors = np.vstack([np.zeros(3), [o.color for o in scene.objects]]).astype(np.float32)
    a = acceptance.draw(full, view.camera, view.meshes[k - 1], view.view.triangle, stencil, box, colors)
    b = acceptance.draw(pruned, view.camera, view.meshes[k - 1], view.view.triangle, stencil, box, colors, rays)
    for x, y in zip(a[:3], b[:3]):
        assert np.array_equal(x, y)
    assert a[3]["pixels_accepted"] == b[3]["pixels_accepted"] > 0


def test_acceptance_over_ray_lists_matches_the_plain_loop():
    """The acceptance over each candidate's rays (accept_near) gives the plain pixel-by-candidate
    loop's nearest hits bit for bit, on one thread and on several: with every ray in every list
    (and then its covered pixels too), with the lists of the rays that may hit each real
    triangle (rays_near), which leave out rays and pixels that cannot change the result, and with
    every third candidate without a list (tested at every pixel it covers)."""
    import naive_several_pool

    from refsoft._parallel import parallel_range
    from refsoft.search._several import accept_near

    rng = np.random.default_rng(5)
    h, w, r0, c0 = 14, 18, 5, 7
    valid = rng.random((h, w)) < 0.8
    valid[3] = False
    origin = np.concatenate([rng.uniform(-1, 1, (h, w, 2)), np.full((h, w, 1), 2.0)], axis=2)
    direction = np.concatenate([rng.normal(0, 0.2, (h, w, 2)), np.full((h, w, 1), -1.0)], axis=2)
    real = np.concatenate([rng.uniform(-1.5, 1.5, (30, 3, 2)), rng.uniform(-0.5, 0.5, (30, 1, 1)).repeat(3, 1)],
                          axis=2)
    real = np.repeat(real, rng.integers(1, 4, 30), axis=0)
    n = len(real)
    screen = rng.uniform([c0 - 3, r0 - 3], [c0 + w + 3, r0 + h + 3], (n, 3, 2))
    screen[::7, 2] = screen[::7, 0]
    dilate = rng.uniform(0.5, 3.0, n)
    dilate[::5] = -1.0
    lo, hi = np.floor(screen.min(axis=1) - dilate[:, None]), np.ceil(screen.max(axis=1) + dilate[:, None])
    bbox = np.stack([lo[:, 1] - r0, hi[:, 1] - r0, lo[:, 0], hi[:, 0]], axis=1).astype(np.int64)
    want = naive_several_pool.accept(r0, c0, valid, origin, direction, screen, bbox, dilate, real)
    assert (want[1] >= 0).sum() > 20
    rows, cols = np.nonzero(valid)
    o, d = np.ascontiguousarray(origin[valid]), np.ascontiguousarray(direction[valid])
    pruned = reach.Reach(o, d)
    near = pruned.test(real, *pruned.every(n))
    every = pruned.every(n)
    assert np.sum(near[1] - near[0]) < np.sum(every[1] - every[0]) / 5  # the lists are short
    mixed = (np.where(np.arange(n) % 3 == 0, -1, near[0]), np.where(np.arange(n) % 3 == 0, -1, near[1]))
    for lists, same_tested in ((every, True), (near, False), (mixed, False)):
        for threads in (True, False):
            got = (np.full((h, w), np.inf), np.full((h, w), -1, np.int64), np.zeros((h, w, 2)),
                   np.zeros((h, w), bool))
            args = (accept_near, h, r0, c0, valid, acceptance._spans(valid), origin, direction, rows, cols, o, d,
                    screen, bbox, dilate, real, acceptance._runs(real), *lists, pruned.ray(), *got,
                    np.full((h, w), -1, np.int64))
            with one_thread(not threads):
                parallel_range(*args)
            for a, b in zip(got[:3], want[:3]):
                assert np.array_equal(a, b)
            assert np.array_equal(got[3], want[3]) if same_tested else not np.any(got[3] & ~want[3])


def test_screen_bounds_match_the_numpy_version(drawn):
    """The candidates' screen positions, dilated bounds and dilations (kernel, on one thread and
    several) are the NumPy version's bit for bit: triangles in view, partly off screen, with a
    vertex behind the eye, and far aside (positions or edges too large to be finite: NumPy's own
    rows)."""
    scene, frame, view, k, stencil, out, truth = drawn
    rng = np.random.default_rng(2)
    cam = view.camera
    eye, target = np.asarray(cam.eye, float), np.asarray(cam.target, float)
    ahead = (target - eye) / np.linalg.norm(target - eye)
    virtual = target + rng.normal(0, 2.0, (400, 3, 3))
    virtual[::9, 1] = eye - ahead  # behind the eye
    side = np.cross(ahead, [0.0, 1.0, 0.0])
    side /= np.linalg.norm(side)
    far = eye + 2.0 * ahead + np.array([1e150, 1e306, 1e307, 1e308])[:, None] * side
    virtual[::13, 2] = far[np.arange(len(virtual[::13])) % 4]  # too far aside: overflows
    box = (3, H - 2, 5, W - 1)
    want = naive.screen(virtual, cam, box)
    assert 0 < want[3].sum() < len(virtual) and np.sum(want[2] < 0) > 40
    fine = want[3]  # (a bound cast from a value that is not finite is NumPy's own)
    for threads in (True, False):
        with one_thread(not threads):
            got = acceptance._screen(virtual, cam, box)
        for a, b in zip(got, want[:3]):
            assert a.dtype == b.dtype and np.array_equal(a[fine], b[fine])
        assert np.array_equal(got[0], want[0], equal_nan=True) and np.array_equal(got[2], want[2])


def test_rays_near_every_gives_the_lists_of_every_ray():
    """The test of every ray a block at a time (rays_near_every, on one thread and several) keeps
    each triangle the rays that rays_near keeps of every ray, in order, over several blocks."""
    from refsoft.search._several import RAY_BLOCK

    rng = np.random.default_rng(17)
    real = rng.uniform(-1.0, 1.0, (30, 3, 3))
    real[:, :, 2] = rng.uniform(-0.3, 0.3, (30, 1))
    real[3] = [[0, 0, 0], [1, 0, 0], [2, 0, 0]]
    n = 2 * RAY_BLOCK + 77
    o = np.concatenate([rng.uniform(-1.2, 1.2, (n, 2)), np.full((n, 1), 2.0)], axis=1)
    d = np.concatenate([rng.normal(0, 0.1, (n, 2)), np.full((n, 1), -1.0)], axis=1)
    want = reach.Reach(o, d)
    span = want.test(real, *want.every(len(real)))
    lists = [want.ray()[a:b].tolist() for a, b in zip(*span)]
    assert 0 < sum(map(len, lists)) < n * len(real) / 4 and any(x and x[-1] >= 2 * RAY_BLOCK for x in lists)
    for threads in (True, False):
        with one_thread(not threads):
            got = reach.Reach(o, d)
            span = got.test_every(real)
        assert [got.ray()[a:b].tolist() for a, b in zip(*span)] == lists
