"""refsoft.search.tessellate._split (the conforming midpoint split) against the plain
per-triangle reference in tests/naive.py on small planar meshes: the same children in the same
order, which cover their parent with its winding and leave no T-junction."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from naive import naive_split

from refsoft.search.tessellate import KEY_BASE, _edge_keys, _split


def _grid(nx, ny, diagonals):
    """A counter-clockwise triangulated nx x ny grid on even integer points (midpoints are then
    integer too): positions (V, 2) int64 and faces (2 nx ny, 3)."""
    pts = np.array([(2 * i, 2 * j) for j in range(ny + 1) for i in range(nx + 1)], dtype=np.int64)
    faces = []
    for j in range(ny):
        for i in range(nx):
            a, b = j * (nx + 1) + i, j * (nx + 1) + i + 1
            c, d = a + nx + 1, b + nx + 1
            faces += [(a, b, d), (a, d, c)] if diagonals[j * nx + i] else [(a, b, c), (b, d, c)]
    return pts, np.array(faces, dtype=np.int64)


def _area2(p, f):
    a, b, c = p[f[:, 0]], p[f[:, 1]], p[f[:, 2]]
    return (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])


@st.composite
def _meshes(draw):
    nx, ny = draw(st.integers(1, 4)), draw(st.integers(1, 3))
    pts, faces = _grid(nx, ny, draw(st.lists(st.booleans(), min_size=nx * ny, max_size=nx * ny)))
    edges = np.unique(np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1), axis=0)
    chosen = draw(st.lists(st.booleans(), min_size=len(edges), max_size=len(edges)))
    return pts, faces, edges[np.array(chosen, dtype=bool)]


@settings(max_examples=200, deadline=None)
@given(_meshes())
def test_split_equals_the_reference_and_conforms(mesh):
    pts, faces, split = mesh
    n = len(pts)
    keys = np.sort(_edge_keys(split[:, 0], split[:, 1], KEY_BASE)) if len(split) else np.zeros(0, np.int64)
    mids = n + np.arange(len(keys), dtype=np.int64)
    got, parent = _split(faces, keys, mids, KEY_BASE)
    ref = {(int(k // KEY_BASE), int(k % KEY_BASE)): int(m) for k, m in zip(keys, mids)}
    exp, exp_parent = naive_split(faces, ref)
    np.testing.assert_array_equal(got, exp)
    np.testing.assert_array_equal(parent, exp_parent)
    # geometry: new vertices at the edge midpoints; every child counter-clockwise like its
    # parent, and the children's areas sum to the parent's
    ends = np.array([(k // KEY_BASE, k % KEY_BASE) for k in keys], dtype=np.int64).reshape(-1, 2)
    p = np.concatenate([pts, (pts[ends[:, 0]] + pts[ends[:, 1]]) // 2])
    assert np.all(_area2(p, got) > 0)
    np.testing.assert_array_equal(np.bincount(parent, weights=_area2(p, got), minlength=len(faces)),
                                  _area2(p, faces))
    # conforming: every directed edge inside the grid has its reverse (a T-junction leaves a
    # long edge whose reverse is missing)
    directed = {(int(u), int(v)) for f in got for u, v in ((f[0], f[1]), (f[1], f[2]), (f[2], f[0]))}
    top = pts.max(axis=0)
    for u, v in directed:
        on_side = np.any((p[u] == p[v]) & ((p[u] == 0) | (p[u] == top)))
        assert (v, u) in directed or on_side


@settings(max_examples=100, deadline=None)
@given(_meshes(), st.data())
def test_split_of_chosen_triangles_only_equals_the_reference(mesh, data):
    pts, faces, _ = mesh
    only = np.array(data.draw(st.lists(st.booleans(), min_size=len(faces), max_size=len(faces))), dtype=bool)
    ends = faces[only]
    keys = np.unique(np.concatenate([_edge_keys(ends[:, i], ends[:, (i + 1) % 3], KEY_BASE) for i in range(3)]))
    mids = len(pts) + np.arange(len(keys), dtype=np.int64)
    got, parent = _split(faces, keys, mids, KEY_BASE, only)
    ref = {(int(k // KEY_BASE), int(k % KEY_BASE)): int(m) for k, m in zip(keys, mids)}
    exp, exp_parent = naive_split(faces, ref, only)
    np.testing.assert_array_equal(got, exp)
    np.testing.assert_array_equal(parent, exp_parent)
    np.testing.assert_array_equal(np.bincount(parent, minlength=len(faces)), np.where(only, 4, 1))
