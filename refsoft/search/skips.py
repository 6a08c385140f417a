"""Tests that let the frame driver skip work a frame does not need .

Every skip here is *exact*: the frame's outputs are bit for bit those of the full computation
(tests/search/test_skips.py renders every built-in animation with each skip on and off). A skip that
changes results by design is an approximation, named as such and off by default
(:func:`projection_clipped`, used by ``RenderOptions.adaptive_widen``).

- :func:`outside_frustum`: all of a mesh's vertices strictly outside one clip plane, so the
  rasterizer draws no pixel of it: its G-buffer is empty and every search is CULLED.
- :func:`camera_key` and :func:`reusable`: a G-buffer is reused when the reflector and the
  G-buffer camera did not move; a vertex's search is reused when its object did not move either,
  with the iterations and flags the search itself would give (see :func:`reused_result`).
- :func:`outside_box`: per (reflector, object), virtual vertices that all lie beyond one side
  of the stencil's box (with a margin wider than the rasterizer's snapping): the object's virtual
  triangles cannot cover a stencil pixel, so they are not rasterized.
"""

from __future__ import annotations

import numpy as np

from .._numba import kernel, readonly
from .._parallel import parallel_range
from . import BORDER, CAPPED, CULLED, HIDDEN
from ..constants import BOX_MARGIN_PIXELS


def outside_frustum(clip) -> bool:
    """True when every clip-space vertex is strictly outside the near plane or one of the four
    side planes (the rasterizer does not clip at the far plane, so it is not tested).

    A triangle's clipped polygon is a convex combination of its vertices, so it stays outside
    that plane and covers no pixel centre (all of which lie inside the frustum).

    Parameters
    ----------
    clip : ndarray, shape (V, 4), float64
        ``view_proj @ [p, 1]`` of every vertex, as the rasterizer computes it.
    """
    x, y, z, w = clip[:, 0], clip[:, 1], clip[:, 2], clip[:, 3]
    return bool(len(clip) == 0 or np.all(x > w) or np.all(x < -w) or np.all(y > w) or np.all(y < -w)
                or np.all(z < -w))


def projection_clipped(clip) -> bool:
    """True when some vertex lies outside the view's side planes (its projection is cut by the
    image border) or behind the near plane: where Estalella's wider frustum is needed."""
    x, y, z, w = clip[:, 0], clip[:, 1], clip[:, 2], clip[:, 3]
    return bool(np.any((np.abs(x) > w) | (np.abs(y) > w) | (z < -w)))


def camera_key(camera) -> tuple:
    """Everything a G-buffer raster reads from its camera: the world-to-clip matrix, the eye and
    the viewport. Two cameras with equal keys give bit-identical G-buffers."""
    return (camera.view_proj().tobytes(), np.asarray(camera.eye, dtype=np.float64).tobytes(),
            int(camera.width), int(camera.height))


def reusable(result, coherence: bool, inverse: str, border_restart: bool = False) -> np.ndarray:
    """Vertices whose last result a new search would repeat, given the same G-buffer, eye and
    vertex, shape (N,) bool.

    Without coherence every search starts at the same pixel, so every result repeats. With
    coherence a search starts at its last end pixel; the walk stops there at once (no neighbour
    scores strictly higher) unless it was CAPPED (not a local optimum) or was an inverse search
    (``inverse="search"`` and HIDDEN: the standard search would restart from ``R*``, not ``R``),
    or stopped on the border with ``border_restart`` (walked twice: searched again).
    CULLED results repeat only without coherence (the G-buffer is the same empty one).
    """
    flags = result.flags
    if not coherence or getattr(result, "method", "walk") == "hierarchy":  # no start pixel: it repeats
        return np.ones(len(flags), dtype=bool)
    ok = (flags & (CAPPED | CULLED)) == 0
    if inverse == "search":
        ok &= (flags & HIDDEN) == 0
    if border_restart:
        ok &= (flags & BORDER) == 0
    return ok


def reused_result(result, coherence: bool):
    """Iterations and flags of a reused search: unchanged without coherence; with coherence the
    walk evaluates one neighbourhood and keeps HIDDEN and BORDER (both depend on the end pixel
    only), RESTARTED is not set (the start was covered). Returns (iterations, flags)."""
    if not coherence or getattr(result, "method", "walk") == "hierarchy":
        return result.iterations, result.flags
    return np.ones(len(result.flags), dtype=np.int32), (result.flags & (HIDDEN | BORDER)).astype(np.uint8)


def box_planes(box, width: int, height: int, margin: float = BOX_MARGIN_PIXELS):
    """NDC bounds ``(x_lo, x_hi, y_lo, y_hi)`` of the pixel centres of ``box = (r0, r1, c0,
    c1)``, widened by ``margin`` pixels (rows count down from the top; NDC y up)."""
    r0, r1, c0, c1 = box
    x_lo = 2.0 * (c0 + 0.5 - margin) / width - 1.0
    x_hi = 2.0 * (c1 - 0.5 + margin) / width - 1.0
    y_lo = 2.0 * (height - r1 + 0.5 - margin) / height - 1.0
    y_hi = 2.0 * (height - r0 - 0.5 + margin) / height - 1.0
    return x_lo, x_hi, y_lo, y_hi


def outside_box(clip, bounds) -> bool:
    """True when every clip vertex lies strictly beyond one side of the NDC ``bounds``
    (:func:`box_planes`) or behind the near plane.

    Each side is the clip-space half-space ``x > x_hi w`` (and the like): linear, so a clipped
    polygon stays in it, and a visible point (w > 0) in it projects beyond that side.
    """
    if len(clip) == 0:
        return True
    x_lo, x_hi, y_lo, y_hi = bounds
    sides = (lambda c: c[:, 0] > x_hi * c[:, 3], lambda c: c[:, 0] < x_lo * c[:, 3],
             lambda c: c[:, 1] > y_hi * c[:, 3], lambda c: c[:, 1] < y_lo * c[:, 3], lambda c: c[:, 2] < -c[:, 3])
    # a side whose test the first vertex fails holds no part: only the others are scanned (a
    # visible part's first vertex usually rules out all five)
    return any(bool(side(clip[:1])[0]) and bool(np.all(side(clip))) for side in sides)


def triangles_skipped(clip, faces, flags, lost, bounds=None, serial=False):
    """Per triangle, whether the virtual pass leaves it out: one of its vertices has a flag in
    ``lost`` (it has no virtual vertex to be drawn with), or, given ``bounds``, :func:`outside_box`
    of its three clip vertices (the same half-space tests: it covers no pixel of the box and need
    not be set up at all).

    Parameters
    ----------
    clip : ndarray, shape (V, 4), float64
    faces : ndarray, shape (F, 3), int64
    flags : ndarray, shape (V,), uint8
        The vertices' search flags.
    lost : int
        The flags that leave a vertex's triangles out (0: none).
    bounds : (x_lo, x_hi, y_lo, y_hi), optional
        The box's NDC bounds (:func:`box_planes`); None: no box test.
    serial : bool
        Test on the calling thread alone (:func:`refsoft._parallel.parallel_range`).

    Returns
    -------
    ndarray, shape (F,), bool
    """
    box = bounds is not None
    x_lo, x_hi, y_lo, y_hi = (float(b) for b in bounds) if box else (0.0, 0.0, 0.0, 0.0)
    out = np.empty(len(faces), dtype=np.bool_)
    parallel_range(_triangles_skipped, len(faces), readonly(np.ascontiguousarray(clip, dtype=np.float64)),
                   readonly(np.ascontiguousarray(faces, dtype=np.int64)),
                   readonly(np.ascontiguousarray(flags, dtype=np.uint8)), np.uint8(lost), box, x_lo, x_hi, y_lo, y_hi,
                   out, serial=serial)
    return out


def triangles_outside_box(clip, faces, x_lo, x_hi, y_lo, y_hi, serial=False):
    """Per triangle, :func:`outside_box` of its three clip vertices: :func:`triangles_skipped`
    with no flag lost. ``clip`` (V, 4) float64, ``faces`` (F, 3) int64; returns (F,) bool."""
    return triangles_skipped(clip, faces, np.zeros(len(clip), np.uint8), 0, (x_lo, x_hi, y_lo, y_hi), serial)


@kernel
def _triangles_skipped(lo, hi, clip, faces, flags, lost, box, x_lo, x_hi, y_lo, y_hi, out):
    """``out[t]`` for the triangles ``t`` in ``lo .. hi - 1`` (:func:`triangles_skipped`)."""
    for t in range(lo, hi):
        if ((flags[faces[t, 0]] | flags[faces[t, 1]] | flags[faces[t, 2]]) & lost) != 0:
            out[t] = True
            continue
        if not box:
            out[t] = False
            continue
        right = True
        left = True
        above = True
        below = True
        near = True
        for j in range(3):
            v = clip[faces[t, j]]
            x, y, z, w = v[0], v[1], v[2], v[3]
            right = right and x > x_hi * w
            left = left and x < x_lo * w
            above = above and y > y_hi * w
            below = below and y < y_lo * w
            near = near and z < -w
        out[t] = right or left or above or below or near
