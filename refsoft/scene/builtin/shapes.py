"""Meshes the built-in scenes need beyond the primitives: bowls, saucers, quads, merged parts."""

from __future__ import annotations

import numpy as np

from ..mesh import Mesh, concatenate, normalize_rows
from ..primitives import _drop_degenerate, _grid_faces
from ..model import Transform


def merge(parts, name="merged") -> Mesh:
    """One mesh from (mesh, Transform) pairs (vertex order: part by part)."""
    c = concatenate([mesh.transformed(tf.matrix()) for mesh, tf in parts])
    return Mesh(c.vertices, c.faces, c.normals, name=name)


def bowl(radius=1.0, rings=24, segments=64, inside=False) -> tuple[Mesh, Mesh]:
    """An open hemispherical bowl (the lower half of a sphere, rim at y = 0) and its closed
    proxy (the same half with a flat lid). ``inside=True`` turns normals and winding inwards
    (the concave inner surface)."""
    theta = np.linspace(np.pi / 2, np.pi, rings + 1)
    phi = np.linspace(0.0, 2 * np.pi, segments + 1)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    n = np.stack([np.sin(t) * np.sin(p), np.cos(t), np.sin(t) * np.cos(p)], -1).reshape(-1, 3)
    v = n * radius
    faces = _drop_degenerate(v, _grid_faces(rings, segments, flip=not inside))
    shell = Mesh(v, faces, -n if inside else n, name="bowl")
    # lid: a fan over the rim, facing up
    ring = v[: segments + 1][:-1]
    lid_v = np.vstack([[0.0, 0.0, 0.0], ring])
    i = np.arange(segments)
    lid_f = np.stack([np.zeros(segments, int), 1 + (i + 1) % segments, 1 + i], -1)
    closed_v = np.vstack([v, lid_v])
    closed_f = np.vstack([faces, lid_f + len(v)])
    closed_n = np.vstack([-n if inside else n, np.tile([0.0, 1.0, 0.0], (len(lid_v), 1))])
    return shell, Mesh(closed_v, closed_f, closed_n, name="bowl_closed")


def quad(size=(2.0, 2.0)) -> Mesh:
    """Two triangles in the xy plane facing +z (the case where linear interpolation of a
    reflection is visibly wrong)."""
    sx, sy = size
    v = np.array([[-sx / 2, -sy / 2, 0], [sx / 2, -sy / 2, 0], [sx / 2, sy / 2, 0], [-sx / 2, sy / 2, 0]], float)
    return Mesh(v, [[0, 1, 2], [0, 2, 3]], np.tile([0.0, 0.0, 1.0], (4, 1)), name="quad")


def subdivide_long_edges(mesh: Mesh, max_edge: float, max_rounds: int = 8) -> Mesh:
    """Split triangles 1-to-4 until no edge is longer than ``max_edge`` (for cans whose long
    thin triangles would otherwise reflect badly). Normals are interpolated and renormalised."""
    from ..primitives import split_in_four

    v, f, n = mesh.vertices, mesh.faces.astype(np.int64), mesh.normals
    for _ in range(max_rounds):
        e = np.linalg.norm(v[f[:, [1, 2, 0]]] - v[f], axis=2).max()
        if e <= max_edge:
            break
        v2, f2, attr = split_in_four(v, f, {"n": n})
        v, f, n = v2, f2, attr["n"]
    return Mesh(v, f, normalize_rows(n), name=mesh.name)


def tf(t=(0, 0, 0), r=(0, 0, 0), s=1.0) -> Transform:
    return Transform(t, r, s if not np.isscalar(s) else (s, s, s))
