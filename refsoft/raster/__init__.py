"""The exact CPU rasterizer (spec section 2), in two stages like a GPU pipeline:

1. :func:`rasterize` — clip-space triangles to a visibility buffer: per pixel the window depth
   and the visible triangle (LESS depth test, first drawn wins ties);
2. :func:`interpolate` — perspective-correct attributes of the visible triangle at each pixel.

On top of these, :func:`gbuffer` renders one reflector's position and normal maps, and
:func:`color_pass` renders the shaded main view with object ids (:func:`shade_fragments`: normals
interpolated and shaded in one pass); :func:`gbuffer_layers` gives a G-buffer's second-nearest
fragment and depth margin (:mod:`refsoft.raster.layers`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import constants, limits
from .._numba import readonly
from .._parallel import parallel_range
from ..scene.camera import Camera, check_image_size
from ..errors import RefsoftError
from ..scene.mesh import Mesh, concatenate
from . import _kernels, _setup, _shading
from ._threads import SERIAL_MAX_TRIANGLES, one_thread

__all__ = ["Fragments", "GBuffer", "ColorPass", "rasterize", "interpolate", "gbuffer", "color_pass", "coverage_region",
           "shade_fragments",
           "to_uint8", "PRECISIONS", "DepthLayers", "SecondFragment", "depth_layers", "gbuffer_layers"]

#: Accepted precision names and their dtypes.
PRECISIONS = {"float32": np.float32, "float64": np.float64}
#: The kernels' precision is chosen by a prototype scalar of that type.
_CONVERT = {np.float32: np.float32(0), np.float64: np.float64(0)}


def _dtype(precision) -> type:
    key = precision if isinstance(precision, str) else np.dtype(precision).name
    if key not in PRECISIONS:
        raise RefsoftError(f"precision must be 'float32' or 'float64', got {precision!r}")
    return PRECISIONS[key]


@dataclass(frozen=True, eq=False)
class Fragments:
    """Visibility buffer made by :func:`rasterize`.

    Attributes
    ----------
    depth : ndarray, shape (H, W), float32
        Window depth of the visible fragment; 1.0 where nothing is drawn.
    triangle : ndarray, shape (H, W), int32
        Index of the visible input triangle; -1 where nothing is drawn.
    index : ndarray, shape (H, W), int32
        Index of the visible *clip triangle* (internal; used by :func:`interpolate`).
    origin : (int, int)
        (row, col) of the first pixel of the rasterized region in the viewport ((0, 0) for the
        whole viewport); the maps above cover that region only.
    setup : dict of ndarray
        Clip-triangle data: snapped ``X``, ``Y`` (T, 3) int32, ``Z``, ``IW`` (T, 3) float64,
        ``slot`` (T,) int32 row of ``B`` (K, 3, 3) float64, the clip vertices' barycentrics
        w.r.t. the input triangle (-1: unclipped, identity; -2: unclipped, vertices 1 and 2
        swapped), ``tri`` (T,) int32.
    n_faces : int
        Number of input triangles.
    """

    depth: np.ndarray
    triangle: np.ndarray
    index: np.ndarray
    setup: dict
    n_faces: int
    height: int = 0
    origin: tuple = (0, 0)

    @property
    def mask(self) -> np.ndarray:
        """Coverage, shape (H, W), bool."""
        return self.triangle >= 0

    @property
    def shape(self) -> tuple[int, int]:
        return self.depth.shape


def _check_faces(faces, n_vertices: int) -> np.ndarray:
    f = np.asarray(faces)
    if f.ndim != 2 or f.shape[1] != 3 or not np.issubdtype(f.dtype, np.integer):
        raise RefsoftError(f"faces must be an integer array of shape (F, 3), got {f.dtype} {f.shape}")
    if len(f) and (f.min() < 0 or f.max() >= n_vertices):
        raise RefsoftError(f"face indices must be in [0, {n_vertices - 1}], got [{int(f.min())}, {int(f.max())}]")
    # read-only like a Mesh's faces, whoever made them: the kernels are compiled for one array type
    return readonly(np.ascontiguousarray(f, dtype=np.int32))


#: ``rasterize``'s cull choices -> the kernels' code.
CULL_MODES = {None: 0, "cw": 1, "ccw": 2}


def rasterize(clip, faces, width: int, height: int, peel_depth=None, region=None, cull=None) -> Fragments:
    """Rasterize clip-space triangles with OpenGL's rules (spec section 2).

    Parameters
    ----------
    clip : array_like, shape (V, 4), float64
        Clip coordinates of the vertices (``view_proj @ [p, 1]``).
    faces : array_like, shape (F, 3), integer
        Triangles, drawn in index order; both windings are drawn unless ``cull`` says otherwise.
    width, height : int
        Viewport size in pixels.
    peel_depth : array_like, shape (H, W), float32, optional
        Depth peeling: keep only fragments strictly behind this depth (the previous layer).
        With ``region``, shape (row1 - row0, col1 - col0).
    region : (int, int, int, int), optional
        ``(row0, row1, col0, col1)``: rasterize only these rows and columns of the viewport
        (half-open). The result equals the whole viewport's, cropped; it is faster when the
        region is small (e.g. a reflector's stencil).
    cull : {None, "cw", "ccw"}
        Face culling on the snapped window coordinates (exact integer arithmetic, y up): ``"cw"``
        draws only triangles whose signed area is < 0 (clockwise; GL ``glFrontFace(GL_CW);
        glCullFace(GL_BACK)``), ``"ccw"`` only those > 0; None draws both windings. A clipped
        triangle is judged piece by piece, as GL judges the clipped polygon.

    Returns
    -------
    Fragments
    """
    width, height = check_image_size(width, height, "viewport")
    if cull not in CULL_MODES:
        raise RefsoftError(f"cull must be None, 'cw' or 'ccw', got {cull!r}")
    clip = np.asarray(clip, dtype=np.float64)
    if clip.ndim != 2 or clip.shape[1] != 4:
        raise RefsoftError(f"clip coordinates must have shape (V, 4), got {clip.shape}")
    if not np.all(np.isfinite(clip)):
        raise RefsoftError("clip coordinates are not finite")
    clip = np.ascontiguousarray(clip)
    faces = _check_faces(faces, len(clip))
    if region is None:
        region = (0, height, 0, width)
    try:
        r0, r1, c0, c1 = (int(x) for x in region)
    except (TypeError, ValueError):
        raise RefsoftError(f"region must be (row0, row1, col0, col1), got {region!r}") from None
    if not (0 <= r0 < r1 <= height and 0 <= c0 < c1 <= width):
        raise RefsoftError(f"region {region!r} is empty or outside the {width}x{height} viewport")
    rh, rw = r1 - r0, c1 - c0
    peel = None
    if peel_depth is not None:
        peel = np.ascontiguousarray(peel_depth, dtype=np.float32)
        if peel.shape != (rh, rw):
            raise RefsoftError(f"peel_depth must have shape {(rh, rw)}, got {peel.shape}")
    bad = (clip[:, 3] <= 0) & (clip[:, 2] + clip[:, 3] >= 0)
    if bad.any():
        raise RefsoftError(f"clip vertex {int(np.argmax(bad))} has w <= 0 inside the near plane: the "
                           "projection must give w > 0 in front of the near plane")
    return rasterize_trusted(clip, faces, width, height, (r0, r1, c0, c1), peel, CULL_MODES[cull])


def rasterize_trusted(clip, faces, width, height, region, peel, cull_code) -> Fragments:
    """:func:`rasterize` of inputs it has already checked, for callers that made them so: ``clip``
    (V, 4) float64 C-contiguous and finite, every w > 0 inside the near plane; ``faces`` (F, 3)
    int32 read-only, in ``[0, V)``; ``region`` (r0, r1, c0, c1) Python ints inside the viewport;
    ``peel`` (h, w) float32 or None; ``cull_code`` :data:`CULL_MODES`' value."""
    r0, r1, c0, c1 = region
    rh, rw = r1 - r0, c1 - c0
    use_peel = peel is not None
    if not use_peel:
        peel = np.zeros((1, 1), dtype=np.float32)
    tile = constants.TILE_SIZE
    tiles_x, tiles_y = -(-rw // tile), -(-rh // tile)
    small = len(faces) <= SERIAL_MAX_TRIANGLES  # the per-triangle front end on this thread (_threads)
    X, Y, Z, IW, slot, B, tri, valid, bbox, area, bias = _setup.setup_region(
        clip, faces, width, height, r0, r1, c0, c1, cull_code, constants.GUARD_BAND_PIXELS, small)
    starts, items = _kernels.bin_triangles(valid, bbox, tile, tiles_x, tiles_y, r0, c0, serial=small)
    depth, index, triangle = limits.maps((rh, rw), np.float32, np.int32, np.int32)
    depth.fill(constants.DEPTH_CLEAR)
    index.fill(-1)
    triangle.fill(-1)
    parallel_range(_kernels.raster_tiles, tiles_x * tiles_y, starts, items, X, Y, Z, tri, bbox, area, bias, width,
                   height, tile, tiles_x, r0, c0, depth, index, triangle, peel, use_peel)
    setup = {"X": X, "Y": Y, "Z": Z, "IW": IW, "slot": slot, "B": B, "tri": tri}
    return Fragments(depth, triangle, index, setup, len(faces), height, (r0, c0))


def interpolate(fragments: Fragments, attributes, faces, precision="float32", normalize=False) -> np.ndarray:
    """Perspective-correct per-pixel attributes (GL ``smooth``) of the visible triangles.

    Parameters
    ----------
    fragments : Fragments
        From :func:`rasterize` with the same ``faces``.
    attributes : array_like, shape (V, C)
        Per-vertex attributes.
    faces : array_like, shape (F, 3), integer
    precision : {"float32", "float64"}
        Arithmetic and output precision.
    normalize : bool
        Renormalise the interpolated vector per pixel (normals); zero stays zero.

    Returns
    -------
    ndarray, shape (H, W, C), float32 or float64
        Zero where nothing is drawn.
    """
    dt = _dtype(precision)
    attr = np.asarray(attributes)
    if attr.ndim != 2 or len(attr) == 0:
        raise RefsoftError(f"attributes must have shape (V, C), got {attr.shape}")
    attr = np.ascontiguousarray(attr, dtype=dt)
    faces = _check_faces(faces, len(attr))
    if len(faces) != fragments.n_faces:
        raise RefsoftError(f"faces ({len(faces)}) do not match the rasterized triangles ({fragments.n_faces})")
    s = fragments.setup
    h, w = fragments.shape
    out = np.zeros((h, w, attr.shape[1]), dtype=dt)
    r0, c0 = fragments.origin
    parallel_range(_kernels.interpolate_rows, h, fragments.index, s["X"], s["Y"], s["IW"].astype(dt), s["slot"],
                   s["B"].astype(dt), s["tri"], faces, attr, fragments.height, r0, c0, bool(normalize), _CONVERT[dt], out,
                   work=lambda: (np.empty(attr.shape[1], dtype=dt),))
    return out


class GBuffer:
    """One reflector's G-buffer (Estalella section 3.1).

    Attributes
    ----------
    position : ndarray, shape (H, W, 3), float32 or float64
        World-space position (relative to ``origin``); zero where not covered.
    normal : ndarray, shape (H, W, 3), float32 or float64
        Interpolated vertex normal, renormalised; zero where not covered.
    mask : ndarray, shape (H, W), bool
        Coverage.
    depth : ndarray, shape (H, W), float32
        Window depth; 1.0 where not covered.
    triangle : ndarray, shape (H, W), int32
        Visible triangle of the mesh; -1 where not covered.
    view_proj : ndarray, shape (4, 4), float64
        The camera's world-to-clip matrix.
    origin : ndarray, shape (3,), float64
        Positions are ``world - origin`` (zero for world space).

    ``depth`` and ``triangle`` may be given as ``(r0, c0, crop)``: the crop's values at
    ``[r0:, c0:]``, the clear value elsewhere, made full size on first use (only ``refsoft
    gbuffer`` and the tests read them; filling two full-size maps per reflector and frame cost
    about 3 ms at 1024x768).
    """

    __slots__ = ("position", "normal", "mask", "_depth", "_triangle", "view_proj", "origin")

    def __init__(self, position, normal, mask, depth, triangle, view_proj, origin):
        self.position = position
        self.normal = normal
        self.mask = mask
        self._depth = depth
        self._triangle = triangle
        self.view_proj = view_proj
        self.origin = origin

    def _full(self, name, clear, dtype):
        value = getattr(self, name)
        if isinstance(value, tuple):
            r0, c0, crop = value
            full = np.full(self.mask.shape, clear, dtype=dtype)
            full[r0:r0 + crop.shape[0], c0:c0 + crop.shape[1]] = crop
            setattr(self, name, full)
            value = full
        return value

    @property
    def depth(self) -> np.ndarray:
        return self._full("_depth", constants.DEPTH_CLEAR, np.float32)

    @property
    def triangle(self) -> np.ndarray:
        return self._full("_triangle", -1, np.int32)


def _check_camera(camera):
    if not isinstance(camera, Camera):
        raise RefsoftError(f"camera must be a refsoft.Camera, got {type(camera).__name__}")


def _check_mesh(mesh):
    if not isinstance(mesh, Mesh):
        raise RefsoftError(f"mesh must be a refsoft.Mesh, got {type(mesh).__name__}")


def coverage_region(clip, width: int, height: int):
    """A region ``(r0, r1, c0, c1)`` outside which no triangle of these clip vertices can cover a
    pixel: the projected vertices' bounding box plus one pixel (snapping moves a vertex by at
    most 1/512 px). ``None`` when a vertex is not strictly in front of the near plane or lies
    beyond the guard band (clipping may then move vertices: rasterize everything), ``()`` when
    the box misses the viewport.
    """
    w = clip[:, 3]
    if len(clip) == 0 or np.any(w <= 0) or np.any(clip[:, 2] + w <= 0):
        return None
    x = (clip[:, 0] / w + 1.0) * (0.5 * width)
    y = (clip[:, 1] / w + 1.0) * (0.5 * height)
    g = constants.GUARD_BAND_PIXELS
    if np.any(np.abs(x - 0.5 * width) >= g) or np.any(np.abs(y - 0.5 * height) >= g):
        return None
    # pixel (row, col) has its centre at x = col + 0.5, y = height - row - 0.5
    c0 = max(int(np.floor(x.min() - 1.5)), 0)
    c1 = min(int(np.ceil(x.max() + 0.5)), width)
    r0 = max(int(np.floor(height - y.max() - 1.5)), 0)
    r1 = min(int(np.ceil(height - y.min() + 0.5)), height)
    if r0 >= r1 or c0 >= c1:
        return ()
    return r0, r1, c0, c1


def gbuffer(mesh: Mesh, camera: Camera, precision="float32", origin=None, crop=True) -> GBuffer:
    """Render a mesh's position and normal maps from a camera.

    Parameters
    ----------
    mesh : Mesh
        World-space mesh (the reflector, or its closed proxy).
    camera : Camera
    precision : {"float32", "float64"}
    origin : array_like, shape (3,), optional
        Interpolate positions relative to this point (e.g. the eye) to keep float32 precision
        far from the world origin. Default: the world origin.
    crop : bool
        Rasterize and interpolate only over the mesh's projected box (:func:`coverage_region`);
        the maps are the same, bit for bit, and far cheaper for a small reflector.

    Returns
    -------
    GBuffer
    """
    _check_mesh(mesh)
    _check_camera(camera)
    dt = _dtype(precision)
    o = np.zeros(3) if origin is None else np.asarray(origin, dtype=np.float64)
    if o.shape != (3,) or not np.all(np.isfinite(o)):
        raise RefsoftError(f"origin must be 3 finite numbers, got {origin!r}")
    vp = camera.view_proj()
    clip = _setup.transform_points(mesh.vertices, vp)
    H, W = camera.height, camera.width
    region = coverage_region(clip, W, H) if crop else None
    pos = limits.zeros((H, W, 3), dt)  # only the pages of the covered box are ever touched
    nrm = limits.zeros((H, W, 3), dt)
    if region == ():
        return GBuffer(pos, nrm, np.zeros((H, W), dtype=bool), (0, 0, np.zeros((0, 0), np.float32)),
                       (0, 0, np.zeros((0, 0), np.int32)), vp, o)
    frags = rasterize(clip, mesh.faces, W, H, region=region)
    r0, c0 = frags.origin
    h, w = frags.shape
    # positions and normals share each pixel's barycentrics: one fused pass, same arithmetic
    # as interpolate(..., dt) and interpolate(..., dt, normalize=True)
    pos_r = pos[r0:r0 + h, c0:c0 + w] if region is None else np.zeros((h, w, 3), dtype=dt)
    nrm_r = nrm[r0:r0 + h, c0:c0 + w] if region is None else np.zeros((h, w, 3), dtype=dt)
    s = frags.setup
    parallel_range(_kernels.interpolate_pair, h, frags.index, s["X"], s["Y"], s["IW"].astype(dt), s["slot"],
                   s["B"].astype(dt), s["tri"], mesh.faces, np.ascontiguousarray(mesh.vertices - o, dtype=dt),
                   np.ascontiguousarray(mesh.normals, dtype=dt), H, r0, c0, _CONVERT[dt], pos_r, nrm_r)
    if region is None:
        return GBuffer(pos, nrm, frags.mask, frags.depth, frags.triangle, vp, o)
    pos[r0:r0 + h, c0:c0 + w] = pos_r
    nrm[r0:r0 + h, c0:c0 + w] = nrm_r
    mask = limits.zeros((H, W), bool)
    mask[r0:r0 + h, c0:c0 + w] = frags.mask
    return GBuffer(pos, nrm, mask, (r0, c0, frags.depth), (r0, c0, frags.triangle), vp, o)


def to_uint8(color) -> np.ndarray:
    """8-bit conversion of spec section 5: ``round(clip(c, 0, 1) * 255)``, half to even, in
    float64 (a Numba kernel; equal to ``np.rint(np.clip(c, 0, 1) * 255)`` bit for bit)."""
    c = np.asarray(color)
    if c.dtype not in (np.float32, np.float64):
        c = c.astype(np.float64)
    flat = np.ascontiguousarray(c).reshape(-1)
    out = np.empty(flat.shape, dtype=np.uint8)
    parallel_range(_shading.to_uint8_flat, len(flat), flat, out)
    return out.reshape(c.shape)


@dataclass(frozen=True, eq=False)
class ColorPass:
    """The shaded main view.

    Attributes
    ----------
    color : ndarray, shape (H, W, 3), float32
        Linear colour before 8-bit conversion (background colour where nothing is drawn).
    object_id : ndarray, shape (H, W), int32
        1-based id of the visible object; 0 for the background.
    depth : ndarray, shape (H, W), float32
    triangle : ndarray, shape (H, W), int32
        Triangle index within the visible object; -1 for the background.
    image : ndarray, shape (H, W, 3), uint8
        ``to_uint8(color)``, made when first asked for.
    """

    color: np.ndarray
    object_id: np.ndarray
    depth: np.ndarray
    triangle: np.ndarray

    @property
    def image(self) -> np.ndarray:
        cached = self.__dict__.get("_image")
        if cached is None:
            cached = to_uint8(self.color)
            self.__dict__["_image"] = cached
        return cached


def shade(normals, colors) -> np.ndarray:
    """Simple two-sided shading: ``colour * (AMBIENT + DIFFUSE * |dot(n, L)|)`` (float32).

    Parameters
    ----------
    normals : ndarray, shape (..., 3)
        Unit normals (zero allowed: ambient only).
    colors : ndarray, shape (..., 3)
        Object colours.
    """
    light = constants.LIGHT_DIRECTION.astype(np.float32)
    n = np.asarray(normals, dtype=np.float32)
    lam = np.abs(n[..., 0] * light[0] + n[..., 1] * light[1] + n[..., 2] * light[2])
    k = np.float32(constants.AMBIENT) + np.float32(constants.DIFFUSE) * lam
    return (np.asarray(colors, dtype=np.float32) * k[..., None]).astype(np.float32)


def color_pass(meshes, colors, camera: Camera) -> ColorPass:
    """Render several objects, shaded, with their ids (object ``i`` has id ``i + 1``).

    Parameters
    ----------
    meshes : sequence of Mesh
        World-space meshes, drawn in order (earlier objects win depth ties).
    colors : array_like, shape (len(meshes), 3)
        Colours in [0, 1].
    camera : Camera

    Returns
    -------
    ColorPass
    """
    _check_camera(camera)
    meshes = list(meshes)
    if not meshes:
        raise RefsoftError("color_pass needs at least one mesh")
    for m in meshes:
        _check_mesh(m)
    colors = np.asarray(colors, dtype=np.float64)
    if colors.shape != (len(meshes), 3):
        raise RefsoftError(f"colors must have shape ({len(meshes)}, 3), got {colors.shape}")
    scene = concatenate(meshes)
    with one_thread(len(scene.faces) <= SERIAL_MAX_TRIANGLES):
        clip = _setup.transform_points(scene.vertices, camera.view_proj())
    # checked meshes under a checked camera: finite clip coordinates, w > 0 inside the near
    # plane, face indices in range (below MAX_VERTICES: int32 holds them), so the raster's own
    # types are made once here rather than checked and converted by each public entry point
    faces = readonly(scene.faces.astype(np.int32))
    frags = rasterize_trusted(clip, faces, camera.width, camera.height, (0, camera.height, 0, camera.width), None,
                              CULL_MODES[None])
    table = readonly(np.vstack([constants.BACKGROUND_COLOR, colors]).astype(np.float32))
    color, object_id, local_tri = shade_fragments_trusted(
        frags, readonly(scene.normals.astype(np.float32)), faces, readonly(scene.face_object),
        readonly(scene.face_offsets), table)
    return ColorPass(color, object_id, frags.depth, local_tri)


def shade_fragments(fragments: Fragments, normals, faces, face_object, face_offset, table, stencil=None):
    """The visible fragments shaded (:func:`shade` of the renormalised interpolated normal, as
    ``interpolate(..., np.float32, normalize=True)`` gives it) with their object ids, in one
    pass over the rasterized region (no normal map is made).

    Parameters
    ----------
    fragments : Fragments
        From :func:`rasterize` with the same ``faces``.
    normals : array_like, shape (V, 3)
    faces : array_like, shape (F, 3), integer
    face_object : array_like, shape (F,), int32
        The object id (>= 1) of each triangle.
    face_offset : array_like, shape (M,), int64
        ``face_offset[k - 1]``: the first triangle of object ``k`` (for the local triangle index).
    table : array_like, shape (M + 1, 3), float32
        Row ``k``: object ``k``'s colour; row 0 the colour where nothing is drawn.
    stencil : ndarray, shape (h, w), bool, optional
        Shade only these pixels of the region (the others are as if nothing were drawn).

    Returns
    -------
    color : ndarray, shape (h, w, 3), float32
    object_id : ndarray, shape (h, w), int32
        0 where nothing is drawn.
    local_triangle : ndarray, shape (h, w), int32
        ``triangle - face_offset[object_id - 1]``; -1 where nothing is drawn.
    """
    nrm = readonly(np.ascontiguousarray(normals, dtype=np.float32))
    faces = _check_faces(faces, len(nrm))
    if stencil is not None:
        stencil = readonly(np.ascontiguousarray(stencil, dtype=bool))
    return shade_fragments_trusted(fragments, nrm, faces, readonly(np.ascontiguousarray(face_object, dtype=np.int32)),
                                   readonly(np.ascontiguousarray(face_offset, dtype=np.int64)),
                                   readonly(np.ascontiguousarray(table, dtype=np.float32)), stencil)


def shade_fragments_trusted(fragments: Fragments, normals, faces, face_object, face_offset, table, stencil=None):
    """:func:`shade_fragments` of inputs already in the kernel's types, for callers that made
    them so: ``normals`` (V, 3) float32, ``faces`` (F, 3) int32 in ``[0, V)``, ``face_object``
    (F,) int32, ``face_offset`` (M,) int64, ``table`` (M + 1, 3) float32, ``stencil`` (h, w)
    bool or None; every array C-contiguous and read-only."""
    s = fragments.setup
    h, w = fragments.shape
    r0, c0 = fragments.origin
    use_stencil = stencil is not None
    if not use_stencil:
        stencil = readonly(np.zeros((1, 1), dtype=bool))
    color = np.empty((h, w, 3), dtype=np.float32)
    object_id, local_tri = limits.maps((h, w), np.int32, np.int32)
    parallel_range(_kernels.shade_visible, h, fragments.index, s["X"], s["Y"], s["IW"].astype(np.float32), s["slot"],
                   s["B"].astype(np.float32), s["tri"], faces, normals, face_object, face_offset, table,
                   readonly(constants.LIGHT_DIRECTION.astype(np.float32)), np.float32(constants.AMBIENT),
                   np.float32(constants.DIFFUSE), stencil, use_stencil, fragments.height, r0, c0, color, object_id,
                   local_tri, color.reshape(h * w * 3))
    return color, object_id, local_tri


# the two nearest fragments of each pixel (the G-buffer's depth margin), built on the above
from .layers import DepthLayers, SecondFragment, depth_layers, gbuffer_layers  # noqa: E402
