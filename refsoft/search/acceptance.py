"""Exact per-pixel acceptance (spec section 4.8's drawing of every image, and a later bounce's,
spec section 5.1): candidate virtual triangles, each rasterized conservatively (dilated) in a
stencil, and at each pixel it covers the pixel's reflected ray met with the candidate's *real*
scene triangle; the nearest hit with ``t > 0`` inside the triangle wins. A candidate across a
tear or beyond a fold is never drawn where it does not reflect, and a pixel whose reflected ray
hits no candidate stays empty. A candidate with a ray list (:class:`Candidates`' ``rays``) is
tested at those rays' pixels alone (``accept_near``): the others miss its triangle.

See ``docs/sheets.md``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import constants
from .._parallel import parallel_range
from ..raster import _setup, shade
from ..raster.rays import box_rays
from ._several import accept, accept_near, accept_untracked, bounds_area, ray_bounds
from ._several import screen_bounds as _screen_bounds
from ._traced import LEAF, accept_traced, leaf_boxes, parent_boxes, widen
from .scratch import kept


@dataclass(frozen=True, eq=False)
class Candidates:
    """Candidate virtual triangles of one reflector.

    Attributes
    ----------
    virtual : (C, 3, 3) float64
        The images of the triangle's corners (world space).
    real : (C, 3, 3) float64
        The scene triangle (or its part after subdivision), world space.
    normals : (C, 3, 3) float64
        Vertex normals at its corners.
    object_id : (C,) int32
    triangle : (C,) int64
        The scene triangle (row of the faces given) each candidate comes from.
    subdivided : int
        Scene triangles cut at least once (with the reflected rays given to :func:`candidates`:
        of those it makes and keeps).
    rays : tuple or None
        With the reflected rays given to :func:`candidates`: each candidate's rays that may hit
        its real triangle, ``ray[first[c]:last[c]]`` ascending, as ``(first (C,) int64, last (C,)
        int64, ray (K,) int64)``; a ray is the index of a valid pixel of :func:`pixel_rays` in
        row-major order; ``first[c] < 0``: none made (every pixel the candidate covers is
        tested). None: every pixel is tested.
    """

    virtual: np.ndarray
    real: np.ndarray
    normals: np.ndarray
    object_id: np.ndarray
    triangle: np.ndarray
    subdivided: int
    rays: tuple = None


# --- drawing ----------------------------------------------------------------------------------
def pixel_rays(camera, reflector_mesh, triangle, stencil, box, scratch=False):
    """The reflected ray of every stencil pixel of the box (the truth's,
    :func:`refsoft.raster.rays.primary_rays`, through :func:`refsoft.raster.rays.box_rays`).

    Parameters
    ----------
    camera, reflector_mesh, triangle, stencil, box
        As :func:`draw`.
    scratch : bool
        Write them into this thread's scratch memory (:func:`refsoft.search.scratch.kept`), for
        a caller done with them before it asks again: no fresh pages each time.

    Returns
    -------
    valid : (h, w) bool
        Box pixels with a reflected ray.
    origin, direction : (h, w, 3) float64
        Each box pixel's reflected ray (zeros off the stencil).
    """
    out = None
    if scratch:
        h, w = int(box[1]) - int(box[0]), int(box[3]) - int(box[2])
        out = kept("rays_valid", (h, w), bool), kept("rays_origin", (h, w, 3)), kept("rays_direction", (h, w, 3))
    return box_rays(camera, reflector_mesh, triangle, stencil, box, out)


def draw(cand: Candidates, camera, reflector_mesh, triangle, stencil, box, colors, rays=None):
    """Draw the candidates at the reflector's stencil pixels by exact per-pixel acceptance
    (module docstring, step 3).

    Parameters
    ----------
    cand : Candidates
    camera : Camera
        The view camera.
    reflector_mesh : Mesh
        The reflector's world mesh (the main view's).
    triangle : (H, W) int
        The reflector's visible triangle per view pixel (the main view's).
    stencil : (H, W) bool
    box : (r0, r1, c0, c1)
    colors : (K + 1, 3) float32
        Object colours by id (row 0 unused).
    rays : tuple, optional
        :func:`pixel_rays` of these arguments (made here when not given).

    Returns
    -------
    colour : (h, w, 3) float32
    reflected_id : (h, w) int32
    covered : (h, w) bool
    counts : dict
        ``pixels_accepted`` (a candidate's real triangle hit), ``pixels_empty`` (pixels with a
        reflected ray where no candidate's triangle is hit: nothing drawn).
    """
    rays = pixel_rays(camera, reflector_mesh, triangle, stencil, box) if rays is None else rays
    best_c, best_uv = nearest(cand, camera, stencil, box, rays=rays)
    covered = best_c >= 0
    c = best_c[covered]
    return shade_winners(best_c, best_uv, cand.normals[c], cand.object_id[c], colors, rays[0])


def nearest(cand: Candidates, camera, stencil, box, *, rays=None, screen=None, triangle=None, reflector_mesh=None,
            runs=True, traced=None, scratch=False):
    """Per box pixel the candidate whose real triangle the pixel's reflected ray meets nearest,
    among those whose dilated virtual triangle covers it (:func:`draw` without the shading).

    Parameters
    ----------
    cand : Candidates
        Only ``real`` and ``rays`` are read when ``screen`` is given, ``virtual`` too otherwise.
    camera, stencil, box
        As :func:`draw`.
    rays : tuple, optional
        :func:`pixel_rays` (made from ``triangle`` and ``reflector_mesh`` when not given).
    screen : tuple, optional
        :func:`screen_bounds` of the candidates (made here when not given).
    runs : bool
        Test a pixel's ray once per run of consecutive candidates with the same real triangle
        (worth it where many share one, as every image's candidates do); False: each candidate
        on its own, without the bookkeeping (kernel ``_several.accept_untracked``). The result
        is the same.
    traced : bool, optional
        With ``runs=False``: walk each pixel's ray through a hierarchy of the candidates' real
        triangles (kernel ``_traced.accept_traced``) instead of testing every pixel each candidate
        covers (True), or not (False); by default whichever :func:`_trace_pays` expects to be
        cheaper. The result is the same bits.
    scratch : bool
        Return arrays in this thread's scratch memory (:func:`refsoft.search.scratch.kept`), for
        a caller done with them before it asks again.

    Returns
    -------
    best_c : (h, w) int64
        The winning candidate per box pixel, -1 none.
    best_uv : (h, w, 2) float64
        Its barycentrics (u, v) on the real triangle.
    """
    r0, r1, c0, c1 = (int(x) for x in box)
    h, w = r1 - r0, c1 - c0
    valid, origin, direction = pixel_rays(camera, reflector_mesh, triangle, stencil, box) if rays is None else rays
    screen, bbox, dilate = _screen(cand.virtual, camera, box) if screen is None else screen
    if scratch:
        best_t, best_c, best_uv = kept("best_t", (h, w)), kept("best_c", (h, w), np.int64), kept("best_uv", (h, w, 2))
        best_t.fill(np.inf)
        best_c.fill(-1)
        best_uv.fill(0.0)
    else:
        best_t = np.full((h, w), np.inf)
        best_c = np.full((h, w), -1, np.int64)
        best_uv = np.zeros((h, w, 2))
    if len(screen):
        real = np.ascontiguousarray(cand.real)
        tested, seen = (np.zeros((h, w), bool), np.full((h, w), -1, np.int64)) if runs or cand.rays is not None else (
            None, None)
        if cand.rays is None and not runs and _trace_pays(valid, bbox, h, c0, c1, real, traced):
            _accept_traced(r0, c0, valid, origin, direction, screen, bbox, dilate, real, best_t, best_c, best_uv)
        elif cand.rays is None and not runs:
            parallel_range(accept_untracked, h, r0, c0, valid, _spans(valid), origin, direction, screen, bbox, dilate,
                           real, _ray_bounds(valid, origin, direction), constants.EXACT_TRACE_MARGIN, best_t, best_c,
                           best_uv)
        elif cand.rays is None:
            parallel_range(accept, h, r0, c0, valid, _spans(valid), origin, direction, screen, bbox, dilate, real,
                           _runs(real), best_t, best_c, best_uv, tested, seen)
        else:  # each candidate's pixels whose rays may hit it, not every pixel it covers
            rows, cols = np.nonzero(valid)
            first, last, ray = (np.ascontiguousarray(a, np.int64) for a in cand.rays)
            parallel_range(accept_near, h, r0, c0, valid, _spans(valid), origin, direction, rows, cols,
                           np.ascontiguousarray(origin[valid]), np.ascontiguousarray(direction[valid]), screen, bbox,
                           dilate, real, _runs(real), first, last, ray, best_t, best_c, best_uv, tested, seen)
    return best_c, best_uv


def _trace_pays(valid, bbox, h, c0, c1, real, traced):
    """Whether the traced acceptance is expected to cost less than the candidates' own loop: where
    the candidates' dilated bounds cover more than :data:`refsoft.constants.EXACT_TRACE_COVER`
    candidates per valid pixel on average (the loop's work grows with that, a walk's with the
    hierarchy's depth)."""
    if traced is not None:
        return bool(traced)
    covered = float(bounds_area(bbox, h, c0, c1))
    return covered > constants.EXACT_TRACE_COVER * float(np.count_nonzero(valid))


def _accept_traced(r0, c0, valid, origin, direction, screen, bbox, dilate, real, best_t, best_c, best_uv):
    """Kernel ``_traced.accept_traced`` with its hierarchy over the candidates in their order,
    :data:`._traced.LEAF` a leaf. With a value that is not finite among the triangles, the
    candidates' own loop (the same bits)."""
    size = [-(-len(real) // LEAF)]
    while size[-1] > 1:
        size.append(-(-size[-1] // 2))
    size = np.asarray(size, np.int64)
    start = np.concatenate([[0], np.cumsum(size)[:-1]]).astype(np.int64)
    boxes, rects = kept("trace_boxes", (int(size.sum()), 6)), kept("trace_rects", (int(size.sum()), 4), np.int64)
    parallel_range(leaf_boxes, int(size[0]), real, bbox, boxes, rects)
    if not np.isfinite(widen(int(size[0]), boxes, constants.EXACT_TRACE_MARGIN)):
        # the boxes would not bound such a triangle: the candidates' own loop
        parallel_range(accept_untracked, valid.shape[0], r0, c0, valid, _spans(valid), origin, direction, screen,
                       bbox, dilate, real, _ray_bounds(valid, origin, direction), constants.EXACT_TRACE_MARGIN, best_t,
                       best_c, best_uv)
        return
    parent_boxes(start, size, boxes, rects)
    parallel_range(accept_traced, valid.shape[0], r0, c0, valid, origin, direction, screen, bbox, dilate, real, start,
                   size, boxes, rects, constants.EXACT_TRACE_MARGIN, best_t, best_c, best_uv,
                   work=lambda: (np.empty(2 * len(size) + 2, np.int64), np.empty(2 * len(size) + 2)))


def shade_winners(best_c, best_uv, normals, object_id, colors, valid):
    """Shade the pixels :func:`nearest` found a candidate for.

    Parameters
    ----------
    best_c : (h, w) int64
    best_uv : (h, w, 2) float64
        :func:`nearest`'s outputs.
    normals : (k, 3, 3) float64
        The corner normals of the winning candidate of each covered pixel (``best_c >= 0``, in
        row-major order).
    object_id : (k,) int32
        Its object.
    colors : (K + 1, 3) float32
        Object colours by id.
    valid : (h, w) bool
        Box pixels with a reflected ray.

    Returns
    -------
    colour, reflected_id, covered, counts
        As :func:`draw`.
    """
    h, w = best_c.shape
    covered = best_c >= 0
    rid = np.zeros((h, w), np.int32)
    colour = np.zeros((h, w, 3), np.float32)
    if covered.any():
        u, v = best_uv[covered, 0], best_uv[covered, 1]
        n = (1.0 - u - v)[:, None] * normals[:, 0] + u[:, None] * normals[:, 1] + v[:, None] * normals[:, 2]
        length = np.sqrt(np.sum(n * n, axis=1))[:, None]
        n = np.divide(n, length, out=np.zeros_like(n), where=length > 0)
        rid[covered] = object_id
        colour[covered] = shade(n, np.asarray(colors, np.float32)[object_id])
    counts = {"pixels_accepted": int(covered.sum()), "pixels_empty": int((valid & ~covered).sum())}
    return colour, rid, covered, counts


def _runs(real):
    """(C,) int64: the run of each candidate, a new one wherever its real triangle (C, 3, 3) float64
    differs in any bit from the previous one's."""
    bits = real.reshape(len(real), -1).view(np.int64)
    new = np.ones(len(real), bool)
    new[1:] = np.any(bits[1:] != bits[:-1], axis=1)
    return np.cumsum(new, dtype=np.int64)


def _ray_bounds(valid, origin, direction):
    """(7,) float64: the box of the valid pixels' ray origins (min x, y, z, max x, y, z) and their
    directions' largest length (kernel ``_several.ray_bounds`` per row, then over the rows)."""
    rows = np.empty((valid.shape[0], 7))
    parallel_range(ray_bounds, valid.shape[0], valid, origin, direction, rows)
    return np.concatenate([rows[:, :3].min(axis=0, initial=np.inf), rows[:, 3:6].max(axis=0, initial=-np.inf),
                           [rows[:, 6].max(initial=0.0)]])


def _spans(valid):
    """(h, 2) int64: per row of ``valid`` (h, w) its first True column and last plus one (0, 0:
    none)."""
    any_ = valid.any(axis=1)
    first = np.where(any_, np.argmax(valid, axis=1), 0)
    last = np.where(any_, valid.shape[1] - np.argmax(valid[:, ::-1], axis=1), 0)
    return np.ascontiguousarray(np.stack([first, last], axis=1), np.int64)


def _screen(virtual, camera, box):
    """View-pixel positions (C, 3, 2) float64 of the candidates' virtual vertices (C, 3, 3), their
    dilated bounds (C, 4) int64 (box rows, view columns) and dilations (C,) float64 (-1: a vertex
    at or behind the eye plane, the whole box): :func:`screen_bounds` of their clip coordinates."""
    c = len(virtual)
    clip = _setup.transform_points(np.ascontiguousarray(virtual, np.float64).reshape(-1, 3), camera.view_proj())
    return screen_bounds(clip, np.arange(3 * c, dtype=np.int64).reshape(c, 3), camera, box)


def screen_bounds(clip, corner, camera, box):
    """View-pixel positions (C, 3, 2) float64 of candidates whose corners are rows ``corner``
    (C, 3) int64 of the clip coordinates ``clip`` (n, 4) float64, their dilated bounds (C, 4)
    int64 (box rows, view columns) and dilations (C,) float64 (-1: a vertex at or behind the eye
    plane, the whole box): kernel ``_several.screen_bounds``, and :func:`_screen_numpy` for the
    rows with a value that is not finite."""
    r0, r1, c0, c1 = (int(x) for x in box)
    c = len(corner)
    clip = np.ascontiguousarray(clip, np.float64)
    corner = np.ascontiguousarray(corner, np.int64)
    screen, bbox, dilate = np.empty((c, 3, 2)), np.empty((c, 4), np.int64), np.empty(c)
    odd = np.zeros(c, bool)
    if c:
        parallel_range(_screen_bounds, c, clip, corner, float(camera.width), float(camera.height), r0, r1, c0, c1,
                       float(constants.SEVERAL_DILATE_PIXELS), float(constants.SEVERAL_DILATE_FRACTION), screen, bbox,
                       dilate, odd)
    if odd.any():
        screen[odd], bbox[odd], dilate[odd] = _screen_numpy(clip[corner[odd]], camera, box)
    return screen, bbox, dilate


def _screen_numpy(clip, camera, box):
    """:func:`_screen` from the clip coordinates (C, 3, 4) float64, in NumPy (a bound from a value
    that is not finite is whatever NumPy's cast makes of it; its dilation is -1)."""
    r0, r1, c0, c1 = box
    c = len(clip)
    W, H = camera.width, camera.height
    wv = clip[..., 3]
    good = np.all(wv > 0, axis=1)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        x = (clip[..., 0] / wv + 1.0) * 0.5 * W
        y = (1.0 - clip[..., 1] / wv) * 0.5 * H
        screen = np.ascontiguousarray(np.stack([x, y], axis=2))
        screen[~good] = 0.0
        edge = np.max(np.sqrt(np.sum((screen - screen[:, [1, 2, 0]]) ** 2, axis=2)), axis=1)
        dilate = constants.SEVERAL_DILATE_PIXELS + constants.SEVERAL_DILATE_FRACTION * edge
        bbox = np.empty((c, 4), np.int64)
        lo_x, hi_x = np.min(x, axis=1) - dilate, np.max(x, axis=1) + dilate
        lo_y, hi_y = np.min(y, axis=1) - dilate, np.max(y, axis=1) + dilate
        big = float(1 << 30)
        bbox[:, 0] = np.floor(np.clip(lo_y - 0.5, -big, big)).astype(np.int64) - r0
        bbox[:, 1] = np.ceil(np.clip(hi_y - 0.5, -big, big)).astype(np.int64) + 1 - r0
        bbox[:, 2] = np.floor(np.clip(lo_x - 0.5, -big, big)).astype(np.int64)
        bbox[:, 3] = np.ceil(np.clip(hi_x - 0.5, -big, big)).astype(np.int64) + 1
    bbox[~good] = (0, r1 - r0, c0, c1)
    dilate = np.where(good & np.isfinite(dilate), dilate, -1.0)
    return screen, bbox, dilate
