"""The vertex search's first stages for one reflector (spec section 1): the G-buffer camera and
G-buffer of its closed proxy, the coherent start pixels, and :class:`Reflection`, the record of
one reflector's G-buffer, search and virtual vertices; :func:`reflect` runs them for a whole
scene at one frame.

Vertices to reflect are those of every non-reflector object, concatenated in scene order, each
in file order (:func:`refsoft.scene.scene_vertices`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import validate
from ..errors import RefsoftError
from ..raster import GBuffer, gbuffer
from ..scene.model import Scene


def gbuffer_camera(scene: Scene, frame: int = 0, widen: float = 1.0, size=None):
    """The camera a reflector's G-buffer is rendered with: the view camera, widened by
    ``widen`` (Estalella 5.2) at ``size = (width, height)`` (default: the view's pixel density)."""
    cam = scene.camera_at(frame)
    if widen == 1.0 and size is None:
        return cam
    w, h = (None, None) if size is None else size
    return cam.widened(widen, w, h)


def reflector_gbuffer(scene: Scene, reflector: int, frame: int = 0, widen: float = 1.0, size=None,
                      precision="float32") -> GBuffer:
    """G-buffer of one reflector (its closed proxy when it has one), positions relative to the
    eye (float32 keeps its precision far from the world origin)."""
    check_reflector(scene, reflector)
    cam = gbuffer_camera(scene, frame, widen, size)
    return gbuffer(scene.world_mesh(reflector, frame, proxy=True), cam, precision, origin=cam.eye)


def check_reflector(scene: Scene, reflector) -> int:
    """``reflector`` must be the object id of one of ``scene``'s reflectors."""
    n = len(scene.objects)
    if not validate.is_integer(reflector) or not 1 <= reflector <= n:
        raise RefsoftError(f"scene {scene.name!r} has no object {reflector!r} (object ids are 1..{n}; "
                           f"reflectors: {scene.reflector_ids})")
    if reflector not in scene.reflector_ids:
        raise RefsoftError(f"object {reflector} ({scene.objects[reflector - 1].name!r}) of scene {scene.name!r} is "
                           f"not a reflector (reflectors: {scene.reflector_ids})")
    return int(reflector)


@dataclass(frozen=True, eq=False)
class Reflection:
    """One reflector's reflection stage for one frame.

    Attributes
    ----------
    reflector : int
        Object id.
    gbuffer : GBuffer
    result : SearchResult
    virtual : ndarray, shape (N, 3)
        Virtual vertices, world space, in the G-buffer's precision (the output).
    virtual64 : ndarray, shape (N, 3), float64, optional
        The same, computed relative to the G-buffer's origin and moved to world space in
        float64 (no rounding of large world coordinates): what the virtual raster draws.
    surface : (P, N, offset), optional
        Sub-texel reflection points when refined (:func:`refsoft.search.refine.refine`).
    images : Images, optional
        Every reflection point of every vertex (spec section 4.8), where the enumeration ran
        (``images="all"`` on a reflector that can give two: :mod:`refsoft.search.convex`).
    """

    reflector: int
    gbuffer: GBuffer
    result: object
    virtual: np.ndarray
    virtual64: np.ndarray | None = None
    surface: tuple | None = None
    images: object = None


def reflect(scene: Scene, frame: int = 0, reflectors=None, previous=None, **options):
    """Run the vertex search's G-buffer, search and virtual-vertex stages for each reflector of
    one frame (no virtual raster, no composite).

    Parameters
    ----------
    scene : Scene
    frame : int
    reflectors : list of int, optional
        Object ids (default: every reflector).
    previous : dict of int -> ndarray (N, 2), optional
        Last frame's reflection pixels per reflector (coherence).
    **options
        :class:`refsoft.RenderOptions` fields (``method``, ``neighbourhood``, ``inverse``,
        ``widen``, ``gbuffer_size``, ``precision``, ``cap``, ``refine``, ...).

    Returns
    -------
    vertices : ndarray (N, 3) float64
    vertex_object : ndarray (N,) int32
    reflections : dict of int -> Reflection
    """
    from ..options import RenderOptions
    from ..seam import FrameView
    from .method import VertexSearch

    if scene.animation is not None and not 0 <= frame < scene.n_frames:
        raise RefsoftError(f"frame must be in [0, {scene.n_frames - 1}], got {frame}")
    ids = scene.reflector_ids if reflectors is None else [check_reflector(scene, k) for k in reflectors]
    method = VertexSearch(scene, RenderOptions(**{"reuse": False, **options}))
    method.previous = dict(previous or {})
    meshes = [scene.world_mesh(k, frame) for k in range(1, len(scene.objects) + 1)]
    view = FrameView(scene, frame, scene.camera_at(frame), meshes, None,
                     {j: scene.transform_at(j, frame) for j in range(1, len(scene.objects) + 1)})
    out = {k: method.reflection(view, k)[0] for k in ids}
    return view.vertices, view.vertex_object, out


def coherent_starts(previous, n, shape):
    """Last frame's reflection pixels as search starts: None when there are none or their
    count is not ``n`` (the vertex count changed); pixels outside a G-buffer of ``shape``
    (it changed size) become (-1, -1), a restart."""
    if previous is None or np.shape(previous) != (n, 2):
        return None
    prev = np.asarray(previous)
    r, c = prev[:, 0], prev[:, 1]  # (a reduction along the rows' two entries costs three times more)
    return np.where(((r < 0) | (r >= shape[0]) | (c < 0) | (c >= shape[1]))[:, None], -1, prev)
