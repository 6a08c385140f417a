"""The vertex search as a reflection method (spec sections 1, 4 and 5; the seam is
:mod:`refsoft.seam`).

Per reflector and frame: the G-buffer of its closed proxy (optionally widened), the search of
every non-reflector vertex (coherent with the last frame), the virtual vertices (optionally from
sub-texel points), then the virtual scene (optionally tessellated) rasterized inside the
reflector's stencil. The exact skips of :mod:`refsoft.search.skips` leave every output
bit-identical.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from .. import constants, keys, limits
from .._parallel import parallel_range
from ..raster import PRECISIONS, GBuffer, _setup, gbuffer
from ..raster._kernels import world_positions
from ..seam import ReflectorResult, stencil_box
from . import BORDER, CULLED, RESTARTED, SEVERAL, SearchResult, levels, search, skips, virtual_vertices
from .convex import several_possible
from .exact import edges_pass, exact_pass
from .images import facing_gbuffer, find_images
from .reflect import Reflection, coherent_starts, gbuffer_camera
from .refine import refine as refine_points
from .virtual import reflected_mesh, refined_parts, virtual_parts, virtual_pass, with_mirror_copies


@dataclass
class _Last:
    """What the method remembers of a reflector's last frame, for the reuse skip."""

    key: tuple  # (G-buffer camera key, reflector transform, widen used)
    gbuffer: object
    result: object
    transforms: dict  # object id -> Transform of the vertices searched


def empty_gbuffer(camera, precision) -> GBuffer:
    """The G-buffer the rasterizer makes of a mesh it draws no pixel of (the eye as origin)."""
    dt = PRECISIONS[precision]
    h, w = camera.height, camera.width
    return GBuffer(limits.zeros((h, w, 3), dt), limits.zeros((h, w, 3), dt), limits.zeros((h, w), bool),
                   (0, 0, np.zeros((0, 0), np.float32)), (0, 0, np.zeros((0, 0), np.int32)),
                   camera.view_proj(), np.asarray(camera.eye, dtype=np.float64))


def gbuffer_outputs(gb: GBuffer, k: int) -> dict:
    """The spec section 7 G-buffer arrays of reflector ``k``: world-space float32 positions,
    zero where not covered (as the rasterizer's maps), float32 normals, the mask and the
    view-projection matrix."""
    position = limits.zeros(gb.position.shape, np.float32)
    if gb.mask.any():
        r0, r1, c0, c1 = stencil_box(gb.mask)  # only the covered box is converted
        parallel_range(world_positions, r1 - r0, r0, c0, c1, np.ascontiguousarray(gb.position),
                       np.ascontiguousarray(gb.mask), np.asarray(gb.origin, np.float64), position)
    return {keys.GBUFFER_POSITION(k): position, keys.GBUFFER_NORMAL(k): np.asarray(gb.normal, dtype=np.float32),
            keys.GBUFFER_MASK(k): gb.mask, keys.GBUFFER_VIEW_PROJ(k): gb.view_proj}


def vertex_outputs(refl: Reflection, owner, k: int) -> dict:
    """The spec section 7 per-vertex arrays of reflector ``k`` (plus its scores and margins),
    with flag SEVERAL and the per-image arrays where every image was enumerated."""
    res = refl.result
    flags = res.flags.astype(np.uint8)
    out = {}
    if refl.images is not None:
        im = refl.images
        count = im.count
        flags = flags | np.where(count > 1, SEVERAL, 0).astype(np.uint8)
        out = {keys.IMAGE_COUNT(k): count, keys.IMAGE_VERTEX(k): im.vertex,
               keys.IMAGE_PIXEL(k): im.pixel.astype(np.int32), keys.IMAGE_VIRTUAL(k): im.virtual.astype(np.float32),
               keys.IMAGE_SHEET(k): im.sheet.astype(np.int32)}
    return {keys.REFLECTION_PIXEL(k): res.pixel.astype(np.int32),
            keys.VIRTUAL_VERTEX(k): refl.virtual.astype(np.float32),
            keys.ITERATIONS(k): res.iterations.astype(np.int32),
            keys.FLAGS(k): flags,
            keys.VERTEX_OBJECT(k): owner.astype(np.int32),
            keys.SCORE(k): res.score,
            keys.MARGIN(k): res.margin, **out}


def image_counts(count) -> dict:
    """Vertices with 0, 1, 2 and 3 or more images: ``{"0": n, "1": n, "2": n, "3+": n}``."""
    c = np.asarray(count)
    return {"0": int(np.sum(c == 0)), "1": int(np.sum(c == 1)), "2": int(np.sum(c == 2)), "3+": int(np.sum(c >= 3))}


def virtual_relative(gb, res, verts, eye, refine, rule="mirror"):
    """Virtual vertices relative to the G-buffer's origin by ``rule``, from sub-texel points if
    ``refine``; and those points (P, N, offset) or None."""
    if not (refine and len(verts) and gb.mask.any()):
        return virtual_vertices(gb, res, verts, relative=True, rule=rule, eye=eye), None
    surface = refine_points(gb, eye, verts, res)
    return virtual_vertices(gb, res, verts, relative=True, surface=surface[:2], rule=rule, eye=eye), surface


class VertexSearch:
    """The vertex search for every reflector of a scene, frame after frame.

    Keeps each reflector's previous reflection pixels (coherence) and, for the reuse skip, its
    last G-buffer and search results.

    Parameters
    ----------
    scene : Scene
    options : RenderOptions
        Read: ``method``, ``neighbourhood``, ``inverse``, ``widen``, ``gbuffer_size``,
        ``precision``, ``coherence``, ``cap``, the skips, ``adaptive_widen``, ``tessellate``,
        ``max_level``, ``refine``, ``images``, ``bounces``.
    """

    name = "vertex"
    stages = ("gbuffer", "search", "virtual")
    pixel_arrays = {}
    #: How a reflector's G-buffer is made: :func:`refsoft.raster.gbuffer`, or the first run's
    #: warm-up process's ray-cast ball (:mod:`refsoft._warmup`).
    make_gbuffer = staticmethod(gbuffer)

    def __init__(self, scene, options):
        self.scene = scene
        self.options = options
        if options.bounces > 1:  # the reflections taken per pixel, and the later levels' time
            self.pixel_arrays = {levels.BOUNCE_DEPTH: ((), np.int8, 0)}
            self.stages = self.stages + ("bounces",)
        #: The last frame's later bounces by path (reflector ids, the first reflector first):
        #: :class:`refsoft.search.bounces.Bounce` s, what a trace of a later bounce replays.
        self.kept_bounces, self._kept_frame = {}, None
        self.later_starts = levels.LaterStarts()  # the later levels' pixels, frame to frame
        self.previous = {}
        self._last = {}
        self._reflected = None  # the concatenated non-reflector meshes (reflected_mesh)
        self._several = {}  # reflector id -> several_possible of its closed proxy (model space)

    # --- the seam --------------------------------------------------------------------------
    def reflect(self, view, k: int, stencil) -> ReflectorResult:
        """Reflector ``k``'s G-buffer, search, virtual vertices and virtual pass (the
        :mod:`refsoft.seam` interface)."""
        opt = self.options
        report = {}
        refl, t_gb, t_search = self.reflection(view, k, report)
        times = {"gbuffer": t_gb, "search": t_search, "virtual": 0.0}
        self.previous[k] = refl.result.pixel
        out = ReflectorResult(k, time_ms=times, report=report, state=refl)
        if stencil.any():
            t = time.perf_counter()
            box = stencil_box(stencil) if opt.crop_virtual else (0, view.camera.height, 0, view.camera.width)
            drawn = self._draw_images(view, k, refl, stencil, box)
            if drawn is not None:  # every image, drawn by exact acceptance (search/several.py)
                out.colour, out.reflected_id, out.covered, extra, sheeted = drawn
                report.update(extra)
                refl = replace(refl, images=sheeted)  # the images with their sheets
                out.state = refl
            elif opt.tessellate is None and opt.silhouette != "clip" and opt.draw == "raster":
                parts = virtual_parts(self.scene, view.meshes, refl)
            else:
                self._reflected = reflected_mesh(self.scene, view.meshes, self._reflected)
                twins = opt.draw == "exact"  # the exact drawing's second candidates
                parts, counts, real, *mirror = refined_parts(self.scene, view.meshes, refl, view.vertices, opt,
                                                             view.camera.eye, self._reflected[1], with_real=True,
                                                             with_mirror=twins)
                report.update(counts)
                times["tessellate"] = 1000 * (time.perf_counter() - t)
                t = time.perf_counter()
            if drawn is None and opt.draw == "exact":  # every stencil pixel's ray met exactly
                # the triangles with a vertex whose image by the mirror rule is elsewhere once more,
                # with that image (virtual.with_mirror_copies)
                part, real = with_mirror_copies(parts[0], real, mirror[0], view.camera)
                out.colour, out.reflected_id, out.covered, report["exact"] = exact_pass(
                    self.scene, part, real, view.camera, view.meshes[k - 1], view.view.triangle, stencil, box,
                    opt.inverse)
            elif drawn is None and opt.draw == "edges":  # rasterized, then met exactly along the outlines
                out.colour, out.reflected_id, out.covered, report["exact"] = edges_pass(
                    self.scene, parts[0], real, view.camera, view.meshes[k - 1], view.view.triangle, stencil, box,
                    opt.inverse, opt.cull_virtual)
            elif drawn is None:
                out.colour, out.reflected_id, out.covered, report["virtual_objects_culled"] = virtual_pass(
                    self.scene, parts, view.camera, stencil, box, opt.inverse, opt.cull_virtual)
            out.box = box
            times["virtual"] = 1000 * (time.perf_counter() - t)
            if opt.bounces > 1 and drawn is None:  # the reflectors seen in this image, level by level
                t = time.perf_counter()
                if self._kept_frame != view.frame:  # the bounces of this frame only
                    self.kept_bounces, self._kept_frame = {}, view.frame
                report["bounces"] = levels.deepen(self.scene, view, k, stencil, box, out, refl, parts, opt,
                                                  lambda v: self._first_level(refl.gbuffer, view.camera.eye, v),
                                                  self.kept_bounces, self.later_starts if opt.coherence else None)
                times["bounces"] = 1000 * (time.perf_counter() - t)
            elif opt.bounces > 1:  # every image drawn: the reflectors seen in them, this one too if it can
                t = time.perf_counter()
                if self._kept_frame != view.frame:
                    self.kept_bounces, self._kept_frame = {}, view.frame
                report["bounces"] = levels.deepen_images(self.scene, view, k, stencil, box, out, self._drawn, opt,
                                                         self.kept_bounces, self.later_starts if opt.coherence else None)
                times["bounces"] = 1000 * (time.perf_counter() - t)
        out.arrays = {**gbuffer_outputs(refl.gbuffer, k), **vertex_outputs(refl, view.vertex_object, k)}
        return out

    def _first_level(self, gb, eye, verts):
        """Virtual vertices (N, 3) float64 world and flags of more vertices (another reflector's)
        on a first bounce's G-buffer, as :meth:`reflection` computes the scene's."""
        opt = self.options
        res = search(gb, eye, verts, opt.neighbourhood, opt.inverse, None, opt.cap, method=opt.method)
        rel, _ = virtual_relative(gb, res, verts, eye, opt.refine, opt.virtual)
        return rel.astype(np.float64) + gb.origin, res.flags

    def _draw_images(self, view, k, refl, stencil, box):
        """Every image of reflector ``k`` drawn (:func:`refsoft.search.several.several_pass`), or
        None: the virtual pass."""
        from . import several

        source = several.image_source(self.scene, view, k, refl, self.options)
        if source is None:
            return None
        self._reflected = reflected_mesh(self.scene, view.meshes, self._reflected)
        self._drawn = {}  # what a later bounce needs of the drawing (levels.deepen_images)
        return several.several_pass(self.scene, view, k, stencil, box, self._reflected[1], self.options, *source,
                                    keep=self._drawn)

    def frame_report(self, results) -> dict:
        """``stats.json``'s per-frame ``iterations`` (mean and max per reflector, CULLED vertices
        left out), ``skipped`` (what the exact skips left out, and tessellation counts) and, with
        ``images="all"``, ``images``: per reflector where every image was enumerated, the
        vertices with 0, 1, 2 and 3 or more images and the enumeration's time (the others are
        listed in ``skipped["images_convex"]``); with ``draw="exact"``, ``exact``: per reflector
        drawn so, its candidate triangles and the pixels accepted and left empty."""
        iterations, images = {}, {}
        skipped = {"reflectors_outside_view": [], "gbuffers_reused": [], "searches_reused": {},
                   "virtual_objects_culled": {}, "widen_off": []}
        if self.options.images == "all":
            skipped["images_convex"] = []
        tessellation, silhouette, drawn, later, exact = {}, {}, {}, {}, {}
        for k, r in results.items():
            rep = r.report
            if "bounces" in rep:
                later[str(k)] = rep["bounces"]
            for flag, name in (("outside_view", "reflectors_outside_view"), ("gbuffer_reused", "gbuffers_reused")):
                if rep.get(flag):
                    skipped[name].append(k)
            if rep.get("widen_off"):
                skipped["widen_off"].append(k)
            for name in ("searches_reused", "virtual_objects_culled"):
                if name in rep:
                    skipped[name][str(k)] = rep[name]
            if "tessellation" in rep:
                tessellation[str(k)] = rep["tessellation"]
            if "silhouette" in rep:
                silhouette[str(k)] = rep["silhouette"]
            if "images" in rep:
                images[str(k)] = rep["images"]
            elif rep.get("images_convex"):
                skipped["images_convex"].append(k)
            if "several" in rep:
                drawn[str(k)] = rep["several"]
            if "exact" in rep:
                exact[str(k)] = rep["exact"]
            res = r.state.result
            it = res.iterations[(res.flags & CULLED) == 0]
            iterations[str(k)] = {"mean": float(it.mean()) if len(it) else 0.0, "max": int(it.max()) if len(it) else 0}
        if self.options.tessellate is not None:
            skipped["tessellation"] = tessellation  # reported beside the skips (what was added, not skipped)
        if self.options.silhouette == "clip":
            skipped["silhouette"] = silhouette
        out = {"iterations": iterations, "skipped": skipped}
        if self.options.images == "all":
            out["images"] = images
        if drawn:  # every image drawn (search/several.py): candidates, subdivisions, pixels per reflector
            out["several"] = drawn
        if exact:  # the virtual triangles drawn exactly (search/exact.py): candidates, pixels per reflector
            out["exact"] = exact
        if self.options.bounces > 1:  # per first reflector, each later bounce drawn in its image
            out["bounces"] = later
        return out

    # --- the stages --------------------------------------------------------------------------
    def reflection(self, view, k: int, report=None):
        """Reflector ``k``'s G-buffer, search and virtual vertices, with the exact skips.

        Returns (Reflection, G-buffer ms, search ms); ``report`` (a dict) receives which skips
        were taken."""
        scene, opt = self.scene, self.options
        report = {} if report is None else report
        frame, camera, verts = view.frame, view.camera, view.vertices
        t0 = time.perf_counter()
        proxy = scene.world_mesh(k, frame, proxy=True)
        widen = opt.widen
        if opt.adaptive_widen and widen != 1.0:
            if not skips.projection_clipped(_setup.transform_points(proxy.vertices, camera.view_proj())):
                widen = 1.0
                report["widen_off"] = True
        gcam = gbuffer_camera(scene, frame, widen, opt.gbuffer_size)
        key = (skips.camera_key(gcam), view.transforms[k], widen)
        last = self._last.get(k)
        same = opt.reuse and last is not None and last.key == key and len(last.result) == len(verts)
        if same:
            gb = last.gbuffer
            report["gbuffer_reused"] = True
        elif opt.cull_reflectors and skips.outside_frustum(_setup.transform_points(proxy.vertices, gcam.view_proj())):
            gb = empty_gbuffer(gcam, opt.precision)
            report["outside_view"] = True
        else:
            gb = self.make_gbuffer(proxy, gcam, opt.precision, origin=gcam.eye)
        t1 = time.perf_counter()
        prev = self.previous.get(k) if opt.coherence else None
        if last is not None and last.key[2] != widen:
            prev = None  # the G-buffer's pixel grid changed: restart
        prev = coherent_starts(prev, len(verts), gb.mask.shape)
        eye = camera.eye
        if same:
            moved = [j for j, tr in view.transforms.items() if last.transforms.get(j) != tr]
            reuse = ~np.isin(view.vertex_object, moved) & skips.reusable(last.result, opt.coherence, opt.inverse,
                                                                           opt.border_restart)
            res = self._merged_search(gb, eye, verts, prev, last.result, reuse)
            report["searches_reused"] = int(reuse.sum())
        else:
            res = self.search_vertices(gb, eye, verts, prev)
        rel, surface = virtual_relative(gb, res, verts, eye, opt.refine, opt.virtual)
        world64 = rel.astype(np.float64) + gb.origin
        images = None
        if opt.images == "all":
            if self._can_have_several(k):
                t2 = time.perf_counter()
                # an open mirror seen from behind reflects on the side facing the eye
                images = find_images(facing_gbuffer(gb, eye), eye, verts, res)
                report["images"] = {**image_counts(images.count), "ms": 1000 * (time.perf_counter() - t2)}
            else:
                report["images_convex"] = True
        refl = Reflection(k, gb, res, world64.astype(rel.dtype), world64, surface, images)
        if opt.reuse:
            self._last[k] = _Last(key, gb, res, dict(view.transforms))
        return refl, 1000 * (t1 - t0), 1000 * (time.perf_counter() - t1)

    def _can_have_several(self, k: int) -> bool:
        """:func:`refsoft.search.convex.several_possible` of reflector ``k``'s closed proxy, once
        per run (an object's transform is affine: it keeps convexity at every frame)."""
        if k not in self._several:
            obj = self.scene.objects[k - 1]
            self._several[k] = several_possible(obj.closed_proxy if obj.closed_proxy is not None else obj.mesh)
        return self._several[k]

    def search_vertices(self, gb, eye, verts, prev):
        """:func:`refsoft.search.search` with the options, from the starts ``prev`` (N, 2) or
        None; with ``border_restart``, the walks from a previous pixel that stop on the border
        with a score below :data:`refsoft.constants.BORDER_RESTART_SCORE` walked again from the
        start without history, the higher score kept (a tie keeps the first walk), their
        iterations the sum of both."""
        opt = self.options
        res = search(gb, eye, verts, opt.neighbourhood, opt.inverse, prev, opt.cap, method=opt.method)
        if not (opt.border_restart and prev is not None and opt.method == "walk"):
            return res
        # a walk that restarted (its previous pixel not covered) already began without history; a
        # walk that stopped on the border with a score near 1 reflects there (a far rim's trap scores
        # low): only the others are walked again
        again = np.flatnonzero(((res.flags & BORDER) != 0) & (prev[:, 0] >= 0)
                               & ((res.flags & (CULLED | RESTARTED)) == 0)
                               & (res.score < res.score.dtype.type(constants.BORDER_RESTART_SCORE)))
        if len(again) == 0:
            return res
        fresh = search(gb, eye, verts[again], opt.neighbourhood, opt.inverse, None, opt.cap, method=opt.method)
        better = fresh.score > res.score[again]
        take = again[better]
        pixel, score, margin = res.pixel.copy(), res.score.copy(), res.margin.copy()
        iterations, flags = res.iterations.copy(), res.flags.copy()
        pixel[take], score[take], margin[take] = fresh.pixel[better], fresh.score[better], fresh.margin[better]
        flags[take] = fresh.flags[better]
        iterations[again] += fresh.iterations
        return replace(res, pixel=pixel, score=score, margin=margin, iterations=iterations, flags=flags)

    def _merged_search(self, gb, eye, verts, prev, last, reuse):
        """Search the vertices not in ``reuse``; the others keep ``last``'s pixel, score and
        margin with the iterations and flags the search would give them."""
        opt = self.options
        todo = np.flatnonzero(~reuse)
        it, fl = skips.reused_result(last, opt.coherence)
        pixel, score, margin = last.pixel.copy(), last.score.copy(), last.margin.copy()
        iterations, flags = it.copy(), fl.copy()
        if len(todo):
            new = self.search_vertices(gb, eye, verts[todo], None if prev is None else prev[todo])
            pixel[todo], score[todo], margin[todo] = new.pixel, new.score, new.margin
            iterations[todo], flags[todo] = new.iterations, new.flags
            cap = new.cap
        else:
            cap = last.cap
        return SearchResult(pixel, score, margin, iterations, flags, opt.neighbourhood, opt.inverse, cap, opt.method)
