"""The oracle run on a candidate's own inputs to a stage (``refsoft check --profile gpu``).

A port that interpolates its G-buffer its own way searches that G-buffer, not refsoft's: its
search, virtual vertices and image follow from it. The ``gpu`` profile judges the G-buffer
against the golden one within its tolerances, and everything after it against the oracle run
on the candidate's G-buffer as saved, starting each coherent search at the candidate's own
pixel of the previous frame: :class:`GivenGBufferSearch` is the vertex search with those inputs,
:func:`reference_driver` a frame driver around it, :func:`reference_frame` the frame it renders
for ``refsoft check``, and :func:`saved_rounding` what saving a G-buffer as world-space float32
may change in the scores.
"""

from __future__ import annotations

import time

import numpy as np

from .. import keys
from ..search.method import VertexSearch, virtual_relative
from ..search.reflect import Reflection, coherent_starts


class GivenGBufferSearch(VertexSearch):
    """:class:`refsoft.search.method.VertexSearch` that searches the G-buffers in ``given``
    (``{reflector: GBuffer}``, set before each frame) instead of rendering them; reflectors not
    in ``given`` are rendered as usual. ``previous`` (``{reflector: (N, 2) pixels}``) may be set
    before a frame to choose the coherent starts."""

    def __init__(self, scene, options):
        super().__init__(scene, options)
        self.given = {}

    def reflection(self, view, k: int, report=None):
        gb = self.given.get(k)
        if gb is None:
            return super().reflection(view, k, report)
        opt = self.options
        t0 = time.perf_counter()
        prev = coherent_starts(self.previous.get(k) if opt.coherence else None, len(view.vertices), gb.mask.shape)
        res = self.search_vertices(gb, view.camera.eye, view.vertices, prev)  # with the restart at the border
        rel, surface = virtual_relative(gb, res, view.vertices, view.camera.eye, opt.refine, opt.virtual)
        world64 = rel.astype(np.float64) + gb.origin
        return Reflection(k, gb, res, world64.astype(rel.dtype), world64, surface), 0.0, 1000 * (
            time.perf_counter() - t0)


def reference_driver(scene, options: dict):
    """A :class:`refsoft.frame.FrameDriver` for ``scene`` with the case's ``options`` (a dict of
    :class:`refsoft.RenderOptions` fields) around a :class:`GivenGBufferSearch` (``.method``).
    The reuse skip is off: its outputs are the same, and it would keep state across the inputs
    set before each frame."""
    from ..frame import FrameDriver
    from ..options import RenderOptions

    opts = RenderOptions(**{**options, "reuse": False})
    return FrameDriver(scene, opts, method=GivenGBufferSearch(scene, opts))


def candidate_gbuffer(ctx, k, G, C):
    """Reflector ``k``'s G-buffer as the candidate saved it (a :class:`refsoft.raster.GBuffer`
    relative to the oracle's origin, in the case's precision), or None when the candidate's maps
    are the golden ones, bit for bit, or are not there in the golden shapes and dtypes."""
    from ..raster import GBuffer

    names = (keys.GBUFFER_POSITION(k), keys.GBUFFER_NORMAL(k), keys.GBUFFER_MASK(k))
    if not all(n in C and C[n].shape == G[n].shape and C[n].dtype == G[n].dtype for n in names):
        return None
    if all(np.array_equal(C[n], G[n]) for n in names):
        return None
    mask = C[names[2]]
    if not (np.isfinite(C[names[0]][mask]).all() and np.isfinite(C[names[1]][mask]).all()):
        return None  # failed by the non-finite rule; the oracle's own G-buffer stands in
    gb = ctx.oracle().gbuffer(k)
    dt = gb.position.dtype
    rel = np.where(mask[..., None], C[names[0]].astype(np.float64) - gb.origin, 0.0).astype(dt)
    nrm = np.where(mask[..., None], C[names[1]], 0).astype(dt)
    return GBuffer(rel, nrm, mask.copy(), (0, 0, np.zeros((0, 0), np.float32)), (0, 0, np.zeros((0, 0), np.int32)),
                   gb.view_proj, gb.origin)


#: The kinds of output that follow from the G-buffer.
AFTER_GBUFFER = {"pixel", "virtual", "flags", "vertex_object", "iterations", "score", "margin", "image", "trace"}


def reference_frame(ctx, G, C, prev, cand_prev, drivers):
    """Under a profile with ``own_gbuffer``: the frame as the oracle renders it from the
    candidate's own inputs to the search, its G-buffers as saved where they differ from the
    golden ones and (coherent cases) its pixels of the previous frame as the starts
    (:mod:`refsoft.conformance.stages`). Sets ``ctx.stages`` and ``ctx.reference``; leaves the
    golden frame as the reference when those inputs are the golden ones. ``drivers`` keeps one
    driver per case across its frames."""
    if not ctx.profile.own_gbuffer or not set(ctx.kinds) & AFTER_GBUFFER:
        return
    reflectors = keys.reflectors(G)
    given = {k: gb for k in reflectors if (gb := candidate_gbuffer(ctx, k, G, C)) is not None}
    coherent = ctx.entry["options"].get("coherence", True)
    starts = {k: (cand_prev or {}).get(k, (prev or {}).get(k)) for k in reflectors} if coherent else {}
    starts = {k: v for k, v in starts.items() if v is not None}
    same_starts = all(np.array_equal(v, (prev or {}).get(k)) for k, v in starts.items())
    if not given and same_starts:
        return
    o = ctx.oracle()
    if ctx.case not in drivers:
        drivers[ctx.case] = reference_driver(o.scene, o.case.options)
    driver = drivers[ctx.case]
    driver.method.given = given
    driver.method.previous = dict(starts)
    frame = driver.render_frame(ctx.frame)
    ctx.stages = {k: frame.reflectors[k].state.gbuffer for k in given}
    ctx.reference = frame.arrays
    ctx.reference_starts = starts


def saved_rounding(gb, eye, vertices, pixels, inverse=None) -> np.ndarray:
    """A bound on how much the score at each pixel changes when the G-buffer ``gb`` holds a
    candidate's positions as saved, world-space float32 (each coordinate within half an ULP of
    the candidate's own, then rounded again relative to the origin), rather than the values its
    search read: that error times :func:`refsoft.conformance.precision.position_sensitivity`."""
    from .precision import position_sensitivity
    from .rules.common import f32_ulp

    pix = np.asarray(pixels, dtype=np.int64).reshape(-1, 2)
    rel = gb.position[pix[:, 0], pix[:, 1]].astype(np.float64)
    world = rel + gb.origin
    q = 0.5 * np.sqrt(3.0) * (f32_ulp(np.abs(world).max(axis=1)) + f32_ulp(np.abs(rel).max(axis=1)))
    return q * position_sensitivity(gb, eye, vertices, pix, inverse)
