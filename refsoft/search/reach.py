"""The reflected rays that may hit each triangle: the pruning of the drawing of every image
(:mod:`refsoft.search.several`) and its lists of rays per candidate. A ray is left out of a
triangle's list only when the acceptance's own ray test (``_several._may_hit``: Moller-Trumbore
with a margin) puts it clearly off the triangle; the lists of :func:`ray_lists` are found through
ray tiles (:mod:`refsoft.search._raytiles`) and hold the same rays, less those that cannot hit.
"""

from __future__ import annotations

import numpy as np

from .. import constants
from .._parallel import parallel_range
from ..errors import RefsoftError
from ._several import rays_near, rays_near_every
from .acceptance import Candidates


def near_rays(verts, normals, faces, face_obj, rays):
    """One candidate per triangle a ray comes near (``Reach``, the pruning of :func:`candidates`),
    with those rays and no projection (its virtual corners NaN): the acceptance meets it with each
    ray of its list, wherever the pixel, so the drawing is the ray cast's up to the pruning's
    margin. A later bounce on a reflector that sees itself (spec section 5.1) is drawn so.

    Parameters
    ----------
    verts, normals : (N, 3) float64
    faces : (F, 3) int64
    face_obj : (F,) int32
    rays : tuple of two (R, 3) float64
        Origins and directions of the rays the candidates are met with.

    Returns
    -------
    Candidates
    """
    faces = np.asarray(faces, np.int64).reshape(-1, 3)
    reach = Reach(*rays)
    first, last = reach.test_every(np.asarray(verts, np.float64)[faces]) if len(faces) else reach.every(0)
    src = np.flatnonzero(last > first)
    return Candidates(np.full((len(src), 3, 3), np.nan), np.asarray(verts, np.float64)[faces[src]],
                      np.asarray(normals, np.float64)[faces[src]], np.asarray(face_obj, np.int32)[src], src, 0,
                      (first[src], last[src], reach.ray()))


def take(span, keep):
    """The rays ``(first, last)`` of the triangles ``keep`` (a mask or indices)."""
    return span[0][keep], span[1][keep]


class Reach:
    """The reflected rays that may hit each triangle (:func:`._several.rays_near`): a part is
    tested against its face's rays alone (a ray that misses a face by the margin misses its parts).
    A triangle's rays are ``ray()[first:last]`` (ascending): the lists of every test are kept, one
    after another."""

    def __init__(self, origin, direction):
        self.origin = np.ascontiguousarray(origin, np.float64).reshape(-1, 3)
        self.direction = np.ascontiguousarray(direction, np.float64).reshape(-1, 3)
        d = self.direction
        self.length = np.sqrt((d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1]) + d[:, 2] * d[:, 2])
        self.columns = np.ascontiguousarray(np.concatenate([self.origin.T, d.T, self.length[None]]))
        self.lists = [np.arange(len(self.origin), dtype=np.int64)]  # the first: every ray
        self.size = len(self.origin)
        self._ray = None

    def ray(self):
        """(K,) int64: every list so far."""
        if self._ray is None or len(self._ray) != self.size:
            self._ray = np.concatenate(self.lists)
        return self._ray

    def every(self, n):
        """``(first, last)``: every ray for each of ``n`` triangles."""
        return np.zeros(n, np.int64), np.full(n, len(self.origin), np.int64)

    def test_every(self, real):
        """``(first, last)``: the rays of every ray that may hit each triangle of ``real`` (F, 3,
        3) float64 (:func:`test` of :meth:`every`, the rays a block at a time:
        :func:`._several.rays_near_every`)."""
        real = np.ascontiguousarray(real, np.float64)
        args = (real, self.columns, float(constants.SEVERAL_PRUNE_MARGIN), float(constants.SEVERAL_PRUNE_PARALLEL))
        n = np.zeros(len(real), np.int64)
        at = np.zeros(len(real), np.int64)
        if len(real):
            parallel_range(rays_near_every, len(real), *args, n, n, at, np.zeros(0, np.int64), False)
        start = np.cumsum(n) - n
        out = np.empty(int(n.sum()), np.int64)
        if len(out):
            parallel_range(rays_near_every, len(real), *args, n, start, at, out, True)
        start += self.size
        self.lists.append(out)
        self.size += len(out)
        return start, start + n

    def test(self, real, first, last):
        """``(first, last)``: the rays of ``ray()[first:last]`` that may hit each triangle of
        ``real`` (F, 3, 3) float64 (a new list each)."""
        real = np.ascontiguousarray(real, np.float64)
        args = (real, self.origin, self.direction, self.length, np.ascontiguousarray(first, np.int64),
                np.ascontiguousarray(last, np.int64), self.ray(), float(constants.SEVERAL_PRUNE_MARGIN),
                float(constants.SEVERAL_PRUNE_PARALLEL))
        n = np.zeros(len(real), np.int64)
        if len(real):
            parallel_range(rays_near, len(real), *args, n, np.zeros(0, np.int64), False)
        start = np.cumsum(n) - n
        out = np.empty(int(n.sum()), np.int64)
        if len(out):  # the second pass skips the rays of the triangles without any
            args = args[:5] + (np.where(n > 0, args[5], args[4]),) + args[6:]
            parallel_range(rays_near, len(real), *args, start, out, True)
        start += self.size
        self.lists.append(out)
        self.size += len(out)
        return start, start + n


def ray_lists(real, rays):
    """The reflected rays that may hit each triangle, found through ray tiles
    (:mod:`refsoft.search._raytiles`): per triangle the rays ``_several._may_hit`` keeps (the
    test of the candidates' pruning), less those whose tile cannot reach the triangle.

    Parameters
    ----------
    real : (F, 3, 3) float64
        Triangles, world space.
    rays : tuple
        :func:`refsoft.search.acceptance.pixel_rays`: ``valid`` (h, w) bool, ``origin`` and
        ``direction`` (h, w, 3) float64.

    Returns
    -------
    first, last : (F,) int64
        Triangle ``f``'s rays are ``ray[first[f]:last[f]]``, ascending.
    ray : (K,) int64
        Indices of valid pixels in row-major order.
    """
    from ._raytiles import TILE_WIDTH, rays_near_tiles, tile_bounds

    real = np.ascontiguousarray(real, np.float64).reshape(-1, 3, 3)
    valid, origin, direction = rays
    valid = np.ascontiguousarray(valid, bool)
    if valid.ndim != 2 or np.shape(origin) != valid.shape + (3,) or np.shape(direction) != valid.shape + (3,):
        raise RefsoftError(f"rays must be valid (h, w) and origin, direction (h, w, 3), got {valid.shape}, "
                           f"{np.shape(origin)}, {np.shape(direction)}")
    origin = np.ascontiguousarray(origin, np.float64)
    direction = np.ascontiguousarray(direction, np.float64)
    n = len(real)
    count = np.zeros(n, np.int64)
    if n == 0 or not valid.any():
        return count, count.copy(), np.zeros(0, np.int64)
    h, w = valid.shape
    ray_id = np.full((h, w), -1, np.int64)
    ray_id[valid] = np.arange(int(valid.sum()), dtype=np.int64)
    size, ratio = int(constants.SEVERAL_RAY_TILE), int(constants.SEVERAL_RAY_BLOCK)
    bounds = []
    for side in (size, size * ratio):
        rows, cols = -(-h // side), -(-w // side)
        b = np.zeros((rows * cols, TILE_WIDTH))
        parallel_range(tile_bounds, rows, valid, origin, direction, side, cols, b)
        bounds.append(b)
    d = direction[valid]
    dmax = float(np.max(np.sqrt((d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1]) + d[:, 2] * d[:, 2])))
    dmax = dmax if np.isfinite(dmax) else 0.0  # a ray that is not finite makes its tile keep every ray
    args = (real, valid, origin, direction, ray_id, bounds[0], bounds[1], size, ratio,
            float(constants.SEVERAL_PRUNE_MARGIN), float(constants.SEVERAL_PRUNE_PARALLEL), dmax)

    def work():
        return np.empty(-(-w // (size * ratio)), np.int64), np.empty(-(-w // size), np.int64)

    start = np.zeros(n, np.int64)
    parallel_range(rays_near_tiles, n, *args, count, start, np.zeros(0, np.int64), False, work=work)
    start = np.cumsum(count) - count
    out = np.empty(int(count.sum()), np.int64)
    if len(out):
        parallel_range(rays_near_tiles, n, *args, count, start, out, True, work=work)
    return start, start + count, out
