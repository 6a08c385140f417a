"""Per-frame reflection stage for a whole scene: each visible reflector's G-buffer (closed
proxy, optionally widened frustum), the search for every vertex of every non-reflector object,
and the virtual vertices (DESIGN section 1, first three stages).

Vertices to reflect are those of every non-reflector object, concatenated in scene order, each
in file order; ``vertex_object`` gives each one's object id.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import RefsoftError
from ..raster import GBuffer, gbuffer
from ..scene.model import Scene
from . import SearchResult, search, virtual_vertices


def scene_vertices(scene: Scene, frame: int = 0, meshes=None):
    """World-space vertices of every non-reflector object.

    ``meshes`` (optional) are the world meshes of all objects at ``frame``, already computed.

    Returns
    -------
    vertices : ndarray, shape (N, 3), float64
    vertex_object : ndarray, shape (N,), int32
        1-based object id of each vertex.
    """
    verts, ids = [], []
    for k, obj in enumerate(scene.objects, start=1):
        if obj.reflector:
            continue
        m = scene.world_mesh(k, frame) if meshes is None else meshes[k - 1]
        verts.append(m.vertices)
        ids.append(np.full(m.n_vertices, k, dtype=np.int32))
    if not verts:
        return np.zeros((0, 3)), np.zeros(0, dtype=np.int32)
    return np.concatenate(verts), np.concatenate(ids)


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
    if reflector not in scene.reflector_ids:
        raise RefsoftError(f"object {reflector} of scene {scene.name!r} is not a reflector "
                           f"(reflectors: {scene.reflector_ids})")
    cam = gbuffer_camera(scene, frame, widen, size)
    return gbuffer(scene.world_mesh(reflector, frame, proxy=True), cam, precision, origin=cam.eye)


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
    """

    reflector: int
    gbuffer: GBuffer
    result: SearchResult
    virtual: np.ndarray
    virtual64: np.ndarray | None = None
    surface: tuple | None = None


def reflect(scene: Scene, frame: int = 0, reflectors=None, neighbourhood="cross", inverse="plane", widen=1.0,
            gbuffer_size=None, precision="float32", previous=None, cap=None):
    """Run the reflection stage for each reflector (each independently).

    Parameters
    ----------
    scene : Scene
    frame : int
    reflectors : list of int, optional
        Object ids (default: every reflector).
    neighbourhood, inverse, cap
        As :func:`refsoft.search.search`.
    widen : float
        Wider-frustum factor for the G-buffer.
    gbuffer_size : (int, int), optional
        G-buffer (width, height); default the view's pixel density.
    precision : {"float32", "float64"}
    previous : dict of int -> ndarray (N, 2), optional
        Last frame's reflection pixels per reflector (coherence).

    Returns
    -------
    vertices : ndarray (N, 3) float64
    vertex_object : ndarray (N,) int32
    reflections : dict of int -> Reflection
    """
    if not 0 <= frame < scene.n_frames and scene.animation is not None:
        raise RefsoftError(f"frame must be in [0, {scene.n_frames - 1}], got {frame}")
    ids = scene.reflector_ids if reflectors is None else list(reflectors)
    verts, owner = scene_vertices(scene, frame)
    out = {}
    for k in ids:
        prev = None if previous is None else previous.get(k)
        out[k], _, _ = reflect_one(scene, k, frame, verts, neighbourhood, inverse, widen, gbuffer_size, precision,
                                   prev, cap)
    return verts, owner, out


def reflect_one(scene, k, frame, verts, neighbourhood, inverse, widen, gbuffer_size, precision, previous, cap):
    """One reflector's G-buffer, search and virtual vertices. Returns (Reflection, G-buffer ms,
    search ms). A previous pixel array of the wrong length (the vertex count changed) is
    ignored; previous pixels outside the G-buffer restart."""
    import time

    t0 = time.perf_counter()
    gb = reflector_gbuffer(scene, k, frame, widen, gbuffer_size, precision)
    t1 = time.perf_counter()
    prev = coherent_starts(previous, len(verts), gb.mask.shape)
    res = search(gb, scene.camera_at(frame).eye, verts, neighbourhood, inverse, prev, cap)
    refl = Reflection(k, gb, res, virtual_vertices(gb, res, verts))
    return refl, 1000 * (t1 - t0), 1000 * (time.perf_counter() - t1)


def coherent_starts(previous, n, shape):
    """Last frame's reflection pixels as search starts: None when there are none or their
    count is not ``n`` (the vertex count changed); pixels outside a G-buffer of ``shape``
    (it changed size) become (-1, -1), a restart."""
    if previous is None or np.shape(previous) != (n, 2):
        return None
    prev = np.asarray(previous)
    return np.where(np.any((prev < 0) | (prev >= np.array(shape)), axis=1)[:, None], -1, prev)
