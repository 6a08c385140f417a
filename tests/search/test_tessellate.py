"""Adaptive tessellation (refsoft.search.tessellate): conforming splits keep closed surfaces closed,
the threshold and the level limit stop it, it leaves no crack where the thesis's rule does."""

import numpy as np
import pytest

import refsoft
from refsoft import primitives
from refsoft.frame import FrameDriver, RenderOptions
from refsoft.search.tessellate import KEY_BASE, _edge_keys, _split


def _edge_uses(faces):
    e = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    _, counts = np.unique(e, axis=0, return_counts=True)
    return counts


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_conforming_split_keeps_a_closed_mesh_closed(seed):
    ball = primitives.icosphere(2, 1.0)
    faces = ball.faces.astype(np.int64)
    rng = np.random.default_rng(seed)
    chosen = rng.choice(len(faces), 30, replace=False)
    ends = faces[chosen]
    keys = np.unique(np.concatenate([_edge_keys(ends[:, i], ends[:, (i + 1) % 3], KEY_BASE) for i in range(3)]))
    mids = ball.n_vertices + np.arange(len(keys))
    new, parent = _split(faces, keys, mids, KEY_BASE)
    assert np.all(_edge_uses(new) == 2)  # every edge shared by exactly two triangles: no T-junction
    assert len(new) > len(faces) + 3 * 30 and np.all(np.bincount(parent)[chosen] == 4)
    # the same as a plain loop over the triangles (the red-green rule written out)
    split = {(int(k // KEY_BASE), int(k % KEY_BASE)): int(m) for k, m in zip(keys, mids)}
    expect = []
    for a, b, c in faces:
        e = [(a, b), (b, c), (c, a)]
        m = [split.get((min(x), max(x)), -1) for x in e]
        n = sum(x >= 0 for x in m)
        if n == 0:
            expect.append((a, b, c))
        elif n == 3:
            expect += [(a, m[0], m[2]), (m[0], b, m[1]), (m[2], m[1], c), (m[0], m[1], m[2])]
        elif n == 1:
            k = [x >= 0 for x in m].index(True)
            expect += [(e[k][0], m[k], e[(k + 1) % 3][1]), (m[k], e[k][1], e[(k + 1) % 3][1])]
        else:
            k = [x >= 0 for x in m].index(False)
            v0, v1, opp = e[k][0], e[k][1], e[(k + 1) % 3][1]
            expect += [(v0, v1, m[(k + 1) % 3]), (v0, m[(k + 1) % 3], m[(k + 2) % 3]),
                       (m[(k + 2) % 3], m[(k + 1) % 3], opp)]
    np.testing.assert_array_equal(new, np.array(expect))
    only = np.zeros(len(faces), dtype=bool)
    only[chosen] = True
    thesis, _ = _split(faces, keys, mids, KEY_BASE, only)
    assert np.any(_edge_uses(thesis) == 1)  # the thesis's rule leaves edges used once: cracks


def test_a_high_threshold_changes_nothing_and_levels_are_bounded():
    scene = refsoft.load_scene("quad", width=96, height=72)
    plain = FrameDriver(scene, RenderOptions(preset="paper", inverse="search")).render_frame(0)
    same = FrameDriver(scene, RenderOptions(preset="paper", inverse="search", tessellate=1.0)).render_frame(0)
    np.testing.assert_array_equal(plain.image, same.image)
    assert same.skipped["tessellation"]["1"]["vertices_searched"] == 0
    for level in (1, 2):
        fr = FrameDriver(scene, RenderOptions(preset="paper", inverse="search", tessellate=0.0, max_level=level)).render_frame(0)
        assert fr.skipped["tessellation"]["1"]["levels"] == level
    with pytest.raises(refsoft.RefsoftError, match="tessellate"):
        RenderOptions(tessellate=-1.0)


def test_no_crack_where_the_thesis_rule_leaves_some(monkeypatch):
    """The sphere scene's floor reflected in the ball: pixels whose 3x3 neighbourhood the
    untessellated reflection of the floor covers are never left empty by the crack-free rule;
    the thesis's rule (split triangles only, T-junctions left) empties some (measured: 66). The
    virtual triangles are rasterized (drawn exactly, a T-junction leaves no pixel empty)."""
    import importlib

    tess = importlib.import_module("refsoft.search.virtual")
    scene = refsoft.load_scene("sphere", width=320, height=240)
    floor = [i + 1 for i, o in enumerate(scene.objects) if o.name == "floor"][0]
    opts = dict(inverse="discard", tessellate=1e-3, max_level=3, draw="raster")
    plain = FrameDriver(scene, RenderOptions(inverse="discard", draw="raster")).render_frame(0).arrays["reflected_id"]
    inner = plain == floor
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            inner &= np.roll(np.roll(plain == floor, dr, 0), dc, 1)
    assert inner.sum() > 1000
    fr = FrameDriver(scene, RenderOptions(**opts)).render_frame(0)
    assert fr.skipped["tessellation"]["1"]["vertices_searched"] > 0
    assert np.sum(fr.arrays["reflected_id"][inner] == 0) == 0
    original = tess.tessellate
    monkeypatch.setattr(tess, "tessellate", lambda *a, **k: original(*a, **dict(k, crack_free=False)))
    thesis = FrameDriver(scene, RenderOptions(**opts)).render_frame(0).arrays["reflected_id"]
    assert np.sum(thesis[inner] == 0) > 10


def test_splitting_only_the_touched_faces_gives_the_full_split(rng):
    """``_split_some`` runs the red-green split on the faces two of whose corners end split
    edges and keeps the others: the same faces and parents as splitting them all."""
    from refsoft.search.tessellate import KEY_BASE, _edge_keys, _split, _split_some

    mesh = primitives.icosphere(3)
    faces = mesh.faces.astype(np.int64)
    n = mesh.n_vertices
    for share in (0.01, 0.2, 1.0):
        pick = faces[rng.random(len(faces)) < share]
        keys = np.unique(np.concatenate([_edge_keys(pick[:, i], pick[:, (i + 1) % 3], KEY_BASE) for i in range(3)]))
        mids = n + np.arange(len(keys), dtype=np.int64)
        ea, eb = keys // KEY_BASE, keys % KEY_BASE
        want = _split(faces, keys, mids, KEY_BASE)
        got = _split_some(faces, keys, mids, ea, eb, n + len(keys))
        np.testing.assert_array_equal(got[0], want[0])
        np.testing.assert_array_equal(got[1], want[1])


def test_split_edges_and_distinct_equal_np_unique(rng):
    """The sorted distinct edge keys of split triangles (a sort and a comparison of neighbours)
    are ``np.unique``'s, empty input included."""
    from refsoft.search.tessellate import _distinct, _split_edges

    for t in (0, 1, 50, 3000):
        tris = rng.integers(0, max(t // 2, 3), size=(t, 3)).astype(np.int64)
        want = np.unique(np.concatenate([_edge_keys(tris[:, i], tris[:, (i + 1) % 3], KEY_BASE) for i in range(3)]))
        got = _split_edges(tris)
        assert got.dtype == want.dtype
        np.testing.assert_array_equal(got, want)
        keys = np.sort(rng.integers(-5, 5 + t, size=t))
        np.testing.assert_array_equal(_distinct(keys), np.unique(keys))


def test_apply_split_marks_the_faces_split_into_several(rng):
    """``_apply_split``'s next candidates are the children of the faces that were split, its
    object ids the parents' (against ``_split`` and a plain count of children per parent)."""
    from refsoft.search.tessellate import _apply_split, _split_edges

    mesh = primitives.icosphere(3)
    faces = mesh.faces.astype(np.int64)
    face_obj = rng.integers(1, 9, size=len(faces)).astype(np.int32)
    n = mesh.n_vertices
    for share in (0.02, 0.3):
        chosen = np.flatnonzero(rng.random(len(faces)) < share)
        keys = _split_edges(faces[chosen])
        mids = n + np.arange(len(keys), dtype=np.int64)
        ea, eb = keys // KEY_BASE, keys % KEY_BASE
        want, parent = _split(faces, keys, mids, KEY_BASE)
        kids = {}
        for p in parent.tolist():
            kids[p] = kids.get(p, 0) + 1
        got, obj, active = _apply_split(faces, face_obj, keys, mids, ea, eb, n + len(keys))
        np.testing.assert_array_equal(got, want)
        np.testing.assert_array_equal(obj, face_obj[parent])
        np.testing.assert_array_equal(active, np.array([kids[p] > 1 for p in parent.tolist()]))
        assert 0 < active.sum() < len(active)


@pytest.mark.parametrize("min_span", [0, 1])
def test_triangle_errors_equal_the_plain_reduction(min_span):
    """Each triangle's largest edge error, -inf for a CULLED corner (and, when adaptive, all
    corners hidden), against per-edge :func:`edge_errors` reduced row by row."""
    from scene_data import sphere_searched

    from refsoft import search
    from refsoft.search.tessellate import _triangle_errors, edge_errors

    scene, gb, verts, _, comb, res = sphere_searched("plane")
    cam = scene.camera
    f = comb.faces
    ends = [(f[:, i], f[:, (i + 1) % 3]) for i in range(3)]
    per_edge = np.stack([edge_errors(gb, cam.eye, verts[a], verts[b], res.pixel[a], res.pixel[b]) for a, b in ends],
                        axis=1)
    if min_span:
        for i, (a, b) in enumerate(ends):
            near = np.all(np.abs(res.pixel[a] - res.pixel[b]) <= min_span, axis=1)
            per_edge[near, i] = 0.0
    # flags with CULLED and HIDDEN corners to leave out (the errors do not read them)
    flags = res.flags.copy()
    flags[::11] |= search.CULLED
    flags[:len(flags) // 3] |= search.HIDDEN
    fl = flags[f]
    for threshold in (0.0, 1e-4):
        bad = np.any(fl & search.CULLED, axis=1)
        if threshold > 0:
            bad |= np.all(fl & search.HIDDEN, axis=1)
        want = np.where(bad, -np.inf, per_edge.max(axis=1))
        got = _triangle_errors(gb, cam.eye, verts, res.pixel, flags, None, f, threshold, min_span)
        np.testing.assert_array_equal(got, want)
        assert np.isinf(want).any() and (want > 0).any()
    assert np.all(fl & search.HIDDEN, axis=1).any()


def test_reflected_mesh_is_reused_for_the_same_mesh_objects_only():
    """The concatenated non-reflector meshes are made again unless every mesh is the very
    object they were made from; either way they equal ``concatenate`` of the meshes."""
    from refsoft.scene.mesh import concatenate
    from refsoft.search.virtual import reflected_mesh

    scene = refsoft.load_scene("sphere", width=64, height=48)
    meshes = [scene.world_mesh(k) for k in range(1, len(scene.objects) + 1)]
    ids = [k for k, o in enumerate(scene.objects, start=1) if not o.reflector]
    want = concatenate([meshes[k - 1] for k in ids], ids)
    first = reflected_mesh(scene, meshes)
    assert reflected_mesh(scene, list(meshes), first) is first
    other = list(meshes)
    other[ids[0] - 1] = scene.world_mesh(ids[0])  # equal values, another object
    again = reflected_mesh(scene, other, first)
    assert again is not first and again[0][0] is other[ids[0] - 1]
    for got in (first[1], again[1]):
        for name in ("vertices", "normals", "faces", "face_object", "vertex_offsets", "face_offsets"):
            np.testing.assert_array_equal(getattr(got, name), getattr(want, name))


def test_edge_pixel_errors_equal_one_plain_gauss_newton_step():
    """The pixel metric against tests/naive.py's refinement run on each edge's midpoint from the
    texel nearest to the midpoint of its ends' refined points: the distance from that midpoint to
    the refined point, 2 where an end has no pixel or that texel is uncovered."""
    from naive import naive_refine
    from scene_data import sphere_searched

    from refsoft import search
    from refsoft.search.refine import refine
    from refsoft.search.tessellate import edge_pixel_errors

    scene, gb, verts, _, comb, res = sphere_searched("plane")
    eye = scene.camera.eye
    _, _, off = refine(gb, eye, verts, res)
    f = comb.faces
    a, b = f[:, 0], f[:, 1]
    pa, pb = res.pixel[a].copy(), res.pixel[b].copy()
    pa[::7] = -1  # ends without a pixel
    got = edge_pixel_errors(gb, eye, verts[a], verts[b], pa, pb, off[a], off[b])
    mid = 0.5 * ((pa + off[a].astype(np.float64)) + (pb + off[b].astype(np.float64)))
    base = np.floor(mid + 0.5).astype(np.int64)
    h, w = gb.mask.shape
    ok = np.all(pa >= 0, axis=1) & np.all(pb >= 0, axis=1) & np.all(base >= 0, axis=1)
    ok &= (base[:, 0] < h) & (base[:, 1] < w)
    ok[ok] &= gb.mask[base[ok, 0], base[ok, 1]]
    m = 0.5 * (verts[a] + verts[b])
    zero = np.zeros(len(m), np.uint8)
    _, _, step = naive_refine(gb.position, gb.normal, gb.mask, m[ok] - gb.origin, eye - gb.origin, base[ok], zero[ok],
                              search.HIDDEN, search.CULLED)
    want = np.full(len(m), 2.0)
    want[ok] = np.hypot(base[ok, 0] + step[:, 0] - mid[ok, 0], base[ok, 1] + step[:, 1] - mid[ok, 1])
    assert ok.sum() > 100 and (~ok).sum() > 10
    np.testing.assert_array_equal(got[~ok], 2.0)
    # the kernel's arithmetic is the G-buffer's float32, the reference's float64
    np.testing.assert_allclose(got[ok], want[ok], rtol=0, atol=2e-3)
    assert (want[ok] > 0.05).any()  # some edges bend by more than a twentieth of a pixel


def test_the_pixel_metric_splits_some_edges_and_needs_the_subtexel_points():
    """By the pixel metric, a threshold of a third of a pixel splits more than nothing and less
    than everything; the metric refuses to run without the sub-texel points."""
    from scene_data import sphere_searched

    from refsoft.errors import RefsoftError
    from refsoft.search.refine import refine
    from refsoft.search.tessellate import tessellate

    scene, gb, verts, _, comb, res = sphere_searched("plane")
    eye = scene.camera.eye
    surface = refine(gb, eye, verts, res)
    args = (gb, eye, verts, comb.normals, comb.faces, comb.face_object, res.pixel, res.flags)
    with pytest.raises(RefsoftError, match="sub-texel"):
        tessellate(*args, 0.3, 2, metric="pixels")
    some = tessellate(*args, 0.3, 2, surface=surface, metric="pixels")
    every = tessellate(*args, 0.0, 2, surface=surface, metric="pixels")
    assert len(comb.faces) < len(some.faces) < len(every.faces)
    again = tessellate(*args, 0.3, 2, surface=surface, metric="pixels")
    assert np.array_equal(again.faces, some.faces) and np.array_equal(again.surface[2], some.surface[2])
    # the outline edges measured alone (a threshold the thesis's error never exceeds): a subset
    # of the edges, so no more splits (here, fewer); with today's rule, more than today's
    outline = tessellate(*args, 2.0, 2, surface=surface, outline=0.3)
    assert len(comb.faces) < len(outline.faces) < len(some.faces)
    today = tessellate(*args, 1e-4, 2, surface=surface)
    both = tessellate(*args, 1e-4, 2, surface=surface, outline=0.3)
    assert len(today.faces) < len(both.faces)


def test_outline_edges_equal_a_plain_count_of_faces_and_windings(rng):
    """outline_edges against a loop over the edges: used once or thrice, or by two faces whose
    reflected corners wind in opposite senses (or one degenerate)."""
    from collections import defaultdict

    from refsoft.search.tessellate import outline_edges

    n = 40
    faces = np.array([rng.choice(n, 3, replace=False) for _ in range(120)])
    faces = np.concatenate([faces, faces[:10][:, [0, 2, 1]], faces[10:15]])  # flipped twins, a third use
    pixel = rng.integers(0, 30, (n, 2)).astype(np.int32)
    offset = rng.uniform(-0.5, 0.5, (n, 2)).astype(np.float32)
    pixel[3] = pixel[4]  # a degenerate face somewhere, maybe
    q = pixel.astype(np.float64) + offset.astype(np.float64)

    def wind(face):
        a, b, c = q[face]
        return np.sign((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))

    users = defaultdict(list)
    for i, f in enumerate(faces):
        for k in range(3):
            users[frozenset((int(f[k]), int(f[(k + 1) % 3])))].append(i)
    want = np.zeros((len(faces), 3), dtype=bool)
    for i, f in enumerate(faces):
        for k in range(3):
            u = users[frozenset((int(f[k]), int(f[(k + 1) % 3])))]
            w = [wind(faces[j]) for j in u]
            want[i, k] = len(u) != 2 or w[0] != w[1] or 0 in w
    got = outline_edges(faces, pixel, offset)
    np.testing.assert_array_equal(got, want)
    assert want.any() and (~want).any()
    rows = np.array([5, 0, 130, 7, 7])
    np.testing.assert_array_equal(outline_edges(faces, pixel, offset, rows), want[rows])


def _naive_working(faces, pixel, min_span, rings):
    """Faces with an edge spanning more than ``min_span`` pixels along an axis, grown ``rings``
    times by every face sharing a vertex with one kept: plain NumPy."""
    span = np.zeros(len(faces), dtype=bool)
    for k in range(3):
        d = np.abs(pixel[faces[:, k]].astype(np.int64) - pixel[faces[:, (k + 1) % 3]])
        span |= (d > min_span).any(axis=1)
    keep = span
    for _ in range(rings):
        touched = np.isin(faces, np.unique(faces[keep])).any(axis=1)
        keep = keep | touched
    return keep


def test_working_faces_equal_a_plain_ring_growth():
    from scene_data import sphere_searched

    from refsoft.search.tessellate import _working

    _, _, _, _, comb, res = sphere_searched("discard")
    f = comb.faces.astype(np.int64)
    for rings in (1, 3):
        want = _naive_working(f, res.pixel, 1, rings)
        got = _working(f, res.pixel, 1, rings)
        assert 0 < want.sum() < len(f)
        np.testing.assert_array_equal(got, want)
    assert _working(f, res.pixel, 0, 3) is None and _working(f, res.pixel, 1, 0) is None


def test_tessellating_the_working_faces_alone_gives_every_face_s_result(monkeypatch):
    """The faces outside the working set are copied, the others tessellated: the same vertices,
    faces (in order) and object ids as when every face takes part."""
    from scene_data import sphere_searched

    from refsoft.search import tessellate as T
    from refsoft.search.refine import refine

    scene, gb, verts, _, comb, res = sphere_searched("discard", 320, 240)
    eye = scene.camera.eye
    args = (gb, eye, verts, comb.normals, comb.faces, comb.face_object, res.pixel, res.flags, 1e-4, 3, "cross",
            "discard")
    kw = dict(surface=refine(gb, eye, verts, res), min_span=1)
    got = T.tessellate(*args, **kw)
    work = T._working(comb.faces.astype(np.int64), res.pixel, 1, 3)
    assert work is not None and work.sum() < len(comb.faces)
    monkeypatch.setattr(T, "_working", lambda *a: None)
    want = T.tessellate(*args, **kw)
    assert got.searched == want.searched > 0 and got.levels == want.levels
    for name in ("vertices", "normals", "pixel", "flags", "faces", "face_obj"):
        np.testing.assert_array_equal(getattr(got, name), getattr(want, name))
    for a, b in zip(got.surface, want.surface):
        np.testing.assert_array_equal(a, b)


def test_rows_grow_and_keep_their_rows():
    from refsoft.search.tessellate import _Rows

    a, b = np.arange(6.0).reshape(3, 2), np.arange(3, dtype=np.int32)
    rows = _Rows([a, b])
    for m in (5, 40, 1):
        rows.append([np.full((m, 2), float(m)), np.full(m, m, dtype=np.int32)])
    va, vb = rows.view()
    np.testing.assert_array_equal(va, np.concatenate([a] + [np.full((m, 2), float(m)) for m in (5, 40, 1)]))
    np.testing.assert_array_equal(vb, np.concatenate([b] + [np.full(m, m, dtype=np.int32) for m in (5, 40, 1)]))
    assert vb.dtype == np.int32 and rows.n == 49
