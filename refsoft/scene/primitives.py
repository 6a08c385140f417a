"""Procedural meshes with exact normals.

Curved primitives carry analytic normals (a mirror's shape is its normals); flat pieces
(box faces, cylinder caps, grids) have their own vertices so their normals stay flat. Each
function returns a :class:`refsoft.scene.mesh.Mesh` centred at the origin.
"""

from __future__ import annotations

import numpy as np

from .. import linalg, validate
from ..errors import SceneError
from .mesh import Mesh, normalize_rows


def _positive(value, name, kind=float):
    if not (validate.is_number(value) or isinstance(value, (float, np.floating))):  # inf, NaN: "positive" below
        raise SceneError(f"primitive {name} must be a number, got {value!r}")
    if kind is int and int(value) != value:
        raise SceneError(f"primitive {name} must be an integer, got {value!r}")
    if not np.isfinite(value) or value <= 0:
        raise SceneError(f"primitive {name} must be positive, got {value!r}")
    return kind(value)


def _grid_faces(rows: int, cols: int, offset: int = 0, flip: bool = False) -> np.ndarray:
    """Faces of a (rows+1) x (cols+1) vertex grid, two triangles per cell, wound so that the face
    normal is ``u x v`` (u: along a row, increasing column; v: increasing row), or ``v x u``
    with ``flip``."""
    r, c = np.mgrid[0:rows, 0:cols]
    a = r * (cols + 1) + c
    b = a + 1
    d = a + (cols + 1)
    e = d + 1
    tris = np.concatenate([np.stack([a, b, e], -1).reshape(-1, 3), np.stack([a, e, d], -1).reshape(-1, 3)])
    # Interleave so each cell's two triangles are adjacent in index order.
    order = np.arange(len(tris)).reshape(2, -1).T.reshape(-1)
    tris = tris[order] + offset
    return tris[:, [0, 2, 1]] if flip else tris


def _drop_degenerate(v, faces):
    """Faces whose area is not negligible (pole rows collapse to a point)."""
    area = np.linalg.norm(np.cross(v[faces[:, 1]] - v[faces[:, 0]], v[faces[:, 2]] - v[faces[:, 0]]), axis=1)
    return faces[area > 1e-9 * area.max()]


def _icosahedron():
    """The regular icosahedron on the unit sphere: the rectangles (+-1, +-t, 0) of the golden
    ratio t in the three coordinate planes, scaled by 1 / sqrt(1 + t^2), and its 20 faces
    wound outwards (the usual table, the one trimesh's ``icosahedron`` has)."""
    t = (1.0 + 5.0 ** 0.5) / 2.0
    n = np.sqrt(1.0 + t * t)
    a, b = 1.0 / n, t / n
    v = np.array([[-a, b, 0], [a, b, 0], [-a, -b, 0], [a, -b, 0], [0, -a, b], [0, a, b], [0, -a, -b], [0, a, -b],
                  [b, 0, -a], [b, 0, a], [-b, 0, -a], [-b, 0, a]], dtype=np.float64)
    f = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2],
                  [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5],
                  [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]], dtype=np.int64)
    return v, f


def split_in_four(vertices, faces, attributes=None):
    """Every triangle split 1-to-4 at its edges' midpoints (one midpoint per edge, shared).

    The vertices keep their indices; the midpoints follow, one per edge ``(a, b)``, ``a < b``,
    in increasing ``(b, a)``; each face ``(i, j, k)`` becomes ``(i, m_ij, m_ki)``, ``(m_ij, j,
    m_jk)``, ``(m_ki, m_jk, k)``, ``(m_ij, m_jk, m_ki)``, in face order. This is trimesh's
    ``remesh.subdivide`` order, so meshes made with it before are the same, bit for bit
    (``tests/scene/test_primitives.py``), without importing trimesh (a second at start-up).

    Parameters
    ----------
    vertices : ndarray (V, 3) float64
    faces : ndarray (F, 3) int
    attributes : dict of str -> ndarray (V, d), optional
        Per-vertex values averaged onto the midpoints like the positions.

    Returns
    -------
    vertices (V + E, 3), faces (4F, 3) int64, and with ``attributes`` the dict of (V + E, d).
    """
    faces = np.asarray(faces, dtype=np.int64)
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    key = edges[:, 1] * (int(edges.max(initial=0)) + 1) + edges[:, 0]  # orders by (b, a)
    _, unique, inverse = np.unique(key, return_index=True, return_inverse=True)
    mid = inverse.reshape(-1, 3) + len(vertices)
    new_faces = np.column_stack([faces[:, 0], mid[:, 0], mid[:, 2], mid[:, 0], faces[:, 1], mid[:, 1],
                                 mid[:, 2], mid[:, 1], faces[:, 2], mid[:, 0], mid[:, 1], mid[:, 2]]).reshape(-1, 3)
    new_vertices = np.vstack((vertices, vertices[edges[unique]].mean(axis=1)))
    if attributes is None:
        return new_vertices, new_faces
    return new_vertices, new_faces, {k: np.vstack((a, a[edges[unique]].mean(axis=1))) for k, a in attributes.items()}


def icosphere(subdivisions: int = 3, radius: float = 1.0) -> Mesh:
    """Subdivided icosahedron, its vertices pushed onto the sphere after each split (the vertex
    order of trimesh's ``creation.icosphere``), normals ``p / |p|``."""
    subdivisions = int(_positive(subdivisions + 1, "subdivisions", int)) - 1
    radius = _positive(radius, "radius")
    if subdivisions > 9:
        raise SceneError(f"icosphere subdivisions must be at most 9, got {subdivisions}")
    v, f = _icosahedron()
    for _ in range(max(subdivisions, 1)):
        if subdivisions > 0:
            v, f = split_in_four(v, f)
        scalar = linalg.norm3(v)
        v = v + (v / scalar.reshape((-1, 1))) * (radius - scalar).reshape((-1, 1))
    return Mesh(v, f, normalize_rows(v), name="icosphere")


def uv_sphere(rings: int = 32, segments: int = 64, radius: float = 1.0) -> Mesh:
    """Latitude-longitude sphere with poles on the y axis, normals ``p / |p|``."""
    rings = _positive(rings, "rings", int)
    segments = _positive(segments, "segments", int)
    radius = _positive(radius, "radius")
    if rings < 2 or segments < 3:
        raise SceneError("uv_sphere needs rings >= 2 and segments >= 3")
    theta = np.linspace(0.0, np.pi, rings + 1)           # from +y down to -y
    phi = np.linspace(0.0, 2.0 * np.pi, segments + 1)     # seam duplicated (own normals)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    n = np.stack([np.sin(t) * np.sin(p), np.cos(t), np.sin(t) * np.cos(p)], -1).reshape(-1, 3)
    # rows run down from +y, columns around y: u x v points inwards, so flip
    v = n * radius
    f = _drop_degenerate(v, _grid_faces(rings, segments, flip=True))
    return Mesh(v, f, n, name="uv_sphere")


def plane_grid(size=(2.0, 2.0), divisions=(1, 1)) -> Mesh:
    """A grid in the xz plane facing +y, centred at the origin.

    ``size`` is (x extent, z extent); ``divisions`` the cells along x and z.
    """
    sx, sz = (size, size) if np.isscalar(size) else size
    nx, nz = (divisions, divisions) if np.isscalar(divisions) else divisions
    sx, sz = _positive(sx, "size"), _positive(sz, "size")
    nx, nz = _positive(nx, "divisions", int), _positive(nz, "divisions", int)
    x = np.linspace(-sx / 2, sx / 2, nx + 1)
    z = np.linspace(sz / 2, -sz / 2, nz + 1)
    zz, xx = np.meshgrid(z, x, indexing="ij")
    v = np.stack([xx, np.zeros_like(xx), zz], -1).reshape(-1, 3)
    f = _grid_faces(nz, nx)
    return Mesh(v, f, np.tile([0.0, 1.0, 0.0], (len(v), 1)), name="plane")


def box(extents=(1.0, 1.0, 1.0), subdivisions: int = 1) -> Mesh:
    """Axis-aligned box with every face split into ``subdivisions``^2 cells; flat normals."""
    ext = np.broadcast_to(np.asarray(extents, dtype=np.float64), (3,))
    for e in ext:
        _positive(float(e), "extents")
    n = _positive(subdivisions, "subdivisions", int)
    verts, faces, normals = [], [], []
    offset = 0
    for axis in range(3):
        for sign in (1.0, -1.0):
            normal = np.zeros(3)
            normal[axis] = sign
            u_axis, v_axis = (axis + 1) % 3, (axis + 2) % 3
            if sign < 0:
                u_axis, v_axis = v_axis, u_axis
            s = np.linspace(-0.5, 0.5, n + 1)
            vv, uu = np.meshgrid(s, s, indexing="ij")
            p = np.zeros((n + 1, n + 1, 3))
            p[..., axis] = 0.5 * sign
            p[..., u_axis] = uu
            p[..., v_axis] = vv
            verts.append(p.reshape(-1, 3) * ext)
            normals.append(np.tile(normal, ((n + 1) ** 2, 1)))
            faces.append(_grid_faces(n, n, offset))
            offset += (n + 1) ** 2
    return Mesh(np.concatenate(verts), np.concatenate(faces), np.concatenate(normals), name="box")


def cylinder(radius: float = 0.5, height: float = 1.0, sections: int = 32, segments: int = 1,
             caps: bool = True) -> Mesh:
    """Cylinder along y, centred; smooth side normals, flat caps with their own vertices."""
    radius, height = _positive(radius, "radius"), _positive(height, "height")
    sections, segments = _positive(sections, "sections", int), _positive(segments, "segments", int)
    if sections < 3:
        raise SceneError("cylinder needs sections >= 3")
    phi = np.linspace(0.0, 2.0 * np.pi, sections + 1)
    y = np.linspace(height / 2, -height / 2, segments + 1)
    yy, pp = np.meshgrid(y, phi, indexing="ij")
    side_n = np.stack([np.sin(pp), np.zeros_like(pp), np.cos(pp)], -1).reshape(-1, 3)
    side_v = side_n * radius + np.stack([np.zeros_like(yy), yy, np.zeros_like(yy)], -1).reshape(-1, 3)
    verts, norms, faces = [side_v], [side_n], [_grid_faces(segments, sections, flip=True)]
    if caps:
        offset = len(side_v)
        ring = np.stack([np.sin(phi[:-1]), np.zeros(sections), np.cos(phi[:-1])], -1) * radius
        for sign in (1.0, -1.0):
            centre = np.array([[0.0, sign * height / 2, 0.0]])
            v = np.concatenate([centre, ring + centre])
            i = np.arange(sections)
            a, b = 1 + i, 1 + (i + 1) % sections
            f = np.stack([np.zeros(sections, int), a, b] if sign > 0 else [np.zeros(sections, int), b, a], -1)
            verts.append(v)
            norms.append(np.tile([0.0, sign, 0.0], (len(v), 1)))
            faces.append(f + offset)
            offset += len(v)
    return Mesh(np.concatenate(verts), np.concatenate(faces), np.concatenate(norms), name="cylinder")


def capsule(radius: float = 0.5, height: float = 1.0, rings: int = 16, segments: int = 32) -> Mesh:
    """Capsule along y: a cylinder of ``height`` between two hemispheres; analytic normals."""
    radius, height = _positive(radius, "radius"), _positive(height, "height")
    rings, segments = _positive(rings, "rings", int), _positive(segments, "segments", int)
    theta = np.concatenate([np.linspace(0, np.pi / 2, rings + 1), np.linspace(np.pi / 2, np.pi, rings + 1)])
    shift = np.where(np.arange(len(theta)) <= rings, height / 2, -height / 2)
    phi = np.linspace(0.0, 2.0 * np.pi, segments + 1)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    n = np.stack([np.sin(t) * np.sin(p), np.cos(t), np.sin(t) * np.cos(p)], -1)
    v = n * radius
    v[..., 1] += shift[:, None]
    v, n = v.reshape(-1, 3), n.reshape(-1, 3)
    faces = _drop_degenerate(v, _grid_faces(len(theta) - 1, segments, flip=True))
    return Mesh(v, faces, n, name="capsule")


def torus(major_radius: float = 1.0, minor_radius: float = 0.3, major_sections: int = 64,
          minor_sections: int = 32, major_angle_deg: float = 360.0) -> Mesh:
    """Torus around the y axis with analytic normals; ``major_angle_deg`` < 360 gives a section."""
    R, r = _positive(major_radius, "major_radius"), _positive(minor_radius, "minor_radius")
    M, m = _positive(major_sections, "major_sections", int), _positive(minor_sections, "minor_sections", int)
    span = _positive(major_angle_deg, "major_angle_deg")
    if span > 360.0 or M < 3 or m < 3:
        raise SceneError("torus needs major_angle_deg <= 360 and sections >= 3")
    u = np.linspace(0.0, np.radians(span), M + 1)
    w = np.linspace(0.0, 2.0 * np.pi, m + 1)
    uu, ww = np.meshgrid(u, w, indexing="ij")
    radial = np.stack([np.sin(uu), np.zeros_like(uu), np.cos(uu)], -1)
    n = radial * np.cos(ww)[..., None] + np.array([0.0, 1.0, 0.0]) * np.sin(ww)[..., None]
    v = radial * R + n * r
    faces = _grid_faces(M, m, flip=True)
    return Mesh(v.reshape(-1, 3), faces, n.reshape(-1, 3), name="torus")


PRIMITIVES = {
    "icosphere": icosphere,
    "uv_sphere": uv_sphere,
    "plane": plane_grid,
    "box": box,
    "cylinder": cylinder,
    "capsule": capsule,
    "torus": torus,
}


def make_primitive(spec: dict, where: str = "primitive") -> Mesh:
    """Build a primitive from a TOML-style dict ``{"type": name, **parameters}``."""
    if not isinstance(spec, dict) or "type" not in spec:
        raise SceneError(f"{where}: needs a 'type' key, one of {sorted(PRIMITIVES)}")
    kind = spec["type"]
    if kind not in PRIMITIVES:
        raise SceneError(f"{where}.type: unknown primitive {kind!r}, expected one of {sorted(PRIMITIVES)}")
    params = {k: v for k, v in spec.items() if k != "type"}
    import inspect

    allowed = set(inspect.signature(PRIMITIVES[kind]).parameters)
    for key in params:
        if key not in allowed:
            raise SceneError(f"{where}.{key}: unknown parameter for {kind!r} (allowed: {sorted(allowed)})")
    try:
        return PRIMITIVES[kind](**params)
    except SceneError as exc:
        raise SceneError(f"{where}: {exc}") from None
    except (TypeError, ValueError) as exc:
        raise SceneError(f"{where}: bad parameters for {kind!r}: {exc}") from None
