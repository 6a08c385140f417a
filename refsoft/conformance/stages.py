"""The oracle run on a candidate's own inputs to a stage (``refsoft check --profile gpu``).

A port that interpolates its G-buffer its own way searches that G-buffer, not refsoft's: its
search, virtual vertices and image follow from it. The ``gpu`` profile judges the G-buffer
against the golden one within its tolerances, and everything after it against the oracle run
on the candidate's G-buffer as saved, starting each coherent search at the candidate's own
pixel of the previous frame: :class:`GivenGBufferSearch` is the vertex search with those inputs,
:func:`reference_driver` a frame driver around it.
"""

from __future__ import annotations

import time

import numpy as np

from ..search import search
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
        res = search(gb, view.camera.eye, view.vertices, opt.neighbourhood, opt.inverse, prev, opt.cap,
                     method=opt.method)
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
