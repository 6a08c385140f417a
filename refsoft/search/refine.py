"""Sub-texel reflection points: an option beyond the paper (``refine=True``, off by default).

The search ends on a texel, so the reflection point, and with it the tangent plane a vertex is
mirrored across, is quantised to the G-buffer's pixel grid: on a mirror ball the virtual
vertices then project up to about half a pixel off, and the outlines of reflected objects come
out ragged by a pixel. Refinement takes one Gauss-Newton step on ``N(x) - h(x) = 0`` (the
normal equals the bisector of the directions to the eye and to the vertex) from the texel the
search found, with the derivatives of the residual, of P and of N by central differences over
the texel's four neighbours; P and N at the new point come from the same first-order model (N
renormalised). The step is limited to one texel per axis; uncovered neighbours give one-sided
differences, or none along an axis with no covered neighbour. HIDDEN and CULLED vertices are
not refined (their virtual vertices follow spec section 4.6 unchanged).

The reflection pixel reported by the search is not changed; only the virtual vertex moves.
"""

from __future__ import annotations

import numpy as np

from .._parallel import parallel_range
from ..errors import RefsoftError
from ..raster import GBuffer
from . import _refine

#: Refinements of at most this many vertices run on the calling thread (about 50 ns a vertex:
#: a tenth of a millisecond, less than waking another thread costs).
SERIAL_MAX_REFINED = 2048


def refine(gbuffer: GBuffer, eye, vertices, result):
    """Sub-texel surface points for the vertices of one search.

    Parameters
    ----------
    gbuffer : GBuffer
        The G-buffer the search ran on.
    eye : array_like, shape (3,)
        World-space eye.
    vertices : array_like, shape (N, 3)
        World-space vertices, as searched.
    result : SearchResult
        The search's results for them.

    Returns
    -------
    position : ndarray, shape (N, 3), the G-buffer's dtype
        Refined surface points, relative to ``gbuffer.origin``.
    normal : ndarray, shape (N, 3), the G-buffer's dtype
        Unit normals there.
    offset : ndarray, shape (N, 2), the G-buffer's dtype
        The step taken, in texels (rows, cols); in [-1, 1]; 0 where not refined.
    """
    from .. import validate
    from . import _check_gbuffer

    dt = _check_gbuffer(gbuffer)
    verts = validate.points(vertices, "vertices", len(result))
    eye = validate.point(eye, "eye")
    n = len(verts)
    if n == 0:
        return np.zeros((0, 3), dt), np.zeros((0, 3), dt), np.zeros((0, 2), dt)
    pix = np.ascontiguousarray(result.pixel, dtype=np.int64)
    flags = np.ascontiguousarray(result.flags, dtype=np.uint8)
    bad = _refine.check_pixels(pix, flags, gbuffer.mask)
    if bad == 1:
        raise RefsoftError("refine: a reflection pixel lies outside the G-buffer")
    if bad == 2:
        raise RefsoftError("refine: a reflection pixel is not covered by the reflector")
    o = np.ascontiguousarray(gbuffer.origin, dtype=np.float64)
    e = ((eye - o).astype(dt))
    p, nrm, off = np.empty((n, 3), dt), np.empty((n, 3), dt), np.empty((n, 2), dt)  # every row written
    parallel_range(_refine.refine, n, gbuffer.position, gbuffer.normal, gbuffer.mask, np.ascontiguousarray(verts), o, e,
                   pix, flags, dt(0), p, nrm, off, serial=n <= SERIAL_MAX_REFINED, work=lambda: _refine.refine_work(dt))
    return p, nrm, off


def surface_at(gbuffer: GBuffer, pixels, offsets):
    """P and unit N at sub-texel points ``pixels + offsets`` by the first-order model of
    :func:`refine` at each texel (which must be covered).

    Parameters
    ----------
    gbuffer : GBuffer
    pixels : array_like, shape (M, 2), int
        Covered texels (row, col).
    offsets : array_like, shape (M, 2)
        Offsets in texels (rows, cols), at most about one.

    Returns
    -------
    position, normal : ndarray, shape (M, 3), the G-buffer's dtype
        Relative to ``gbuffer.origin``.
    """
    from . import _check_gbuffer

    dt = _check_gbuffer(gbuffer)
    pix = np.ascontiguousarray(np.asarray(pixels, dtype=np.int64).reshape(-1, 2))
    off = np.ascontiguousarray(np.asarray(offsets, dtype=dt).reshape(-1, 2))
    if len(off) != len(pix):
        raise RefsoftError(f"pixels ({len(pix)}) and offsets ({len(off)}) differ in number")
    h, w = gbuffer.mask.shape
    if len(pix) and (np.any(pix < 0) or np.any(pix[:, 0] >= h) or np.any(pix[:, 1] >= w)
                     or not gbuffer.mask[pix[:, 0], pix[:, 1]].all()):
        raise RefsoftError("surface_at: every pixel must be a covered texel of the G-buffer")
    p = np.zeros((len(pix), 3), dtype=dt)
    n = np.zeros((len(pix), 3), dtype=dt)
    if len(pix):
        parallel_range(_refine.surface_at, len(pix), gbuffer.position, gbuffer.normal, gbuffer.mask, pix, off, dt(0),
                       p, n)
    return p, n
