"""Building one object's layered depth texture (docs/ldt.md, "The build").

Once per object, in model space: an axis-aligned cube around the mesh, six orthographic views
from the cube's faces inward rasterized with refsoft's rasterizer (spec section 2), depth peeling
of the triangles facing each view, and the back depths of every layer paired from the opposite
face. Nothing here depends on the camera.

Conventions (faces, texels, depth):

- faces in OpenGL order 0 +X, 1 -X, 2 +Y, 3 -Y, 4 +Z, 5 -Z; axis ``a = f // 2``, sign
  ``sigma = +1`` for even f, the opposite face ``f ^ 1``;
- normalised cube coordinates ``q = (p - centre) / half`` in [-1, 1]^3; face coordinates
  ``(sc, tc)`` from :data:`refsoft.ldt.constants.FACE_TABLE` (the GL cube-map table),
  ``s = (sc + 1) / 2``, ``t = (tc + 1) / 2``;
- texel ``(row, col)`` has its centre at ``s = (col + 0.5) / R``, ``t = (R - row - 0.5) / R``
  (the rasterizer's pixel centre; row 0 at the top);
- depth is axial: ``delta_f(q) = (1 - sigma q_a) / 2``, 0 on face f's plane, 1 on the opposite
  plane.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from .. import raster
from ..errors import RefsoftError
from ..scene.mesh import Mesh
from . import constants as C


@dataclass(eq=False)
class LDT:
    """One object's layered depth texture.

    ``L`` is the largest layer count over the six faces; ``R`` the resolution.

    Attributes
    ----------
    depth : ndarray (6, L, R, R) float32
        Window depth ``delta_f`` of layer j's surface facing face f; 1.0 where none.
    back : ndarray (6, L, R, R) float32
        The depth, in face f's terms, where layer j leaves the object:
        ``1 - depth[f ^ 1, L' - 1 - j, mirrored texel]`` for ``j < count``; 1.0 beyond (and
        everywhere for an open mesh).
    normal : ndarray (6, L, R, R, 3) float32
        Model-space unit normal interpolated at the texel (renormalised); 0 where none.
    triangle : ndarray (6, L, R, R) int32
        The mesh triangle seen; -1 where none.
    count_raw : ndarray (6, R, R) uint8
        Layers face f's peeling found at the texel.
    count : ndarray (6, R, R) uint8
        Layers the search uses: ``min(count_raw, count_raw of the mirrored texel of f ^ 1)``
        (``count_raw`` for an open mesh).
    mismatch : ndarray (6, R, R) bool
        Where the two counts differ (always False for an open mesh).
    cube_center : ndarray (3,) float64
        Model-space centre ``c`` of the cube (the centre of the vertices' bounding box).
    cube_half : float
        Half the cube's side, ``0.5 * Lmax * R / (R - 2)``.
    open : bool
        The mesh is not closed: one layer, both windings, no pairing (``back = 1``).
    layers_capped : bool
        Peeling stopped at the layer limit with surfaces left behind it.
    """

    depth: np.ndarray
    back: np.ndarray
    normal: np.ndarray
    triangle: np.ndarray
    count_raw: np.ndarray
    count: np.ndarray
    mismatch: np.ndarray
    cube_center: np.ndarray
    cube_half: float
    open: bool
    layers_capped: bool

    @property
    def resolution(self) -> int:
        return self.depth.shape[-1]

    @property
    def n_layers(self) -> int:
        """Layers stored (the largest count over the faces)."""
        return self.depth.shape[1]

    @property
    def layer_histogram(self) -> dict:
        """Texels per layer count (``count``), over the six faces: ``{count: texels}``."""
        values, counts = np.unique(self.count, return_counts=True)
        return {int(v): int(n) for v, n in zip(values, counts)}

    def back_in(self, dtype) -> np.ndarray:
        """``back`` computed in ``dtype`` (float32: :attr:`back` itself)."""
        if np.dtype(dtype) == np.float32:
            return self.back
        return pair_back_depths(self.depth, self.count_raw, self.open, dtype)[0]

    def arrays(self) -> dict:
        """The arrays of ``ldt_J.npz``: ``depth``, ``back``, ``normal``, ``triangle``,
        ``count_raw``, ``count``, ``mismatch``, ``cube_center``, ``cube_half``, ``open``,
        ``layers_capped``."""
        return dict(depth=self.depth, back=self.back, normal=self.normal, triangle=self.triangle,
                    count_raw=self.count_raw, count=self.count, mismatch=self.mismatch,
                    cube_center=np.asarray(self.cube_center, np.float64), cube_half=np.float64(self.cube_half),
                    open=np.bool_(self.open), layers_capped=np.bool_(self.layers_capped))

    def save(self, path) -> None:
        """Write :meth:`arrays` to ``path`` (``ldt_J.npz``; a temporary name, then renamed)."""
        from ..io import write_npz

        write_npz(os.fspath(path), **self.arrays())

    @classmethod
    def load(cls, path) -> "LDT":
        """An LDT written by :meth:`save`."""
        with np.load(os.fspath(path)) as z:
            return cls(z["depth"], z["back"], z["normal"], z["triangle"], z["count_raw"], z["count"], z["mismatch"],
                       z["cube_center"], float(z["cube_half"]), bool(z["open"]), bool(z["layers_capped"]))


def check_resolution(resolution) -> int:
    """``resolution`` as an int in [MIN_RESOLUTION, MAX_RESOLUTION]."""
    from .. import validate

    if not validate.is_integer(resolution) or not C.MIN_RESOLUTION <= resolution <= C.MAX_RESOLUTION:
        raise RefsoftError(f"LDT resolution must be an integer in [{C.MIN_RESOLUTION}, {C.MAX_RESOLUTION}], "
                           f"got {resolution!r}")
    return int(resolution)


def cube_of(vertices, resolution: int):
    """The cube around model-space ``vertices`` (V, 3): centre (3,) float64 (the centre of the
    bounding box) and half side ``0.5 * Lmax * R / (R - 2)`` (at least one empty texel on each
    side, exactly one along the longest axis)."""
    v = np.asarray(vertices, dtype=np.float64)
    lo, hi = v.min(axis=0), v.max(axis=0)
    lmax = float(np.max(hi - lo))
    if not lmax > 0.0:
        raise RefsoftError("the object's bounding box is a point: no cube can hold it")
    return 0.5 * (lo + hi), 0.5 * lmax * resolution / (resolution - 2)


def face_coords(q, f: int):
    """Face ``f``'s ``(sc, tc)`` of cube coordinates ``q`` (..., 3), by the GL cube-map table."""
    sa, ss, ta, ts = C.FACE_TABLE[f]
    q = np.asarray(q)
    return ss * q[..., sa], ts * q[..., ta]


def face_clip(q, f: int) -> np.ndarray:
    """Clip coordinates ``(sc, tc, -sigma_f q_a, 1)`` (V, 4) float64 of face ``f``'s orthographic
    view: window depth is then ``delta_f`` at the vertices."""
    q = np.asarray(q, dtype=np.float64)
    sc, tc = face_coords(q, f)
    sigma = 1.0 if f % 2 == 0 else -1.0
    return np.ascontiguousarray(np.stack([sc, tc, -sigma * q[:, f // 2], np.ones(len(q))], axis=1))


def is_closed(mesh: Mesh) -> bool:
    """Every edge is shared by exactly two triangles once vertices at the same position are
    welded (as :meth:`Mesh.boundary_edges` welds them: a box with its own vertices per side, or
    a sphere with a seam, is closed). Degenerate edges are ignored."""
    v = mesh.vertices
    extent = float(np.max(v.max(axis=0) - v.min(axis=0))) or 1.0
    _, weld = np.unique(np.round((v - v.min(axis=0)) / (extent * 1e-9)), axis=0, return_inverse=True)
    f = weld.reshape(-1)[mesh.faces.astype(np.int64)]
    e = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    e = e[e[:, 0] != e[:, 1]]
    _, counts = np.unique(e, axis=0, return_counts=True)
    return bool(len(counts) and np.all(counts == 2))


def signed_volume(vertices, faces) -> float:
    """The mesh's signed volume (positive when its triangles wind counter-clockwise seen from
    outside), relative to the bounding box's centre."""
    v = np.asarray(vertices, dtype=np.float64)
    v = v - 0.5 * (v.min(axis=0) + v.max(axis=0))
    f = np.asarray(faces, dtype=np.int64)
    return float(np.sum(np.einsum("ij,ij->i", v[f[:, 0]], np.cross(v[f[:, 1]], v[f[:, 2]]))) / 6.0)


def mirrored(a, f: int):
    """``a[..., r', c']``: face ``f``'s texel grid seen from the opposite face (``f ^ 1``): the X
    and Z pairs mirror the columns, the Y pair the rows (the texel centres coincide)."""
    return a[..., ::-1, :] if f // 2 == 1 else a[..., :, ::-1]


def pair_back_depths(depth, count_raw, is_open: bool, dtype=np.float32):
    """The back depth of every layer (docs/ldt.md, "Back depths"), computed in ``dtype``.

    Along texel (r, c) of face f the crossings are f1 < b1 < ... < fL < bL; the opposite face
    sees them in reverse order, so ``back[f, j] = 1 - depth[f ^ 1, L' - 1 - j]`` at the mirrored
    texel, with ``L'`` the opposite face's count there, for ``j < min(L_f, L')``.

    Returns
    -------
    back : ndarray (6, L, R, R) of ``dtype``
    count : ndarray (6, R, R) uint8
    mismatch : ndarray (6, R, R) bool
    """
    six, L, R, _ = depth.shape
    one = np.dtype(dtype).type(1)
    back = np.full(depth.shape, one, dtype=dtype)
    if is_open:
        return back, count_raw.copy(), np.zeros(count_raw.shape, dtype=bool)
    count = np.empty_like(count_raw)
    mismatch = np.empty(count_raw.shape, dtype=bool)
    for f in range(6):
        g = f ^ 1
        other = mirrored(depth[g], f)                              # (L, R, R) at f's texels
        lo = mirrored(count_raw[g], f).astype(np.int64)             # L'
        own = count_raw[f].astype(np.int64)
        count[f] = np.minimum(own, lo)
        mismatch[f] = own != lo
        for j in range(L):
            ok = j < count[f]
            k = np.clip(lo - 1 - j, 0, L - 1)
            d = np.take_along_axis(other, k[None], axis=0)[0].astype(dtype)
            back[f, j] = np.where(ok, one - d, one)
    return back, count, mismatch


def build_ldt(mesh: Mesh, resolution: int = C.RESOLUTION, max_layers: int = C.MAX_LAYERS) -> LDT:
    """Build the layered depth texture of a model-space mesh.

    Closed meshes (:func:`is_closed`; winding reversed when the signed volume is < 0) are peeled
    face by face with only the triangles facing the view drawn: clockwise in window space (GL
    ``glFrontFace(GL_CW); glCullFace(GL_BACK)``, the views being mirrored), layer 1 the LESS
    pass, layer l > 1 the fragments strictly behind layer l - 1 (``peel_depth``), until a layer
    is empty or ``max_layers`` are kept. Open meshes get one layer of both windings.

    Parameters
    ----------
    mesh : Mesh
        The object's model-space mesh.
    resolution : int
        R, texels per face edge (a power of two keeps mirrored texel centres bit-identical).
    max_layers : int
        1 .. MAX_LAYERS (1: the convex assumption).

    Returns
    -------
    LDT
    """
    if not isinstance(mesh, Mesh):
        raise RefsoftError(f"mesh must be a refsoft.Mesh, got {type(mesh).__name__}")
    R = check_resolution(resolution)
    if not (isinstance(max_layers, (int, np.integer)) and 1 <= max_layers <= C.MAX_LAYERS):
        raise RefsoftError(f"max_layers must be an integer in [1, {C.MAX_LAYERS}], got {max_layers!r}")
    centre, half = cube_of(mesh.vertices, R)
    q = (mesh.vertices - centre) / half
    closed = is_closed(mesh)
    faces = mesh.faces
    if closed and signed_volume(mesh.vertices, faces) < 0:
        faces = np.ascontiguousarray(faces[:, [0, 2, 1]])
    cull = "cw" if closed else None
    keep = max_layers if closed else 1
    layers, capped = [], False
    for f in range(6):
        clip = face_clip(q, f)
        got, prev = [], None
        while True:
            frags = raster.rasterize(clip, faces, R, R, peel_depth=None if prev is None else prev.depth, cull=cull)
            if not frags.mask.any():
                break
            if len(got) == keep:
                capped = capped or closed  # an open mesh has one layer by definition
                break
            normal = raster.interpolate(frags, mesh.normals, faces, np.float32, normalize=True)
            got.append((frags.depth, normal, frags.triangle))
            prev = frags
            if not closed:
                break
        layers.append(got)
    L = max(1, max(len(g) for g in layers))
    depth = np.ones((6, L, R, R), dtype=np.float32)
    normal = np.zeros((6, L, R, R, 3), dtype=np.float32)
    triangle = np.full((6, L, R, R), -1, dtype=np.int32)
    count_raw = np.zeros((6, R, R), dtype=np.uint8)
    for f, got in enumerate(layers):
        for j, (d, n, t) in enumerate(got):
            depth[f, j], normal[f, j], triangle[f, j] = d, n, t
            count_raw[f] += (t >= 0).astype(np.uint8)
    back, count, mismatch = pair_back_depths(depth, count_raw, not closed)
    return LDT(depth, back, normal, triangle, count_raw, count, mismatch, centre, half, not closed, capped)
