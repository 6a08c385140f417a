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
    the thesis's rule (split triangles only, T-junctions left) empties some (measured: 66)."""
    import importlib

    tess = importlib.import_module("refsoft.search.virtual")
    scene = refsoft.load_scene("sphere", width=320, height=240)
    floor = [i + 1 for i, o in enumerate(scene.objects) if o.name == "floor"][0]
    opts = dict(inverse="discard", tessellate=1e-3, max_level=3)
    plain = FrameDriver(scene, RenderOptions(inverse="discard")).render_frame(0).arrays["reflected_id"]
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
