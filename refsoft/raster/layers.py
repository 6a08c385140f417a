"""The two nearest fragments of every pixel, and the G-buffer's depth margin (spec section 8).

Where a closed reflector's front and back triangles meet (a sphere's silhouette), or where two
triangles overlap, the depth test decides between fragments of nearly equal depth. A GPU
evaluates depth planes its own way and may keep the other fragment there. The *depth margin*
of a pixel is the next fragment's window depth minus the winning fragment's (float32, >= 0; 0
at an exact tie that the first drawn triangle won; +inf where fewer than two fragments cover the
pixel). ``refsoft golden`` saves it per reflector (``gbuffer_depth_margin_K``), and ``refsoft
check`` accepts a port's G-buffer position and normal that match either fragment where the
margin is at most ``DEPTH_TIE_K * TIE_EPS`` (:mod:`refsoft.constants`).

The winning fragment is, bit for bit, :func:`refsoft.raster.rasterize`'s: same setup, same
coverage, same depth arithmetic.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import constants
from .._parallel import parallel_range
from ..errors import RefsoftError
from ..scene.camera import check_image_size
from . import CULL_MODES, _dtype, _CONVERT, _check_faces, _check_mesh, _kernels, _layers, _setup, coverage_region


@dataclass(frozen=True, eq=False)
class DepthLayers:
    """The two nearest fragments of each pixel of a region (see :func:`depth_layers`).

    Attributes
    ----------
    depth, second_depth : ndarray, shape (h, w), float32
        Window depth of the winning fragment (1.0 where none) and of the nearest other one
        (+inf where none).
    index, second_index : ndarray, shape (h, w), int32
        Their clip triangles (-1 where none).
    triangle, second_triangle : ndarray, shape (h, w), int32
        Their input triangles (-1 where none).
    setup : dict
        The clip triangles, as :attr:`refsoft.raster.Fragments.setup`.
    origin : (int, int)
        (row, col) of the region's first pixel in the viewport.
    """

    depth: np.ndarray
    index: np.ndarray
    triangle: np.ndarray
    second_depth: np.ndarray
    second_index: np.ndarray
    second_triangle: np.ndarray
    setup: dict
    origin: tuple

    @property
    def margin(self) -> np.ndarray:
        """``second_depth - depth`` (float32) where a fragment wins, +inf elsewhere."""
        m = np.full(self.depth.shape, np.inf, dtype=np.float32)
        won = self.index >= 0
        m[won] = self.second_depth[won] - self.depth[won]
        return m


def depth_layers(clip, faces, width: int, height: int, region=None) -> DepthLayers:
    """Rasterize like :func:`refsoft.raster.rasterize` (no peeling), keeping the two nearest
    fragments of each pixel.

    Parameters
    ----------
    clip : array_like, shape (V, 4), float64
    faces : array_like, shape (F, 3), integer
    width, height : int
    region : (int, int, int, int), optional
        ``(row0, row1, col0, col1)`` of the viewport (default: all of it).

    Returns
    -------
    DepthLayers
    """
    width, height = check_image_size(width, height, "viewport")
    clip = np.ascontiguousarray(clip, dtype=np.float64)
    if clip.ndim != 2 or clip.shape[1] != 4 or not np.all(np.isfinite(clip)):
        raise RefsoftError(f"clip coordinates must be finite, of shape (V, 4), got {clip.shape}")
    faces = _check_faces(faces, len(clip))
    r0, r1, c0, c1 = (0, height, 0, width) if region is None else (int(x) for x in region)
    if not (0 <= r0 < r1 <= height and 0 <= c0 < c1 <= width):
        raise RefsoftError(f"region {region!r} is empty or outside the {width}x{height} viewport")
    bad = (clip[:, 3] <= 0) & (clip[:, 2] + clip[:, 3] >= 0)
    if bad.any():
        raise RefsoftError(f"clip vertex {int(np.argmax(bad))} has w <= 0 inside the near plane")
    # the triangle setup of rasterize(), the same calls
    X, Y, Z, IW, slot, B, tri, valid, bbox, area, bias = _setup.setup_region(
        clip, faces, width, height, r0, r1, c0, c1, CULL_MODES[None], constants.GUARD_BAND_PIXELS)
    tile = constants.TILE_SIZE
    rh, rw = r1 - r0, c1 - c0
    tiles_x, tiles_y = -(-rw // tile), -(-rh // tile)
    starts, items = _kernels.bin_triangles(valid, bbox, tile, tiles_x, tiles_y, r0, c0)
    depth = np.full((rh, rw), constants.DEPTH_CLEAR, dtype=np.float32)
    index = np.full((rh, rw), -1, dtype=np.int32)
    depth2 = np.full((rh, rw), np.inf, dtype=np.float32)
    index2 = np.full((rh, rw), -1, dtype=np.int32)
    parallel_range(_layers.raster_two_tiles, tiles_x * tiles_y, starts, items, X, Y, Z, tri, bbox, area, bias, height,
                   tile, tiles_x, r0, c0, depth, index, depth2, index2)
    none = index < 0  # a fragment at depth 1 that no other beat: no winner, so no second either
    depth2[none] = np.inf
    index2[none] = -1
    setup = {"X": X, "Y": Y, "Z": Z, "IW": IW, "slot": slot, "B": B, "tri": tri}
    return DepthLayers(depth, index, np.where(index >= 0, tri[np.maximum(index, 0)], -1).astype(np.int32),
                       depth2, index2, np.where(index2 >= 0, tri[np.maximum(index2, 0)], -1).astype(np.int32),
                       setup, (r0, c0))


@dataclass(frozen=True, eq=False)
class SecondFragment:
    """A G-buffer's depth margin and its second fragment, full size (see :func:`gbuffer_layers`).

    Attributes
    ----------
    margin : ndarray, shape (H, W), float32
        Next fragment's depth minus the winner's; +inf where fewer than two fragments.
    triangle : ndarray, shape (H, W), int32
        The next fragment's triangle (-1 where none).
    position, normal : ndarray, shape (H, W, 3), the G-buffer's precision
        The next fragment's interpolated position (relative to ``origin``) and renormalised
        normal, with the G-buffer's arithmetic (zero where none).
    first_triangle : ndarray, shape (H, W), int32
        The winner's triangle (the G-buffer's own; -1 where none).
    """

    margin: np.ndarray
    triangle: np.ndarray
    position: np.ndarray
    normal: np.ndarray
    first_triangle: np.ndarray


def gbuffer_layers(mesh, view_proj, width: int, height: int, precision="float32", origin=None) -> SecondFragment:
    """The depth margin and the second fragment of the G-buffer :func:`refsoft.raster.gbuffer`
    renders of ``mesh`` with a camera of this view-projection matrix and size.

    Parameters
    ----------
    mesh : Mesh
        World-space mesh (the reflector's closed proxy).
    view_proj : array_like, shape (4, 4), float64
        The G-buffer's ``view_proj``.
    width, height : int
    precision : {"float32", "float64"}
    origin : array_like, shape (3,), optional
        As :func:`refsoft.raster.gbuffer`'s (positions relative to it).

    Returns
    -------
    SecondFragment
    """
    _check_mesh(mesh)
    dt = _dtype(precision)
    W, H = check_image_size(width, height, "viewport")
    vp = np.asarray(view_proj, dtype=np.float64)
    if vp.shape != (4, 4) or not np.all(np.isfinite(vp)):
        raise RefsoftError(f"view_proj must be a finite 4x4 matrix, got shape {vp.shape}")
    o = np.zeros(3) if origin is None else np.asarray(origin, dtype=np.float64)
    if o.shape != (3,) or not np.all(np.isfinite(o)):
        raise RefsoftError(f"origin must be 3 finite numbers, got {origin!r}")
    clip = _setup.transform_points(mesh.vertices, np.ascontiguousarray(vp))
    margin = np.full((H, W), np.inf, dtype=np.float32)
    tri2 = np.full((H, W), -1, dtype=np.int32)
    tri1 = np.full((H, W), -1, dtype=np.int32)
    pos = np.zeros((H, W, 3), dtype=dt)
    nrm = np.zeros((H, W, 3), dtype=dt)
    region = coverage_region(clip, W, H)  # the G-buffer's own crop: the same pixels, bit for bit
    if region == ():
        return SecondFragment(margin, tri2, pos, nrm, tri1)
    lay = depth_layers(clip, mesh.faces, W, H, region)
    r0, c0 = lay.origin
    h, w = lay.depth.shape
    s = lay.setup
    # the second fragment's attributes with the G-buffer's own interpolation kernel
    pos_r = np.zeros((h, w, 3), dtype=dt)
    nrm_r = np.zeros((h, w, 3), dtype=dt)
    parallel_range(_kernels.interpolate_pair, h, lay.second_index, s["X"], s["Y"], s["IW"].astype(dt), s["slot"],
                   s["B"].astype(dt), s["tri"], mesh.faces, np.ascontiguousarray(mesh.vertices - o, dtype=dt),
                   np.ascontiguousarray(mesh.normals, dtype=dt), H, r0, c0, _CONVERT[dt], pos_r, nrm_r)
    pos[r0:r0 + h, c0:c0 + w] = pos_r
    nrm[r0:r0 + h, c0:c0 + w] = nrm_r
    margin[r0:r0 + h, c0:c0 + w] = lay.margin
    tri2[r0:r0 + h, c0:c0 + w] = lay.second_triangle
    tri1[r0:r0 + h, c0:c0 + w] = lay.triangle
    return SecondFragment(margin, tri2, pos, nrm, tri1)
