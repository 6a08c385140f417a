"""The icosphere and the 1-to-4 split are written by hand (no trimesh import at start-up) in
trimesh's vertex and face order: the same faces as trimesh makes, and the same positions to a few
ULP (trimesh's own arithmetic is not refsoft's to pin: its icosphere's radii go through BLAS)."""

import numpy as np
import pytest
import trimesh

from refsoft.scene.builtin.shapes import subdivide_long_edges
from refsoft.scene.mesh import Mesh
from refsoft.scene.primitives import icosphere, split_in_four, uv_sphere


@pytest.mark.parametrize("subdivisions", [0, 1, 2, 3, 5])
@pytest.mark.parametrize("radius", [1.0, 0.37, 2.5])
def test_icosphere_is_trimesh_s(subdivisions, radius):
    want = trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius)
    got = icosphere(subdivisions, radius)
    np.testing.assert_allclose(got.vertices, np.asarray(want.vertices), rtol=0, atol=4 * np.finfo(float).eps * radius)
    np.testing.assert_array_equal(got.faces, want.faces)
    # on the sphere to an ULP or two, whatever trimesh does
    np.testing.assert_allclose(np.sqrt(np.sum(got.vertices ** 2, axis=1)), radius, rtol=4 * np.finfo(float).eps)


def test_split_in_four_is_trimesh_s_subdivide_with_attributes():
    m = uv_sphere(5, 7)  # duplicated seam vertices, poles: edges in no particular order
    rng = np.random.default_rng(3)
    attr = {"n": rng.normal(size=(m.n_vertices, 3)), "c": rng.normal(size=(m.n_vertices, 2))}
    want_v, want_f, want_a = trimesh.remesh.subdivide(m.vertices, m.faces.astype(np.int64), vertex_attributes=attr)
    v, f, a = split_in_four(m.vertices, m.faces, attr)
    np.testing.assert_array_equal(f, want_f)
    np.testing.assert_allclose(v, want_v, rtol=4 * np.finfo(float).eps, atol=1e-300)
    for k in attr:
        np.testing.assert_allclose(a[k], want_a[k], rtol=4 * np.finfo(float).eps, atol=1e-300)
    # the midpoints themselves, exactly: (a + b) / 2 of each edge's ends, in refsoft's edge order
    edges = np.sort(m.faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    unique = sorted({(int(b), int(a)) for a, b in edges})
    mid = np.array([(m.vertices[a] + m.vertices[b]) / 2.0 for b, a in unique])
    np.testing.assert_array_equal(v[m.n_vertices:], mid)


def test_long_edges_are_split_until_short():
    v = np.array([[0, 0, 0], [4, 0, 0], [0, 1, 0]], float)
    m = subdivide_long_edges(Mesh(v, [[0, 1, 2]], np.tile([0.0, 0.0, 1.0], (3, 1))), 1.1)
    e = np.linalg.norm(m.vertices[m.faces[:, [1, 2, 0]]] - m.vertices[m.faces], axis=2)
    assert e.max() <= 1.1 and m.n_faces == 4 ** 2
    np.testing.assert_array_equal(m.vertices[:3], v)  # the original vertices keep their indices


def _boundary_cases():
    """Closed, open, seamed (duplicated vertices), degenerate and soup meshes."""
    rng = np.random.default_rng(5)
    ball = icosphere(2, 1.0)
    sphere = uv_sphere(12, 8, 0.5)  # a seam of copies
    box = trimesh.creation.box()
    soup = trimesh.Trimesh(box.vertices[box.faces].reshape(-1, 3), np.arange(36).reshape(-1, 3), process=False)
    open_half = Mesh(ball.vertices, ball.faces[ball.vertices[ball.faces].mean(axis=1)[:, 2] > 0])
    faces = rng.integers(0, 40, (120, 3))
    faces[::9, 1] = faces[::9, 0]  # degenerate triangles
    random = Mesh(np.round(rng.uniform(-1, 1, (40, 3)), 1), faces)  # coincident vertices among them
    return [ball, sphere, Mesh(box.vertices, box.faces), Mesh(soup.vertices, soup.faces), open_half, random]


@pytest.mark.parametrize("case", range(6))
def test_boundary_edges_equal_the_reference(case):
    from naive import naive_boundary_edges

    mesh = _boundary_cases()[case]
    assert mesh.boundary_edges() == naive_boundary_edges(mesh.vertices, mesh.faces)
    if case in (0, 1, 2, 3):  # closed once welded
        assert mesh.boundary_edges() == 0
    if case == 4:
        assert mesh.boundary_edges() > 0
