"""The per-pixel LDT search (docs/ldt.md, "The per-pixel search"): for each reflector pixel, the
ray reflected about the interpolated normal is marched through every object's cube, face by face
and layer by layer, and the nearest hit over the objects is kept.

:class:`Stack` holds the objects' LDTs as one set of arrays (built once), :func:`cube_matrices`
the per-frame world-to-cube matrices, :func:`search` runs the kernel
(:func:`refsoft.ldt._search.search_pixels`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import linalg, validate
from ..errors import RefsoftError
from ..raster import PRECISIONS
from . import constants as C


@dataclass(eq=False)
class Stack:
    """The LDTs of the reflected objects (id order) as arrays over ``K`` objects, each padded to
    the largest layer count ``L`` (depth 1, back 1, normal 0 beyond an object's layers).

    Attributes
    ----------
    ids : ndarray (K,) int32
        Object ids.
    depth : ndarray (K, 6, L, R, R) float32
    back : ndarray (K, 6, L, R, R) float32 or float64
        In the search's precision.
    normal : ndarray (K, 6, L, R, R, 3) float32
    count : ndarray (K, 6, R, R) uint8
    mismatch : ndarray (K, 6, R, R) bool
    open : ndarray (K,) bool
    centre : ndarray (K, 3) float64
    half : ndarray (K,) float64
    """

    ids: np.ndarray
    depth: np.ndarray
    back: np.ndarray
    normal: np.ndarray
    count: np.ndarray
    mismatch: np.ndarray
    open: np.ndarray
    centre: np.ndarray
    half: np.ndarray

    @classmethod
    def of(cls, ldts: dict, precision="float32") -> "Stack":
        """Stack ``{object id: LDT}`` (one resolution) with ``back`` in ``precision``."""
        dt = _dtype(precision)
        ids = sorted(ldts)
        if not ids:
            R, L = 1, 1
        else:
            Rs = {ldts[k].resolution for k in ids}
            if len(Rs) != 1:
                raise RefsoftError(f"the LDTs have different resolutions {sorted(Rs)}")
            R, L = Rs.pop(), max(ldts[k].n_layers for k in ids)
        K = len(ids)
        depth = np.ones((K, 6, L, R, R), np.float32)
        back = np.ones((K, 6, L, R, R), dt)
        normal = np.zeros((K, 6, L, R, R, 3), np.float32)
        for i, k in enumerate(ids):
            ldt = ldts[k]
            n = ldt.n_layers
            depth[i, :, :n] = ldt.depth
            back[i, :, :n] = ldt.back_in(dt)
            normal[i, :, :n] = ldt.normal
        return cls(np.asarray(ids, np.int32), depth, back, normal,
                   np.array([ldts[k].count for k in ids], np.uint8).reshape(K, 6, R, R),
                   np.array([ldts[k].mismatch for k in ids], bool).reshape(K, 6, R, R),
                   np.array([ldts[k].open for k in ids], bool),
                   np.array([ldts[k].cube_center for k in ids], np.float64).reshape(K, 3),
                   np.array([ldts[k].cube_half for k in ids], np.float64))

    @property
    def resolution(self) -> int:
        return self.depth.shape[-1]


@dataclass(eq=False)
class PixelSearch:
    """The search's result per pixel (``n`` pixels, ``K`` objects), in the working precision
    ``fp`` where not said otherwise. "None" entries: -1 for ids, distances and indices, 0 else.

    Attributes
    ----------
    ray : (n, 3) fp
        The reflected direction r.
    distance : (n,) fp
        t of the nearest hit (-1 none); ``hit = P + t r`` is ``hit`` (n, 3) fp (0 none).
    object : (n,) int32
        Index into the stack's ``ids`` (-1 none).
    face, layer : (n,) int8
    texel : (n, 2) int16
        (row, col) in that face.
    residual : (n,) fp
        The accepted residual in texels.
    linear_samples, binary_steps : (n,) int32
        Totals over every object and face searched.
    faces_searched, objects_tested : (n,) int8
        Faces searched; objects whose cube the ray meets and that the regions did not skip (both
        saturating at 127).
    flags : (n,) uint8
        :mod:`refsoft.ldt.constants` bits.
    object_distance : (n, K) fp
        Each object's t (-1 none).
    margin : (n,) fp
        The smallest decisive comparison of the accepted search (|h - z|, |h - d| in depth
        units, texel coordinates' distance from an interior integer in texels); with no hit, of
        every search made (1 when none was).
    """

    ray: np.ndarray
    distance: np.ndarray
    hit: np.ndarray
    object: np.ndarray
    face: np.ndarray
    layer: np.ndarray
    texel: np.ndarray
    residual: np.ndarray
    linear_samples: np.ndarray
    binary_steps: np.ndarray
    faces_searched: np.ndarray
    objects_tested: np.ndarray
    flags: np.ndarray
    object_distance: np.ndarray
    margin: np.ndarray


def _dtype(precision):
    if precision not in PRECISIONS:
        raise RefsoftError(f"precision must be 'float32' or 'float64', got {precision!r}")
    return PRECISIONS[precision]


def check_linear(linear) -> int:
    """``linear`` (a positive step count or ``"texel"``) as the kernel's ``n_lin`` (0: texel)."""
    if linear == "texel":
        return 0
    if not validate.is_integer(linear) or not 1 <= linear <= 1 << 16:
        raise RefsoftError(f"linear must be 'texel' or a step count in [1, 65536], got {linear!r}")
    return int(linear)


def cube_matrices(stack: Stack, transforms: dict) -> np.ndarray:
    """(K, 4, 4) float64: world -> model (``M_k^-1``) -> cube coordinates ``(p - c) / half``."""
    out = np.zeros((len(stack.ids), 4, 4))
    for i, k in enumerate(stack.ids):
        S = np.eye(4)
        S[:3, :3] /= stack.half[i]
        S[:3, 3] = -stack.centre[i] / stack.half[i]
        out[i] = linalg.matmul(S, linalg.inv_affine(transforms[int(k)].matrix()))
    return out


def search(P, N, eye, triangle, region, W, stack: Stack, view_dir=None, linear=C.LINEAR_STEPS, tau=C.TAU,
           faces="three", regions="cone", precision="float32") -> PixelSearch:
    """Search the LDTs from ``n`` reflector pixels.

    Parameters
    ----------
    P, N : array_like (n, 3)
        World position and unit normal at each pixel (converted to ``precision``).
    eye : array_like (3,)
        The camera's eye (perspective: ``I = normalize(P - eye)``).
    triangle : array_like (n,) int
        The reflector triangle at each pixel (row of ``region``).
    region : ndarray (T, K) bool
        The cone test per triangle and object (ignored with ``regions="none"``).
    W : ndarray (K, 4, 4) float64
        :func:`cube_matrices`, rounded to ``precision`` here.
    stack : Stack
        With ``back`` in ``precision``.
    view_dir : array_like (3,), optional
        An orthographic camera's unit view direction (then ``I = view_dir``).
    linear : int or "texel"
    tau : float
    faces : {"three", "entry"}
    regions : {"cone", "none"}
    precision : {"float32", "float64"}

    Returns
    -------
    PixelSearch
    """
    from .._parallel import parallel_range
    from ._search import search_pixels

    dt = _dtype(precision)
    n_lin = check_linear(linear)
    if faces not in C.FACE_MODES:
        raise RefsoftError(f"faces must be one of {C.FACE_MODES}, got {faces!r}")
    if regions not in C.REGION_MODES:
        raise RefsoftError(f"regions must be one of {C.REGION_MODES}, got {regions!r}")
    if not (validate.is_number(tau) and tau >= 0):
        raise RefsoftError(f"tau must be a number >= 0, got {tau!r}")
    if stack.back.dtype != dt:
        raise RefsoftError(f"the stack's back depths are {stack.back.dtype}, the search runs in {precision}")
    P = np.ascontiguousarray(P, dt).reshape(-1, 3)
    N = np.ascontiguousarray(N, dt).reshape(-1, 3)
    n, K = len(P), len(stack.ids)
    tri = np.ascontiguousarray(triangle, np.int64).reshape(-1)
    region = np.ascontiguousarray(region, bool)
    if regions == "cone" and (region.ndim != 2 or region.shape[1] != K or len(tri) != n
                              or (n and (tri.min() < 0 or tri.max() >= len(region)))):
        raise RefsoftError("region must be (T, K) bool with a row for every pixel's triangle")
    ortho = view_dir is not None
    vd = np.asarray(view_dir if ortho else np.zeros(3), dt)
    out = PixelSearch(np.zeros((n, 3), dt), np.empty(n, dt), np.empty((n, 3), dt), np.empty(n, np.int32),
                      np.empty(n, np.int8), np.empty(n, np.int8), np.empty((n, 2), np.int16), np.empty(n, dt),
                      np.empty(n, np.int32), np.empty(n, np.int32), np.empty(n, np.int8), np.empty(n, np.int8),
                      np.empty(n, np.uint8), np.empty((n, K), dt), np.empty(n, dt))
    if n == 0:
        return out
    parallel_range(search_pixels, n, P, N, np.asarray(eye, dt), ortho, vd,
                   tri if regions == "cone" else np.zeros(n, np.int64),
                   region if regions == "cone" else np.ones((1, K), bool), regions == "cone",
                   np.ascontiguousarray(W, dt), stack.depth, stack.back, stack.count, stack.mismatch, stack.open,
                   C.FACE_TABLE, stack.resolution, n_lin, dt(tau), 3 if faces == "three" else 1, dt(0),
                   out.ray, out.distance, out.object, out.face, out.layer, out.texel, out.residual,
                   out.linear_samples, out.binary_steps, out.faces_searched, out.objects_tested, out.flags,
                   out.object_distance, out.margin, out.hit)
    return out


def hit_normals(stack: Stack, result: PixelSearch) -> np.ndarray:
    """(n, 3) float32: the model-space LDT normal at each pixel's hit texel (0 where none)."""
    n = np.zeros((len(result.object), 3), np.float32)
    ok = result.object >= 0
    n[ok] = stack.normal[result.object[ok], result.face[ok], result.layer[ok], result.texel[ok, 0],
                         result.texel[ok, 1]]
    return n
