"""The exact drawing's second candidates (refsoft/search/virtual.py ``mirror_images`` and
``with_mirror_copies``): the faces they add against a loop, on a plane mirror's border the holes
they fill (pixels that saw nothing although their reflected ray meets a triangle), by mirror
balls' silhouettes the pixels they change (all to the truth's object), and their bits across
thread counts."""

import numpy as np
import pytest

import refsoft
from refsoft import constants
from refsoft.frame import FrameDriver, RenderOptions
from refsoft.raster import _setup
from refsoft.search import BORDER, CULLED, HIDDEN, exact
from refsoft.search.method import VertexSearch
from refsoft.search.virtual import with_mirror_copies
from refsoft.truth import TruthRenderer, metrics


class _Camera:
    width, height = 64, 48
    eye = np.zeros(3)

    @staticmethod
    def view_proj():
        return np.eye(4)


def _copies_numpy(part, real, mirror, camera):
    """The rule written as loops. A visible vertex of ``rows`` whose image lies more than the
    threshold from its own in screen pixels (both in front of the eye) gets a twin (its image);
    a HIDDEN vertex (not CULLED) of a face with an ``edge`` corner, or of a face the cut
    replaced, gets one too (``at_texel``). Every face with a twin corner is followed by its copy
    with the twins; the replaced faces follow, with the twins; twins are flagged as their
    vertex, HIDDEN cleared."""
    rows, images, edge, at_texel, (uncut, uncut_obj) = mirror
    virtual, normals, faces, face_obj, flags = part
    n = len(virtual)
    vp = camera.view_proj()
    twin, new_rows, new_images = {}, [], []
    for i, b in zip(rows, images):
        a = _setup.transform_points(virtual[i][None], vp)[0]
        c = _setup.transform_points(b[None], vp)[0]
        if a[3] <= 0 or c[3] <= 0:
            continue
        gap = np.abs(a[:2] / a[3] - c[:2] / c[3]) * 0.5 * np.array([camera.width, camera.height])
        if gap.max() > constants.EXACT_TWIN_PIXELS:
            twin[int(i)] = n + len(new_rows)
            new_rows.append(int(i))
            new_images.append(b)
    near = [any(edge[v] for v in f) for f in faces]
    whole = [True] * len(uncut)
    hidden = sorted({int(v) for f, k in zip(list(faces) + list(uncut), near + whole) if k for v in f
                     if flags[v] & (HIDDEN | CULLED) == HIDDEN})
    for v in hidden:
        twin[v] = n + len(new_rows)
        new_rows.append(v)
    if hidden:
        new_images += list(at_texel(np.array(hidden, np.int64)))
    out, obj = [], []
    for f, o, k in zip(faces, face_obj, near):
        out.append([int(v) for v in f])
        obj.append(o)
        if k or any(int(v) in twin and int(v) not in hidden for v in f):
            out.append([twin.get(int(v), int(v)) for v in f])
            obj.append(o)
    if hidden:
        for f, o, k in zip(uncut, uncut_obj, whole):
            if k:
                out.append([twin.get(int(v), int(v)) for v in f])
                obj.append(o)
    idx = np.array(new_rows, np.int64)
    return (np.array(out, np.int64), np.array(obj, np.int32),
            np.concatenate([virtual, np.array(new_images).reshape(-1, 3)]), np.concatenate([real, real[idx]]),
            np.concatenate([flags, flags[idx] & ~np.uint8(HIDDEN)]))


def _mirror(rng, n, m, flags):
    rows = np.sort(rng.choice(np.flatnonzero(flags & HIDDEN == 0), 20, replace=False)).astype(np.int64)
    edge = (flags & HIDDEN != 0) & (rng.random(n) < 0.1)
    uncut = rng.integers(0, n, (15, 3)).astype(np.int64)

    def at_texel(r):
        return np.asarray(r, np.float64)[:, None] * np.array([1.0, -1.0, 0.5])

    return rows, edge, at_texel, (uncut, rng.integers(1, 5, 15).astype(np.int32))


def test_copies_follow_their_triangle_with_the_twin_corners(rng):
    n, m = 60, 150
    virtual = rng.normal(size=(n, 3))
    virtual[:, 2] = rng.uniform(-0.5, 2.0, n)  # w = z with the identity: some at or behind the eye
    normals = rng.normal(size=(n, 3))
    real = rng.normal(size=(n, 3))
    faces = rng.integers(0, n, (m, 3)).astype(np.int64)
    face_obj = rng.integers(1, 5, m).astype(np.int32)
    flags = rng.choice(np.array([0, BORDER, HIDDEN | BORDER, HIDDEN, CULLED | HIDDEN], np.uint8), n)
    rows, edge, at_texel, uncut = _mirror(rng, n, m, flags)
    images = virtual[rows] + rng.normal(size=(len(rows), 3)) * np.where(rng.random(len(rows)) < 0.5, 1e-4,
                                                                          0.5)[:, None]
    mirror = (rows, images, edge, at_texel, uncut)
    part = (virtual, normals, faces, face_obj, flags)
    (v2, n2, f2, o2, fl2), r2 = with_mirror_copies(part, real, mirror, _Camera)
    want_f, want_o, want_v, want_r, want_fl = _copies_numpy(part, real, mirror, _Camera)
    np.testing.assert_array_equal(f2, want_f)
    np.testing.assert_array_equal(o2, want_o)
    np.testing.assert_array_equal(v2, want_v)
    np.testing.assert_array_equal(r2, want_r)
    np.testing.assert_array_equal(fl2, want_fl)
    assert len(n2) == len(v2)
    assert m < len(f2) < 2 * m + 15  # some copied, not all
    assert np.any(edge) and np.any(fl2[n:] & BORDER)  # both kinds of twin were exercised


def test_no_rows_no_copies(rng):
    part = (rng.normal(size=(5, 3)), rng.normal(size=(5, 3)), np.array([[0, 1, 2]], np.int64),
            np.array([1], np.int32), np.zeros(5, np.uint8))
    mirror = (np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros(5, bool), None,
              (np.zeros((0, 3), np.int64), np.zeros(0, np.int32)))
    got, real = with_mirror_copies(part, np.zeros((5, 3)), mirror, _Camera)
    assert got is part


class _Spy(VertexSearch):
    """The vertex search, keeping its exact drawing's arguments and the part before the copies."""

    def reflect(self, view, k, stencil):
        import refsoft.search.method as method

        real_pass, real_copies = exact.exact_pass, method.with_mirror_copies

        def spy(*args):
            self.args = args
            return real_pass(*args)

        def copies(part, real, mirror, camera):
            self.plain = (part, real)
            return real_copies(part, real, mirror, camera)

        method.exact_pass, method.with_mirror_copies = spy, copies
        try:
            return super().reflect(view, k, stencil)
        finally:
            method.exact_pass, method.with_mirror_copies = real_pass, real_copies


def test_copies_fill_the_plane_mirrors_border_holes_and_change_nothing_else():
    """planar at 1024x768, frame 29: a floor triangle by the mirror's foot whose vertex lies
    1e-4 from the mirror (its walk stops 0.07 away: the score hardly changes along the mirror)
    left one pixel empty where the truth sees the floor. With the copies every pixel the drawing
    without them accepted is the same bits, and the ones they add are the truth's object."""
    scene = refsoft.load_scene("planar", width=1024, height=768)
    spy = _Spy(scene, RenderOptions())
    frame = FrameDriver(scene, RenderOptions(), method=spy).render_frame(29).arrays
    truth = TruthRenderer(scene, exact=True).render_frame(29).arrays
    sc, part, real, camera, mesh, triangle, stencil, box, inverse = spy.args
    got = exact.exact_pass(*spy.args)
    was = exact.exact_pass(sc, *spy.plain, camera, mesh, triangle, stencil, box, inverse)
    assert got[3]["candidates"] > was[3]["candidates"]
    before, after = was[2], got[2]
    assert np.all(after[before])  # nothing accepted is lost
    for a, b in zip(got[:2], was[:2]):
        assert a[before].tobytes() == b[before].tobytes()
    r0, r1, c0, c1 = box
    new = after & ~before
    assert new.sum() >= 1
    np.testing.assert_array_equal(got[1][new], truth["reflected_id"][r0:r1, c0:c1][new])
    # the hole of the drawing without the copies is gone
    assert int(metrics.holes(frame["reflected_id"], truth["reflected_id"]).sum()) == 0


@pytest.mark.parametrize("name, frame", [("planar", 29), ("mirrors", 23)])
def test_copies_draw_the_same_on_one_thread_and_on_several(name, frame):
    import numba

    scene = refsoft.load_scene(name, width=256, height=192)
    got = []
    for threads in (1, numba.config.NUMBA_NUM_THREADS):
        numba.set_num_threads(threads)
        try:
            spy = _Spy(scene, RenderOptions())
            got.append(FrameDriver(scene, RenderOptions(), method=spy).render_frame(frame).arrays)
            assert len(spy.args[1][2]) > len(spy.plain[0][2])  # copies were drawn
        finally:
            numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    for key in ("image", "reflected_id"):
        assert got[0][key].tobytes() == got[1][key].tobytes(), key


def test_hidden_copies_fill_the_silhouettes_of_mirror_balls():
    """mirrors at 320x240, frame 23: next to a ball's silhouette the walks of vertices seen at a
    grazing angle stop on the outline with the texel's normal a little behind them (HIDDEN),
    so their triangles were no candidates and the cut ended their neighbours' short: pixels
    there showed another object or none where the truth sees one. Drawn a second time with the
    hidden vertices at their last texels, every pixel whose object changes gets the truth's."""
    scene = refsoft.load_scene("mirrors", width=320, height=240)
    spies = []

    class _All(_Spy):
        def reflect(self, view, k, stencil):
            out = super().reflect(view, k, stencil)
            spies.append((self.args, self.plain))
            return out

    FrameDriver(scene, RenderOptions(), method=_All(scene, RenderOptions())).render_frame(23)
    truth = TruthRenderer(scene, exact=True).render_frame(23).arrays["reflected_id"]
    changed = right_before = right_after = 0
    for args, plain in spies:
        sc, part, real, camera, mesh, triangle, stencil, box, inverse = args
        if len(part[2]) == len(plain[0][2]):
            continue
        got = exact.exact_pass(*args)[1]
        was = exact.exact_pass(sc, *plain, camera, mesh, triangle, stencil, box, inverse)[1]
        r0, r1, c0, c1 = box
        t = truth[r0:r1, c0:c1]
        diff = (got != was) & stencil[r0:r1, c0:c1]
        changed += int(diff.sum())
        right_before += int(np.sum(was[diff] == t[diff]))
        right_after += int(np.sum(got[diff] == t[diff]))
    assert changed >= 20
    assert right_before == 0 and right_after == changed
