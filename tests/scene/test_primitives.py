"""The icosphere and the 1-to-4 split are written by hand (no trimesh import at start-up) in
trimesh's vertex and face order: the same meshes, bit for bit, as trimesh makes."""

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
    np.testing.assert_array_equal(got.vertices, np.asarray(want.vertices))
    np.testing.assert_array_equal(got.faces, want.faces)


def test_split_in_four_is_trimesh_s_subdivide_with_attributes():
    m = uv_sphere(5, 7)  # duplicated seam vertices, poles: edges in no particular order
    rng = np.random.default_rng(3)
    attr = {"n": rng.normal(size=(m.n_vertices, 3)), "c": rng.normal(size=(m.n_vertices, 2))}
    want_v, want_f, want_a = trimesh.remesh.subdivide(m.vertices, m.faces.astype(np.int64), vertex_attributes=attr)
    v, f, a = split_in_four(m.vertices, m.faces, attr)
    np.testing.assert_array_equal(v, want_v)
    np.testing.assert_array_equal(f, want_f)
    for k in attr:
        np.testing.assert_array_equal(a[k], want_a[k])


def test_long_edges_are_split_until_short():
    v = np.array([[0, 0, 0], [4, 0, 0], [0, 1, 0]], float)
    m = subdivide_long_edges(Mesh(v, [[0, 1, 2]], np.tile([0.0, 0.0, 1.0], (3, 1))), 1.1)
    e = np.linalg.norm(m.vertices[m.faces[:, [1, 2, 0]]] - m.vertices[m.faces], axis=2)
    assert e.max() <= 1.1 and m.n_faces == 4 ** 2
    np.testing.assert_array_equal(m.vertices[:3], v)  # the original vertices keep their indices
