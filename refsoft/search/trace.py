"""Step-by-step replay of one search: the kernel's own code run with a record buffer.

A :class:`Trace` prints as a table, saves as JSON (what a port author diffs against) and draws
the vertex's score field over the reflector with the path (``trace.png``) and one frame per
step (``trace.gif``).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field

import numpy as np

from .._parallel import parallel_range
from ..errors import RefsoftError
from . import _kernels

CANDIDATE_NAMES = ("current", "left", "up", "right", "down", "up-left", "up-right", "down-right", "down-left")
_STATUS = {_kernels.EVALUATED: "evaluated", _kernels.UNCOVERED: "uncovered", _kernels.OUTSIDE: "outside"}


@dataclass
class Trace:
    """One search, step by step.

    Attributes
    ----------
    steps : list of dict
        Per iteration: ``phase`` ("standard" or "inverse"), ``pixel`` [row, col], ``candidates``
        (name, pixel, status, score or None, in visiting order) and ``move_to`` (pixel or None).
    pixel, score, margin, iterations, flags : the search's result (equal to :func:`search`'s).
    start : [row, col]; restarted : bool (a coherence start that was not covered).
    score_map : ndarray, shape (H, W)
        The standard score of this vertex at every covered pixel (NaN elsewhere).
    """

    vertex: np.ndarray
    eye: np.ndarray
    neighbourhood: str
    inverse: str
    cap: int
    start: list
    restarted: bool
    steps: list
    pixel: list
    score: float
    margin: float
    iterations: int
    flags: int
    stop: str
    score_map: np.ndarray = field(repr=False)
    inverse_map: np.ndarray | None = field(default=None, repr=False)

    def to_dict(self) -> dict:
        from . import flag_names

        return {
            "vertex": [float(x) for x in self.vertex], "eye": [float(x) for x in self.eye],
            "neighbourhood": self.neighbourhood, "inverse": self.inverse, "cap": self.cap,
            "start": self.start, "restarted": self.restarted, "steps": self.steps,
            "result": {"pixel": self.pixel, "score": self.score, "margin": self.margin,
                       "iterations": self.iterations, "flags": self.flags, "flag_names": flag_names(self.flags),
                       "stop": self.stop},
        }

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), indent=1)

    def table(self) -> str:
        """The steps as a text table: one row per iteration, one column per candidate."""
        from . import flag_names

        n_cand = 5 if self.neighbourhood == "cross" else 9
        names = CANDIDATE_NAMES[:n_cand]
        head = f"{'step':>4} {'phase':<8} {'pixel':<12}" + "".join(f"{n:>11}" for n in names) + "  move"
        lines = [head, "-" * len(head)]
        for i, s in enumerate(self.steps, 1):
            cells = []
            chosen = None if s["move_to"] is None else s["move_to"]
            for cand in s["candidates"]:
                if cand["status"] != "evaluated":
                    cells.append(f"{cand['status'][:9]:>11}")
                else:
                    mark = "*" if chosen is not None and cand["pixel"] == chosen else " "
                    cells.append(f"{cand['score']:>10.6f}{mark}")
            move = "stop" if chosen is None else f"-> ({chosen[0]}, {chosen[1]})"
            pix = f"({s['pixel'][0]}, {s['pixel'][1]})"
            lines.append(f"{i:>4} {s['phase']:<8} {pix:<12}" + "".join(cells) + "  " + move)
        lines.append(f"result: pixel ({self.pixel[0]}, {self.pixel[1]}), score {self.score:.8f}, margin "
                     f"{self.margin:.3g}, {self.iterations} iterations, stop: {self.stop}, flags: "
                     f"{', '.join(flag_names(self.flags)) or 'none'}")
        return "\n".join(lines)

    def path(self) -> np.ndarray:
        """Pixels visited, in order, shape (S, 2) (the end pixel last)."""
        pts = [s["pixel"] for s in self.steps]
        return np.array(pts, dtype=np.int64).reshape(-1, 2)


def trace_search(gbuffer, eye, vertex, neighbourhood="cross", inverse="plane", previous=None, cap=None) -> Trace:
    """Replay the search of one vertex (same arguments as :func:`refsoft.search.search`, for a
    single vertex, ``vertex`` shape (3,), ``previous`` a pixel or None)."""
    from .. import validate
    from . import NEIGHBOURHOODS, _check_options, _packed, start_pixel

    if neighbourhood == "hierarchy":
        raise RefsoftError("trace_search replays the linear search; for the hierarchy use "
                           "refsoft.search.trace_hierarchy")
    dt, cap = _check_options(gbuffer, neighbourhood, inverse, cap)
    v = validate.point(vertex, "vertex")
    e = validate.point(eye, "eye")
    h, w = gbuffer.mask.shape
    start = start_pixel(gbuffer.mask)
    if start is None:
        raise RefsoftError("the reflector covers no pixel of its G-buffer: there is nothing to search")
    restarted = False
    if previous is not None and tuple(previous) != (-1, -1):
        pr, pc = int(previous[0]), int(previous[1])
        if not (0 <= pr < h and 0 <= pc < w):
            raise RefsoftError(f"previous pixel {previous} is outside the {h}x{w} G-buffer")
        if gbuffer.mask[pr, pc]:
            start = (pr, pc)
        else:
            restarted = True
    G, M, fp, (r0, c0) = _packed(gbuffer, e)
    v_rel = (v - gbuffer.origin).astype(dt)
    record = np.zeros((2 * cap + 2, _kernels.RECORD_WIDTH), dtype=np.float64)
    n_cand = NEIGHBOURHOODS[neighbourhood]
    r, c, s, m, it, fl, n_rec = _kernels.search_one(G, M, v_rel, start[0] - r0, start[1] - c0, n_cand, cap,
                                                    inverse == "search", fp, record,
                                                    np.empty((2, 9), dtype=dt), np.zeros((2, 9), dtype=bool))
    r, c = r + r0, c + c0
    record[:n_rec, 1] += r0
    record[:n_rec, 2] += c0
    if restarted:
        fl |= _kernels.RESTARTED
    steps = _steps(record[:n_rec], n_cand)
    capped_last = bool(steps) and steps[-1]["move_to"] is not None
    field_std = np.full((h, w), np.nan, dtype=dt)
    parallel_range(_kernels.score_field, M.shape[0], G, M, v_rel, False, fp,
                   field_std[r0:r0 + M.shape[0], c0:c0 + M.shape[1]])
    field_inv = None
    if any(st["phase"] == "inverse" for st in steps):
        field_inv = np.full((h, w), np.nan, dtype=dt)
        parallel_range(_kernels.score_field, M.shape[0], G, M, v_rel, True, fp,
                       field_inv[r0:r0 + M.shape[0], c0:c0 + M.shape[1]])
    return Trace(v, e, neighbourhood, inverse, cap, [int(start[0]), int(start[1])], restarted, steps,
                 [int(r), int(c)], float(s), float(m), int(it), int(fl), "capped" if capped_last else "converged",
                 field_std, field_inv)


def _steps(record, n_cand):
    """The steps of a search's record (``_kernels.walk``'s rows) as :class:`Trace` steps."""
    steps = []
    for row in record:
        pr, pc = int(row[1]), int(row[2])
        cands = []
        for k in range(n_cand):
            status = int(row[4 + k])
            pix = [pr + int(_kernels.OFFSETS[k, 0]), pc + int(_kernels.OFFSETS[k, 1])]
            cands.append({"name": CANDIDATE_NAMES[k], "pixel": pix, "status": _STATUS[status],
                          "score": float(row[4 + 9 + k]) if status == _kernels.EVALUATED else None})
        chosen = int(row[3])
        move = None if chosen < 0 else cands[chosen]["pixel"]
        steps.append({"phase": "standard" if row[0] == 0 else "inverse", "pixel": [pr, pc], "candidates": cands,
                      "move_to": move})
    return steps


def trace_bounce(bounce, gb, vertex, neighbourhood="cross", cap=None, previous=None) -> Trace:
    """Replay one vertex's search at a later bounce (:func:`refsoft.search.bounces.search_bounce`,
    each pixel's eye its own) on the bounce's G-buffer ``gb``
    (:func:`refsoft.search.bounces.gbuffer_of`): the same walk and start (from ``previous``, its
    view pixel at the previous frame's bounce, where the search would), recorded. Pixels are
    the G-buffer's (the bounce's box); ``eye`` is the eye of the pixel the search ended at."""
    from .. import validate
    from . import NEIGHBOURHOODS, default_cap
    from . import _bounces
    from .bounces import _starts, own_starts

    v = validate.point(vertex, "vertex")
    if not gb.mask.any():
        raise RefsoftError("the bounce covers no pixel: there is nothing to search")
    dt = gb.position.dtype.type
    fp = dt(0)
    h, w = gb.mask.shape
    cap = default_cap((h, w)) if cap is None else int(cap)
    G = np.zeros((h, w, 9), dtype=dt)
    eye_rel = np.ascontiguousarray((bounce.eye - gb.origin).astype(dt))
    parallel_range(_bounces.pack_eyes, h, gb.position, gb.normal, gb.mask, eye_rel, fp, G)
    v_rel = (v - gb.origin).astype(dt)
    own, restarted = own_starts(bounce, previous, 1)
    start = _starts(G, gb.mask, v_rel[None], own)[0]
    record = np.zeros((2 * cap + 2, _kernels.RECORD_WIDTH), dtype=np.float64)
    n_cand = NEIGHBOURHOODS[neighbourhood]
    r, c, s, m, it, fl, n_rec = _kernels.search_one(G, gb.mask, v_rel, int(start[0]), int(start[1]), n_cand, cap,
                                                    False, fp, record, np.empty((2, 9), dtype=dt),
                                                    np.zeros((2, 9), dtype=bool))
    steps = _steps(record[:n_rec], n_cand)
    capped_last = bool(steps) and steps[-1]["move_to"] is not None
    field = np.full((h, w), np.nan, dtype=dt)
    parallel_range(_kernels.score_field, h, G, gb.mask, v_rel, False, fp, field)
    fl |= _kernels.RESTARTED if restarted[0] else 0
    return Trace(v, np.asarray(bounce.eye[r, c], np.float64), neighbourhood, "discard", cap,
                 [int(start[0]), int(start[1])], bool(restarted[0]), steps, [int(r), int(c)], float(s), float(m),
                 int(it), int(fl),
                 "capped" if capped_last else "converged", field, None)


@dataclass
class HierarchyTrace:
    """One ray-cone hierarchy traversal, replayed (:func:`refsoft.search.trace_hierarchy`).

    Attributes
    ----------
    steps : list of dict
        ``{"attempt", "level", "texel", "event"}`` in order; events are ``popped``, ``pushed``
        (its cone contains the vertex), ``rejected`` and ``chosen`` (the base pixel). Level-0
        texels are G-buffer pixels; higher levels index the pyramid over the cropped box whose
        first pixel is ``origin``.
    pixel : [row, col] or None
        The pixel chosen.
    tests : int
        Texels tested (the search's ``iterations``).
    levels : int
        Pyramid levels.
    base_size : int
        Edge of the pyramid's base (a power of two).
    origin : [row, col]
        The G-buffer pixel of the pyramid's first texel.
    """

    steps: list
    pixel: list | None
    tests: int
    levels: int
    base_size: int
    origin: list

    def path(self) -> list:
        """``[level, row, col]`` of every texel popped, then of the chosen base pixel."""
        return [[s["level"], *s["texel"]] for s in self.steps if s["event"] in ("popped", "chosen")]

    def to_dict(self) -> dict:
        """JSON-ready fields."""
        return {"steps": self.steps, "pixel": self.pixel, "tests": self.tests, "levels": self.levels,
                "base_size": self.base_size, "origin": self.origin}


@dataclass
class VertexReplay:
    """One vertex's search in one reflector of a scene, replayed (:func:`trace_vertex`).

    Attributes
    ----------
    scene : str
    reflector, frame, vertex : int
        ``vertex`` indexes the non-reflector vertices in scene order.
    vertex_object : int
        The vertex's object id; ``local_index`` its index within that object.
    method : str
    trace : Trace or HierarchyTrace
    gbuffer : GBuffer
        The G-buffer searched.
    eye, position : ndarray, shape (3,), float64
        The eye and the vertex, world space, at the frame (what the viewer's side view draws; at a
        later bounce the eye of the pixel the search ended at).
    through : tuple of int
        At a later bounce (:func:`trace_vertex_bounce`), the reflectors of the path, the first
        reflector first and ``reflector`` last; empty for the first bounce.
    """

    scene: str
    reflector: int
    frame: int
    vertex: int
    vertex_object: int
    local_index: int
    method: str
    trace: object
    gbuffer: object
    eye: np.ndarray = field(default=None, repr=False)
    position: np.ndarray = field(default=None, repr=False)
    through: tuple = ()

    def to_dict(self) -> dict:
        """``trace.json``: the trace's fields and where it comes from."""
        data = self.trace.to_dict()
        data.update(scene=self.scene, reflector=self.reflector, frame=self.frame, vertex_index=self.vertex,
                    vertex_object=self.vertex_object)
        if self.method == "hierarchy":
            data["method"] = "hierarchy"
        if self.through:
            data["through"] = list(self.through)
            data["box"] = list(self.gbuffer_box)
        return data

    @property
    def gbuffer_box(self):
        """At a later bounce, the view pixels (r0, r1, c0, c1) its G-buffer covers (its pixels are
        relative to r0, c0)."""
        return getattr(self, "_box", None)


def trace_vertex(scene, vertex: int, reflector=None, frame: int = 0, coherence: bool = True,
                 **options) -> VertexReplay:
    """Replay one vertex's search in one reflector, as a render of ``frame`` runs it.

    With coherence (the walk), the vertex's searches of frames ``0 .. frame - 1`` run first, so
    the replayed search starts where the render's does.

    Parameters
    ----------
    scene : Scene
    vertex : int
        Index into the vertices of the non-reflector objects, in scene order.
    reflector : int, optional
        Object id (default: the first reflector).
    frame : int
    coherence : bool
    **options
        ``method``, ``neighbourhood``, ``inverse``, ``widen``, ``precision``
        (:class:`refsoft.RenderOptions`).

    Returns
    -------
    VertexReplay
    """
    from .. import validate
    from ..options import RenderOptions
    from ..scene.model import scene_vertices
    from . import search, trace_hierarchy
    from .reflect import check_reflector, reflector_gbuffer

    opts = RenderOptions(coherence=coherence, **options)
    validate.integer(frame, "frame", 0, None if scene.animation is None else scene.n_frames - 1)
    if not scene.reflector_ids:
        raise RefsoftError(f"scene {scene.name!r} has no reflector")
    k = scene.reflector_ids[0] if reflector is None else check_reflector(scene, reflector)
    verts, owner = scene_vertices(scene, frame)
    validate.integer(vertex, "vertex", 0, len(verts) - 1)
    gb = reflector_gbuffer(scene, k, frame, opts.widen, None, opts.precision)
    eye = scene.camera_at(frame).eye
    obj = int(owner[vertex])
    local = vertex - int(np.argmax(owner == obj))
    if opts.method == "hierarchy":
        tr = trace_hierarchy(gb, eye, verts[vertex])
        return VertexReplay(scene.name, k, frame, vertex, obj, local, "hierarchy", tr, gb, eye, verts[vertex])
    walk = dict(neighbourhood=opts.neighbourhood, inverse=opts.inverse)
    previous = None
    if coherence:  # this vertex's searches of the earlier frames
        for f in range(frame):
            gb_f = reflector_gbuffer(scene, k, f, opts.widen, None, opts.precision)
            v_f, _ = scene_vertices(scene, f)
            res = search(gb_f, scene.camera_at(f).eye, v_f[vertex:vertex + 1],
                         previous=None if previous is None else previous[None], **walk)
            previous = res.pixel[0]
    tr = trace_search(gb, eye, verts[vertex], previous=previous, **walk)
    return VertexReplay(scene.name, k, frame, vertex, obj, local, "walk", tr, gb, eye, verts[vertex])


def trace_vertex_bounce(scene, vertex: int, through, frame: int = 0, coherence: bool = True,
                        **options) -> VertexReplay:
    """Replay one vertex's search at a later bounce (spec section 5.1): on the G-buffer of the
    last reflector of ``through`` as seen along that path of reflectors, as a render of
    ``frame`` with ``bounces = len(through)`` runs it (frames ``0 .. frame`` rendered first with
    coherence, as the render's levels start from them).

    Parameters
    ----------
    scene : Scene
    vertex : int
        Index into the vertices of the non-reflector objects, in scene order.
    through : sequence of int
        Reflector ids, the first reflector first (at least two).
    frame : int
    coherence : bool
    **options
        :class:`refsoft.RenderOptions` fields (``bounces`` is ``len(through)``).

    Returns
    -------
    VertexReplay
        Pixels in the bounce's G-buffer (its box, ``gbuffer_box``).
    """
    from .. import validate
    from ..frame.driver import FrameDriver
    from ..options import RenderOptions
    from ..scene.model import scene_vertices
    from .bounces import gbuffer_of
    from .reflect import check_reflector

    path = tuple(check_reflector(scene, k) for k in through)
    if len(path) < 2 or len(path) > 8:
        raise RefsoftError(f"through must name 2 to 8 reflectors (the first bounce's first), got {list(through)}")
    validate.integer(frame, "frame", 0, None if scene.animation is None else scene.n_frames - 1)
    opts = RenderOptions(coherence=coherence, bounces=len(path), **options)
    _check_twice(scene, path, opts)
    verts, owner = scene_vertices(scene, frame)
    validate.integer(vertex, "vertex", 0, len(verts) - 1)
    driver = FrameDriver(scene, opts)
    for f in range(frame + 1 if coherence else 0):
        driver.render_frame(f)
    if not coherence:
        driver.render_frame(frame)
    kept = driver.method.kept_bounces
    bounce = kept.get(path)
    if bounce is None:
        seen = ", ".join("->".join(str(k) for k in p) for p in sorted(kept)) or "none"
        raise RefsoftError(f"frame {frame} shows no bounce along {'->'.join(map(str, path))} (paths drawn: {seen})")
    camera = scene.camera_at(frame)
    gb = gbuffer_of(bounce, camera, opts.precision)
    prev = driver.method.later_starts.previous(path, 0, len(verts)) if coherence else None
    tr = trace_bounce(bounce, gb, verts[vertex], opts.neighbourhood, opts.cap, None if prev is None else prev[vertex])
    obj = int(owner[vertex])
    local = vertex - int(np.argmax(owner == obj))
    rp = VertexReplay(scene.name, path[-1], frame, vertex, obj, local, "walk", tr, gb, tr.eye, verts[vertex], path)
    rp._box = bounce.box
    return rp


def _check_twice(scene, path, opts):
    """Refuse a path that takes one reflector twice in a row where no walk draws that level: a
    reflector that cannot see itself (convex or flat), or one that can under ``images="all"``
    (the accurate preset: such a level is drawn by its pixels' rays). With ``images="one"`` (the
    paper preset) the level is searched by walks from each pixel's eye, and replayed."""
    from .meet import sees_itself

    for a, b in zip(path, path[1:]):
        if a != b:
            continue
        if not sees_itself(scene, a):
            raise RefsoftError(f"through names reflector {a} twice in a row ({list(path)}), but it cannot see itself "
                               "(convex or flat): no path takes it twice")
        if opts.images == "all":
            raise RefsoftError(f"through names reflector {a} twice in a row ({list(path)}): with every image "
                               "(the accurate preset) that level is drawn by its pixels' rays, with no walk to "
                               "replay; add --preset paper to replay the walk of the papers' method there, or "
                               f"compare refsoft render and refsoft truth --bounces {len(path)} for the rays' paths")


def trace_vertex_images(scene, replay: VertexReplay):
    """How the enumeration of every image (spec section 4.8) finds the replayed vertex's images
    in its reflector: an :class:`refsoft.search.images.ImagesTrace`, or None when the
    reflector cannot give two reflection points (:mod:`refsoft.search.convex`: nothing is
    enumerated there)."""
    from .convex import several_possible
    from .images import facing_gbuffer, trace_images

    obj = scene.objects[replay.reflector - 1]
    if not several_possible(obj.closed_proxy if obj.closed_proxy is not None else obj.mesh):
        return None
    return trace_images(facing_gbuffer(replay.gbuffer, replay.eye), replay.eye, replay.position, replay.trace.pixel)
