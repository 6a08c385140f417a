"""The reflection-method seam (spec section 1): what the frame driver gives a reflection method
for one reflector, and what the method gives back.

The driver (:mod:`refsoft.frame.driver`) rasterizes the main view, then, for each reflector ``k``
in scene order, calls ``method.reflect(view, k, stencil)`` and composites the result the same way
for every method. A method is any object with

``name`` : str
    Its name in ``stats.json``.
``stages`` : tuple of str
    The timing keys it reports (``stats.json`` lists them before ``main`` and ``composite``).
``pixel_arrays`` : dict of str -> (trailing shape, dtype) or (trailing shape, dtype, fill)
    Frame-wide per-pixel arrays it fills at the pixels it covers (``fill``, default zero,
    elsewhere), e.g. the truth's ``reflected_hit``.
``reflect(view, k, stencil) -> ReflectorResult``
    Called for every reflector, also when its stencil is empty (a method may keep per-reflector
    state from frame to frame: the vertex search's coherence).
``frame_report(results) -> dict``
    What ``stats.json`` records of the frame beside the timings, from the reflectors' results.
``leading_axis_arrays`` : tuple of str (optional)
    Pixel arrays with one trailing axis that the frame stores with that axis first, (K, H, W):
    the layered depth textures' ``ldt_object_distance``.
``run_files() -> dict of str -> dict of arrays`` (optional)
    Files written once per run beside the frames, after the first (``NAME.npz``): the layered
    depth textures' ``ldt_J``.

Methods: :class:`refsoft.search.method.VertexSearch` (the vertex search, the main method),
:class:`refsoft.ldt.LayeredDepthTextures` (the per-pixel comparison method) and
:class:`refsoft.truth.raytrace.RayTracedTruth` (the ray-traced truth).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from .scene.model import Scene, scene_vertices


@dataclass(eq=False)
class FrameView:
    """One frame as every reflection method sees it.

    Attributes
    ----------
    scene : Scene
    frame : int
    camera : Camera
        The view camera at this frame.
    meshes : list of Mesh
        World meshes of every object at this frame (object id ``k`` is ``meshes[k - 1]``).
    view : refsoft.raster.ColorPass
        The main view: ``color`` (H, W, 3) float32, ``object_id`` (H, W) int32, ``triangle``
        (H, W) int64 (the visible triangle of that object, -1 none), ``depth``.
    transforms : dict of int -> Transform
        Each object's transform at this frame.
    """

    scene: Scene
    frame: int
    camera: object
    meshes: list
    view: object
    transforms: dict

    @cached_property
    def vertices(self) -> np.ndarray:
        """(N, 3) float64: every non-reflector object's world vertices, in scene order, each
        object in file order (the vertices the vertex search reflects)."""
        return self._reflected[0]

    @cached_property
    def vertex_object(self) -> np.ndarray:
        """(N,) int32: the object id of each of :attr:`vertices`."""
        return self._reflected[1]

    @cached_property
    def _reflected(self):
        return scene_vertices(self.scene, self.frame, self.meshes)


@dataclass(eq=False)
class ReflectorResult:
    """What a reflection method returns for one reflector of one frame.

    Attributes
    ----------
    reflector : int
        Object id.
    box : (r0, r1, c0, c1) or None
        The rows and columns over which ``colour``, ``reflected_id`` and ``covered`` are given
        (the stencil's bounding box, or the whole view); None when the reflector shows nothing.
    colour : ndarray (h, w, 3) float32
        The reflected colour (the reflector's own colour is blended in by the composite).
    reflected_id : ndarray (h, w) int32
        The object seen in the reflection.
    covered : ndarray (h, w) bool
        Pixels of the stencil where the reflection shows an object.
    arrays : dict
        This reflector's spec section 7 arrays, by key (:mod:`refsoft.keys`), in output order.
    pixels : dict
        Per-pixel arrays over ``box`` named in the method's ``pixel_arrays``.
    pixel_mask : ndarray (h, w) bool, optional
        Where over ``box`` the driver copies ``pixels`` into the frame (default ``covered``; the
        LDT gives its whole stencil, so that pixels without a hit keep their counts and flags).
    time_ms : dict
        Milliseconds per stage.
    report : dict
        What ``frame_report`` needs (skips taken, counts).
    state : object
        The method's own intermediates (the vertex search: a
        :class:`refsoft.search.reflect.Reflection` with the G-buffer and the search result), for
        golden sets, checks and traces.
    """

    reflector: int
    box: tuple | None = None
    colour: np.ndarray | None = None
    reflected_id: np.ndarray | None = None
    covered: np.ndarray | None = None
    arrays: dict = field(default_factory=dict)
    pixels: dict = field(default_factory=dict)
    pixel_mask: np.ndarray | None = None
    time_ms: dict = field(default_factory=dict)
    report: dict = field(default_factory=dict)
    state: object = None


def stencil_box(stencil) -> tuple:
    """``(r0, r1, c0, c1)``: the bounding box of a non-empty (H, W) bool stencil (rows r0..r1-1,
    columns c0..c1-1)."""
    rows = np.flatnonzero(stencil.any(axis=1))
    cols = np.flatnonzero(stencil.any(axis=0))
    return int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1
