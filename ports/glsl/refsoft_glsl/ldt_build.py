"""The layered depth textures' build (refsoft's ``docs/ldt.md``, "The build") on llvmpipe, by
depth peeling through the exact raster (``raster.py``): the textures of ``ldt_J.npz``.

:func:`build_textures` builds one object's textures from its model-space mesh
(``model_J.ply`` of a case's inputs), once per case (:class:`refsoft_glsl.ldt.LdtPipeline`).

Once per object: the cube around the mesh (the centre of its bounding box, half side
``0.5 Lmax R / (R - 2)``), the points ``q = (p - c) / half`` on the host in float64, and per face
an orthographic matrix with one ``+-1`` per row, so the raster's transform gives refsoft's clip
coordinates ``(sc, tc, -sigma q_a, 1)`` bit for bit. A closed mesh (every welded edge shared by
two triangles; its winding reversed when its signed volume is negative) is peeled with only its
clockwise triangles drawn (``cull`` 1 in ``emit.comp``), each layer strictly behind the one
before (``raster.frag``'s peel test) until a layer is empty or the limit is reached; an open mesh
gets one layer of both windings. Normals are interpolated by ``interp.comp`` (mode 0, float32,
renormalised); the back depths are paired on the host (``1 - d`` in float32).
"""

from __future__ import annotations

import ctypes

import numpy as np

from .raster import Raster, params_array

#: Layers a closed mesh is peeled to at most (refsoft's ``MAX_LAYERS``).
MAX_LAYERS = 8
#: Per face: (axis, sign) of ``sc`` and of ``tc`` (the GL cube-map table, as refsoft's).
FACE_TABLE = ((2, -1, 1, -1), (2, 1, 1, -1), (0, 1, 2, 1), (0, 1, 2, -1), (0, 1, 1, -1), (0, -1, 1, -1))


class PeelRaster(Raster):
    """A :class:`~refsoft_glsl.raster.Raster` whose framebuffer also keeps each pixel's float32
    window depth (colour attachment 1, 1.0 where nothing is drawn)."""

    def __init__(self, gl, width, height):
        self.gl = gl
        self.width, self.height = int(width), int(height)
        ctx = gl.ctx
        self.index = ctx.texture((self.width, self.height), 1, dtype="i4")
        self.depth = ctx.texture((self.width, self.height), 1, dtype="f4")
        self.fbo, self._release = gl.depth_framebuffer([self.index, self.depth], (self.width, self.height))
        self.vao = ctx.vertex_array(gl.program("raster"), [])

    def draw(self, setup, peel=None):
        one = (ctypes.c_float * 1)(1.0)
        self.gl._clear_tex_image(self.depth.glo, 0, 0x1903, 0x1406, ctypes.cast(one, ctypes.c_void_p))  # RED, FLOAT
        super().draw(setup, peel)

    def read(self, setup):
        """``(depth (H, W) float32, clip triangle (H, W) int32, -1 none)``, rows from the top."""
        h, w = self.height, self.width
        depth = np.frombuffer(self.depth.read(), np.float32).reshape(h, w)[::-1]
        index = np.frombuffer(self.index.read(), np.int32).reshape(h, w)[::-1] - 1
        return np.ascontiguousarray(depth), np.ascontiguousarray(index)


def cube_of(vertices, resolution):
    """The cube's centre (3,) float64 and half side, as refsoft's ``ldt.build.cube_of``."""
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    lmax = float(np.max(hi - lo))
    if not lmax > 0.0:
        raise ValueError("the object's bounding box is a point: no cube can hold it")
    return 0.5 * (lo + hi), 0.5 * lmax * resolution / (resolution - 2)


def is_closed(vertices, faces) -> bool:
    """Every edge shared by exactly two triangles once vertices at the same position (to 1e-9 of
    the extent) are welded; degenerate edges ignored (refsoft's ``ldt.build.is_closed``)."""
    extent = float(np.max(vertices.max(axis=0) - vertices.min(axis=0))) or 1.0
    _, weld = np.unique(np.round((vertices - vertices.min(axis=0)) / (extent * 1e-9)), axis=0, return_inverse=True)
    f = weld.reshape(-1)[faces.astype(np.int64)]
    e = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    e = e[e[:, 0] != e[:, 1]]
    _, counts = np.unique(e, axis=0, return_counts=True)
    return bool(len(counts) and np.all(counts == 2))


def signed_volume(vertices, faces) -> float:
    """The signed volume about the bounding box's centre (only its sign is used)."""
    v = vertices - 0.5 * (vertices.min(axis=0) + vertices.max(axis=0))
    f = faces.astype(np.int64)
    return float(np.sum(np.einsum("ij,ij->i", v[f[:, 0]], np.cross(v[f[:, 1]], v[f[:, 2]]))) / 6.0)


def face_matrix(face: int) -> np.ndarray:
    """Face ``face``'s orthographic 4x4 matrix: ``(sc, tc, -sigma q_a, 1)`` of ``q``."""
    sa, ss, ta, ts = FACE_TABLE[face]
    m = np.zeros((4, 4))
    m[0, sa], m[1, ta] = ss, ts
    m[2, face // 2] = -1.0 if face % 2 == 0 else 1.0
    m[3, 3] = 1.0
    return m


def _mirrored(a, f):
    return a[..., ::-1, :] if f // 2 == 1 else a[..., :, ::-1]


def pair_back_depths(depth, count_raw, is_open, dtype=np.float32):
    """``back``, ``count`` and ``mismatch`` (refsoft's ``ldt.build.pair_back_depths``), ``back``
    computed in ``dtype``."""
    L = depth.shape[1]
    one = np.dtype(dtype).type(1)
    back = np.full(depth.shape, one, dtype=dtype)
    if is_open:
        return back, count_raw.copy(), np.zeros(count_raw.shape, dtype=bool)
    count = np.empty_like(count_raw)
    mismatch = np.empty(count_raw.shape, dtype=bool)
    for f in range(6):
        other = _mirrored(depth[f ^ 1], f)
        lo = _mirrored(count_raw[f ^ 1], f).astype(np.int64)
        own = count_raw[f].astype(np.int64)
        count[f] = np.minimum(own, lo)
        mismatch[f] = own != lo
        for j in range(L):
            k = np.clip(lo - 1 - j, 0, L - 1)
            d = np.take_along_axis(other, k[None], axis=0)[0].astype(dtype)
            back[f, j] = np.where(j < count[f], one - d, one)
    return back, count, mismatch


def build_textures(gl, mesh, resolution: int, max_layers: int = MAX_LAYERS) -> dict:
    """One object's layered depth texture: the arrays of ``ldt_J.npz``.

    Parameters
    ----------
    gl : refsoft_glsl.context.GL
    mesh : refsoft_glsl.inputs.Mesh
        The object's model-space mesh.
    resolution : int
    max_layers : int

    Returns
    -------
    dict
        ``depth``, ``back`` (6, L, R, R) float32, ``normal`` (6, L, R, R, 3) float32,
        ``triangle`` (6, L, R, R) int32, ``count_raw``, ``count`` (6, R, R) uint8, ``mismatch``
        (6, R, R) bool, ``cube_center`` (3,) float64, ``cube_half``, ``open``, ``layers_capped``.
    """
    from .pipeline import MeshData

    R = int(resolution)
    centre, half = cube_of(mesh.vertices, R)
    q = (mesh.vertices - centre) / half
    closed = is_closed(mesh.vertices, mesh.faces)
    faces = mesh.faces
    if closed and signed_volume(mesh.vertices, faces) < 0:
        faces = np.ascontiguousarray(faces[:, [0, 2, 1]])
    keep = max_layers if closed else 1
    data = MeshData(gl, q, mesh.normals, faces, np.zeros(len(faces), np.int32), np.zeros(len(q), np.int32))
    r = PeelRaster(gl, R, R)
    layers, capped = [], False
    for f in range(6):
        params = gl.buffer(params_array(face_matrix(f), R, R))
        got, peel = [], None
        while True:
            s = r.setup(data.points, data.n_vertices, data.faces, data.n_faces, params, cull=1 if closed else 0)
            r.draw(s, peel)
            depth, clip_tri = r.read(s)
            if not (clip_tri >= 0).any():
                break
            if len(got) == keep:
                capped = capped or closed
                break
            P, N, M = gl.buffer(nbytes=R * R * 12), gl.buffer(nbytes=R * R * 12), gl.buffer(nbytes=R * R * 4)
            r.bind_setup(s)
            gl.run(gl.compute("interp", MODE=0, DOUBLE=0), R * R,
                   [None, None, None, None, None, data.faces, data.points, data.normals, params, None, None, None,
                    P, N, M], width=R, height=R, region=(0, R, 0, R))
            info = gl.read(s["tri_info"], np.int32, (s.n, 4))
            triangle = np.where(clip_tri >= 0, info[np.maximum(clip_tri, 0), 0], -1).astype(np.int32)
            got.append((depth, gl.read(N, np.float32, (R, R, 3)), triangle))
            peel = gl.buffer(depth)
            if not closed:
                break
        layers.append(got)
    r.release()
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
    return dict(depth=depth, back=back, normal=normal, triangle=triangle, count_raw=count_raw, count=count,
                mismatch=mismatch, cube_center=np.asarray(centre, np.float64), cube_half=np.float64(half),
                open=np.bool_(not closed), layers_capped=np.bool_(capped))
