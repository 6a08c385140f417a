"""Triangle meshes: validation, loading through trimesh, transforms.

A :class:`Mesh` holds float64 ``vertices`` (V, 3), int32 ``faces`` (F, 3) and unit float64
``normals`` (V, 3). Vertex order is never changed: vertex ``i`` of a file is vertex ``i`` in
every output (spec section 3).
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from .. import constants, linalg
from ..errors import MeshError, LimitError


def area_weighted_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area-weighted vertex normals: the sum of adjacent faces' cross products, normalised.

    Parameters
    ----------
    vertices : ndarray, shape (V, 3), float64
    faces : ndarray, shape (F, 3), integer

    Returns
    -------
    ndarray, shape (V, 3), float64
        Unit normals; the zero vector for vertices with no (non-degenerate) face.
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    cross = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    acc = np.zeros_like(v)
    for k in range(3):
        np.add.at(acc, f[:, k], cross)
    return normalize_rows(acc)


def normalize_rows(a: np.ndarray) -> np.ndarray:
    """Rows divided by their length; zero rows stay zero (no NaN)."""
    a = np.asarray(a)
    n = linalg.norm3(a)[..., None] if a.shape[-1] == 3 else np.linalg.norm(a, axis=-1, keepdims=True)
    return np.divide(a, n, out=np.zeros_like(a, dtype=np.float64), where=n > 0)


@dataclass(frozen=True, eq=False)
class Mesh:
    """A validated triangle mesh.

    Parameters
    ----------
    vertices : array_like, shape (V, 3)
        Positions; stored as float64.
    faces : array_like, shape (F, 3)
        Vertex indices; stored as int32.
    normals : array_like, shape (V, 3), optional
        Vertex normals; normalised on construction. Default: area-weighted.
    name : str
        Used in error messages.
    """

    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray | None = None
    name: str = "mesh"

    def __post_init__(self):
        v = np.asarray(self.vertices)
        f = np.asarray(self.faces)
        who = f"mesh {self.name!r}"
        if v.ndim != 2 or v.shape[1] != 3:
            raise MeshError(f"{who}: vertices must have shape (V, 3), got {v.shape}")
        if f.ndim != 2 or f.shape[1] != 3:
            raise MeshError(f"{who}: faces must have shape (F, 3), got {f.shape}")
        if len(v) == 0 or len(f) == 0:
            raise MeshError(f"{who} is empty ({len(v)} vertices, {len(f)} faces)")
        if len(v) > constants.MAX_VERTICES or len(f) > constants.MAX_TRIANGLES:
            raise LimitError(f"{who}: {len(v)} vertices / {len(f)} faces exceed the limits "
                             f"({constants.MAX_VERTICES} / {constants.MAX_TRIANGLES})")
        if not np.issubdtype(v.dtype, np.number) or np.issubdtype(v.dtype, np.complexfloating):
            raise MeshError(f"{who}: vertices must be real numbers, got dtype {v.dtype}")
        v = v.astype(np.float64)
        bad = ~np.all(np.isfinite(v), axis=1)
        if bad.any():
            raise MeshError(f"{who}: {int(bad.sum())} non-finite vertices (first: index {int(np.argmax(bad))})")
        if not np.issubdtype(f.dtype, np.integer):
            if np.issubdtype(f.dtype, np.floating) and np.all(np.isfinite(f)) and np.all(f == np.round(f)):
                f = f.astype(np.int64)
            else:
                raise MeshError(f"{who}: faces must be integers, got dtype {f.dtype}")
        if f.min() < 0 or f.max() >= len(v):
            raise MeshError(f"{who}: face indices must be in [0, {len(v) - 1}], got range "
                            f"[{int(f.min())}, {int(f.max())}]")
        f = f.astype(np.int32)
        if self.normals is None:
            n = area_weighted_normals(v, f)
        else:
            n = np.asarray(self.normals, dtype=np.float64)
            if n.shape != v.shape:
                raise MeshError(f"{who}: normals must have shape {v.shape}, got {n.shape}")
            if not np.all(np.isfinite(n)):
                raise MeshError(f"{who}: normals are not finite")
            n = normalize_rows(n)
        for name, arr in (("vertices", v), ("faces", f), ("normals", n)):
            arr = np.ascontiguousarray(arr)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    @property
    def n_vertices(self) -> int:
        return len(self.vertices)

    @property
    def n_faces(self) -> int:
        return len(self.faces)

    def weld(self) -> tuple[np.ndarray, int]:
        """One label per position, vertices within 1e-9 of the mesh's extent sharing it (seams
        and hard-normal copies): ``(labels (V,) int64, number of labels)``, labels in the
        lexicographic order of the positions."""
        v = self.vertices
        lo = v.min(axis=0)
        extent = float(np.max(v.max(axis=0) - lo)) or 1.0
        key = np.round((v - lo) / (extent * 1e-9))
        # rows sorted lexicographically, one label per run of equal rows (np.unique of rows,
        # axis=0, sorts them as records: ten times as slow)
        order = np.lexsort(key.T[::-1])
        ordered = key[order]
        first = np.ones(len(v), dtype=bool)
        first[1:] = np.any(ordered[1:] != ordered[:-1], axis=1)
        weld = np.empty(len(v), dtype=np.int64)
        weld[order] = np.cumsum(first) - 1
        return weld, int(np.count_nonzero(first))

    def boundary_edges(self) -> int:
        """Edges used by exactly one triangle once vertices at the same position are welded
        (:meth:`weld`); 0 for a closed surface. Degenerate edges (both ends welded together) are
        ignored."""
        weld, n_labels = self.weld()
        f = weld[self.faces]
        a, b = f.T.reshape(-1), f[:, [1, 2, 0]].T.reshape(-1)  # every edge of every triangle
        lo_end, hi_end = np.minimum(a, b), np.maximum(a, b)
        keep = lo_end != hi_end
        # an undirected edge as one int64 (labels < MAX_VERTICES = 2^26: the key stays below 2^52)
        _, counts = np.unique(lo_end[keep] * n_labels + hi_end[keep], return_counts=True)
        return int(np.sum(counts == 1))

    def bounds(self) -> np.ndarray:
        """Axis-aligned bounds, shape (2, 3): min and max corners."""
        return np.stack([self.vertices.min(axis=0), self.vertices.max(axis=0)])

    def transformed(self, matrix: np.ndarray) -> "Mesh":
        """The mesh under an affine 4x4 transform (normals by the inverse transpose)."""
        m = np.asarray(matrix, dtype=np.float64)
        v = linalg.affine_points(self.vertices, m)
        normal_matrix = linalg.inv3(m[:3, :3]).T
        n = normalize_rows(linalg.rows_times(self.normals, normal_matrix))
        return Mesh(v, self.faces, n, name=self.name)

    def to_trimesh(self):
        """A ``trimesh.Trimesh`` view (``process=False``) of this mesh."""
        import trimesh

        return trimesh.Trimesh(self.vertices, self.faces, vertex_normals=self.normals, process=False)


def load_mesh(path: str | os.PathLike) -> Mesh:
    """Load a mesh file through trimesh without merging or reordering vertices.

    Parameters
    ----------
    path : str or PathLike
        OBJ, PLY, STL, OFF, GLB or anything else trimesh reads.

    Returns
    -------
    Mesh
        With the file's vertex normals when it has them, else area-weighted ones.
    """
    import trimesh

    path = os.fspath(path)
    if not os.path.isfile(path):
        raise MeshError(f"mesh file not found: {path}")
    try:
        loaded = trimesh.load(path, process=False, maintain_order=True)
    except Exception as exc:  # trimesh raises many types for unreadable files
        raise MeshError(f"cannot read mesh {path}: {exc}".splitlines()[0]) from None
    if isinstance(loaded, trimesh.Scene):
        geoms = [g for g in loaded.dump() if isinstance(g, trimesh.Trimesh)]
        if not geoms:
            raise MeshError(f"mesh file {path} holds no triangle mesh")
        loaded = geoms[0] if len(geoms) == 1 else trimesh.util.concatenate(geoms)
    if not isinstance(loaded, trimesh.Trimesh):
        raise MeshError(f"mesh file {path} holds no triangle mesh (got {type(loaded).__name__})")
    # trimesh keeps normals read from the file in its cache; computed ones are not there yet.
    file_normals = loaded._cache.cache.get("vertex_normals")
    v = np.asarray(loaded.vertices)
    f = np.asarray(loaded.faces)
    if file_normals is not None and np.shape(file_normals) != v.shape:
        file_normals = None
    return Mesh(v, f, file_normals, name=os.path.basename(path))


@dataclass(frozen=True, eq=False)
class Combined:
    """Several meshes as one (:func:`concatenate`).

    Attributes
    ----------
    vertices, normals : ndarray, shape (V, 3), float64
        Every mesh's vertices and normals, mesh after mesh.
    faces : ndarray, shape (F, 3), int64
        Every mesh's faces, indices into the combined vertices.
    face_object : ndarray, shape (F,), int32
        The id given for each face's mesh.
    vertex_offsets, face_offsets : ndarray, shape (M + 1,), int64
        Mesh ``i``'s vertices are ``vertex_offsets[i]:vertex_offsets[i + 1]``; faces likewise.
    """

    vertices: np.ndarray
    normals: np.ndarray
    faces: np.ndarray
    face_object: np.ndarray
    vertex_offsets: np.ndarray
    face_offsets: np.ndarray


def concatenate(meshes, ids=None) -> Combined:
    """Concatenate meshes, re-indexing their faces (the one place this is done).

    Parameters
    ----------
    meshes : sequence of Mesh
    ids : sequence of int, optional
        An id per mesh for ``face_object`` (default ``1 .. M``).
    """
    meshes = list(meshes)
    ids = np.arange(1, len(meshes) + 1) if ids is None else np.asarray(ids)
    v_off = np.cumsum([0] + [m.n_vertices for m in meshes]).astype(np.int64)
    f_off = np.cumsum([0] + [m.n_faces for m in meshes]).astype(np.int64)
    if not meshes:
        empty = np.zeros((0, 3))
        return Combined(empty, empty, np.zeros((0, 3), np.int64), np.zeros(0, np.int32), v_off, f_off)
    return Combined(np.concatenate([m.vertices for m in meshes]), np.concatenate([m.normals for m in meshes]),
                    np.concatenate([m.faces.astype(np.int64) + v_off[i] for i, m in enumerate(meshes)]),
                    np.repeat(ids.astype(np.int32), [m.n_faces for m in meshes]), v_off, f_off)
