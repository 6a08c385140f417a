"""The cube map of the environment-map baseline (docs/envmap.md; the face table of docs/ldt.md): GL's face table,
the six 90-degree face projections, the build by the rasterizer and the nearest-texel lookup.

Faces are numbered in OpenGL order, 0 +X, 1 -X, 2 +Y, 3 -Y, 4 +Z, 5 -Z (axis ``f // 2``, sign +1
for even ``f``). For a direction ``d`` on face ``f`` the table of the GL specification (section
8.13, cube map texture selection) gives ``(sc, tc, ma)``::

    +X: (-d_z, -d_y, d_x)    -X: ( d_z, -d_y, -d_x)
    +Y: ( d_x,  d_z, d_y)    -Y: ( d_x, -d_z, -d_y)
    +Z: ( d_x, -d_y, d_z)    -Z: (-d_x, -d_y, -d_z)

with ``ma = sigma_f d_{a_f}`` (``|d_a|`` on the face's own side), ``s = (sc / ma + 1) / 2``,
``t = (tc / ma + 1) / 2``, texel column ``clamp(floor(s R), 0, R - 1)`` and row
``R - 1 - clamp(floor(t R), 0, R - 1)`` (row 0 at the top, docs/conventions.md). Face ``f`` is
rendered with clip coordinates ``(sc, tc, A ma - B', ma)``, so the rasterizer's pixel (row, col)
is exactly the texel (row, col) of the lookup.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import validate
from ..errors import RefsoftError
from ..raster import interpolate, rasterize, shade
from ..scene.mesh import concatenate

#: Face names in OpenGL order.
FACE_NAMES = ("+X", "-X", "+Y", "-Y", "+Z", "-Z")
#: ``far = FAR_MARGIN * max |X - c|`` over the reflected vertices (docs/envmap.md).
FAR_MARGIN = 1.01
#: ``near = NEAR_RATIO * far``.
NEAR_RATIO = 1e-4
#: Largest accepted face resolution.
MAX_RESOLUTION = 4096


def face_coordinates(d, face: int):
    """GL's cube-map table for one face: ``(sc, tc, ma)`` of directions ``d``.

    Parameters
    ----------
    d : ndarray, shape (..., 3)
        Directions (any float dtype; the table only negates and permutes, so the dtype is kept).
    face : int
        0..5, OpenGL order.

    Returns
    -------
    sc, tc, ma : ndarray, shape (...)
        ``ma = sigma_f d_{a_f}``: positive on the face's own side.
    """
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    return ((-z, -y, x), (z, -y, -x), (x, z, y), (x, -z, -y), (x, -y, z), (-x, -y, -z))[face]


def select_face(r) -> np.ndarray:
    """The face a direction looks up: the major axis is the largest ``|r_i|``, ties z over y
    over x (llvmpipe's and Vulkan's rule); the positive face when the sign bit of ``r_a`` is
    clear.

    Parameters
    ----------
    r : ndarray, shape (N, 3), float

    Returns
    -------
    ndarray, shape (N,), int8
    """
    a = np.abs(r)
    axis = np.where((a[:, 2] >= a[:, 1]) & (a[:, 2] >= a[:, 0]), 2, np.where(a[:, 1] >= a[:, 0], 1, 0))
    ra = r[np.arange(len(r)), axis]
    return (2 * axis + np.signbit(ra)).astype(np.int8)


def lookup(r, resolution: int = 256):
    """Nearest-texel cube-map lookup of directions (docs/envmap.md), in ``r``'s dtype.

    Parameters
    ----------
    r : array_like, shape (N, 3), float32 or float64
        Directions (need not be unit; not all zero).
    resolution : int
        Face size ``R`` in texels.

    Returns
    -------
    face : ndarray (N,) int8
    row, col : ndarray (N,) int32
        The texel, row 0 at the top.
    s, t : ndarray (N,), r's dtype
        The face coordinates in [0, 1].
    """
    r = np.asarray(r)
    if r.dtype not in (np.float32, np.float64):
        raise RefsoftError(f"directions must be float32 or float64, got {r.dtype}")
    if r.ndim != 2 or r.shape[1] != 3:
        raise RefsoftError(f"directions must have shape (N, 3), got {r.shape}")
    if not np.all(np.isfinite(r)):
        raise RefsoftError("directions are not finite")
    if len(r) and not np.all(np.any(r != 0, axis=1)):
        raise RefsoftError("a direction is zero")
    res = validate.integer(resolution, "resolution", 1, MAX_RESOLUTION)
    dt = r.dtype.type
    face = select_face(r)
    s = np.zeros(len(r), dtype=dt)
    t = np.zeros(len(r), dtype=dt)
    for f in range(6):
        on = face == f
        sc, tc, ma = face_coordinates(r[on], f)
        s[on] = (sc / ma + dt(1)) * dt(0.5)
        t[on] = (tc / ma + dt(1)) * dt(0.5)
        # ma >= 0 here; it is +0.0 or a positive number, and never 0 (r is not zero)
    top = res - 1
    col = np.clip(np.floor(s * dt(res)), 0, top).astype(np.int32)
    row = top - np.clip(np.floor(t * dt(res)), 0, top).astype(np.int32)
    return face, row, col, s, t


def face_clip(points, center, face: int, near: float, far: float) -> np.ndarray:
    """Clip coordinates of world points in cube face ``face`` (float64): with ``d = X - c``,
    ``(sc(d), tc(d), A w - B', w)``, ``w = ma(d)``, ``A = (far + near) / (far - near)``,
    ``B' = 2 far near / (far - near)`` (GL's perspective depth: window depth 0 at ``w = near``,
    1 at ``w = far``).

    Parameters
    ----------
    points : ndarray (V, 3) float64
    center : ndarray (3,) float64
    face : int
    near, far : float

    Returns
    -------
    ndarray (V, 4) float64
    """
    d = np.asarray(points, dtype=np.float64) - np.asarray(center, dtype=np.float64)
    sc, tc, w = face_coordinates(d, face)
    a = (far + near) / (far - near)
    b = 2.0 * far * near / (far - near)
    return np.stack([sc, tc, a * w - b, w], axis=1)


@dataclass(eq=False)
class CubeMap:
    """One reflector's cube map of one frame.

    Attributes
    ----------
    color : ndarray (6, R, R, 3) float32
        Shaded colour of the visible reflected surface per texel; 0 where none.
    object_id : ndarray (6, R, R) int32
        Its object id; 0 where none (background).
    center : ndarray (3,) float64
        The cube's centre (the reflector's world AABB centre).
    near, far : float
        The faces' depth range.
    """

    color: np.ndarray
    object_id: np.ndarray
    center: np.ndarray
    near: float
    far: float

    @property
    def resolution(self) -> int:
        return self.object_id.shape[1]


def build_cube_map(meshes, ids, colors, center, resolution: int = 256) -> CubeMap:
    """Render the six faces of a cube map around ``center`` (docs/envmap.md): every mesh,
    both windings, by the rasterizer (LESS, the first drawn wins ties, so lower ids win), each
    texel storing :func:`refsoft.raster.shade` of the interpolated normal and the object id.

    Parameters
    ----------
    meshes : sequence of Mesh
        World meshes of the reflected objects, drawn in order.
    ids : sequence of int
        Their object ids (>= 1).
    colors : array_like (len(meshes), 3)
        Their colours.
    center : array_like (3,)
    resolution : int

    Returns
    -------
    CubeMap
    """
    res = validate.integer(resolution, "resolution", 1, MAX_RESOLUTION)
    c = validate.point(center, "center")
    meshes = list(meshes)
    ids = np.asarray(ids, dtype=np.int64)
    if ids.shape != (len(meshes),) or (len(ids) and ids.min() < 1):
        raise RefsoftError(f"ids must be {len(meshes)} object ids >= 1, got {ids.tolist()}")
    colors = np.asarray(colors, dtype=np.float64)
    if colors.shape != (len(meshes), 3):
        raise RefsoftError(f"colors must have shape ({len(meshes)}, 3), got {colors.shape}")
    color = np.zeros((6, res, res, 3), dtype=np.float32)
    object_id = np.zeros((6, res, res), dtype=np.int32)
    if not meshes:
        return CubeMap(color, object_id, c, NEAR_RATIO, 1.0)
    scene = concatenate(meshes, ids)
    radius = float(np.sqrt(np.max(np.sum((scene.vertices - c) ** 2, axis=1))))
    far = FAR_MARGIN * radius if radius > 0 else 1.0
    near = NEAR_RATIO * far
    # per face of the concatenation: its mesh's colour (float32, as the main view's table)
    face_color = np.repeat(colors.astype(np.float32), np.diff(scene.face_offsets), axis=0)
    for f in range(6):
        frags = rasterize(face_clip(scene.vertices, c, f, near, far), scene.faces, res, res)
        on = frags.triangle >= 0
        tri = frags.triangle[on]
        nrm = interpolate(frags, scene.normals, scene.faces, np.float32, normalize=True)
        color[f][on] = shade(nrm[on], face_color[tri])
        object_id[f][on] = scene.face_object[tri]
    return CubeMap(color, object_id, c, near, far)
