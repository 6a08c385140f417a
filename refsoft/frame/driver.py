"""The frame driver (DESIGN sections 1, 5 and 7): reflection stage, virtual raster inside each
reflector's stencil, main pass and composite, frame after frame.

Only :class:`FrameDriver` keeps state between frames: each reflector's reflection pixels of the
previous frame (frame-to-frame coherence).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from .. import constants, limits
from ..search import skips
from ..errors import RefsoftError
from ..raster import _setup, color_pass, interpolate, rasterize, shade, to_uint8
from ..raster import gbuffer
from ..search.reflect import Reflection, coherent_starts, gbuffer_camera, scene_vertices
from ..scene.model import Scene
from ..search.refine import refine as refine_points
from ..search import CULLED, HIDDEN, INVERSE_MODES, SEARCH_METHODS, SearchResult, search, virtual_vertices

STAGES = ("gbuffer", "search", "virtual", "main", "composite")
#: The exact skips of :class:`RenderOptions` (issue 10).
SKIPS = ("cull_reflectors", "reuse", "cull_virtual", "crop_virtual")


@dataclass(frozen=True)
class RenderOptions:
    """Options of :func:`render` (defaults reproduce the paper's method).

    Parameters
    ----------
    neighbourhood : {"cross", "box", "hierarchy"}
        The search method (``hierarchy``: Szabo's ray-cone pyramid, no coherence).
    inverse : {"plane", "search", "discard"}
    widen : float
        Wider-frustum factor of the G-buffers (1.0: off).
    gbuffer_size : (int, int), optional
        G-buffer (width, height); default keeps the view's pixel density.
    precision : {"float32", "float64"}
    coherence : bool
        Start each search at the vertex's previous reflection pixel.
    cap : int, optional
        Iteration cap per search.
    cull_reflectors, reuse, cull_virtual, crop_virtual : bool
        Exact skips (on by default; outputs are bit-identical with them off): no G-buffer and
        no search for a reflector outside the G-buffer's frustum; G-buffer and search results
        reused when the reflector, the camera and the vertex's object did not move; objects
        whose virtual vertices all lie beyond one side of the stencil's box not rasterized; the
        virtual raster restricted to that box.
    adaptive_widen : bool
        An approximation (off by default, changes results): use ``widen`` only on frames where
        the reflector's projection is clipped by the view.
    tessellate : float, optional
        Szabo's adaptive tessellation of the reflected geometry (:mod:`refsoft.search.tessellate`):
        split triangles whose largest edge error exceeds this threshold (0: every triangle, full
        tessellation), crack-free, up to ``max_level`` levels. Default: off.
    max_level : int
    refine : bool
        Sub-texel reflection points (:mod:`refsoft.search.refine`, beyond the paper; off by
        default): one Gauss-Newton step from the texel found before mirroring the vertex.
    """

    neighbourhood: str = "cross"
    inverse: str = "plane"
    widen: float = 1.0
    gbuffer_size: tuple | None = None
    precision: str = "float32"
    coherence: bool = True
    cap: int | None = None
    cull_reflectors: bool = True
    reuse: bool = True
    cull_virtual: bool = True
    crop_virtual: bool = True
    adaptive_widen: bool = False
    tessellate: float | None = None
    max_level: int = 3
    refine: bool = False

    def __post_init__(self):
        if self.neighbourhood not in SEARCH_METHODS:
            raise RefsoftError(f"search must be one of {list(SEARCH_METHODS)}, got {self.neighbourhood!r}")
        if self.inverse not in INVERSE_MODES:
            raise RefsoftError(f"inverse must be one of {list(INVERSE_MODES)}, got {self.inverse!r}")
        if self.precision not in ("float32", "float64"):
            raise RefsoftError(f"precision must be float32 or float64, got {self.precision!r}")
        if not (isinstance(self.widen, (int, float)) and np.isfinite(self.widen) and self.widen >= 1.0):
            raise RefsoftError(f"widen must be a number >= 1, got {self.widen!r}")
        if self.tessellate is not None and not (isinstance(self.tessellate, (int, float))
                                                and not isinstance(self.tessellate, bool)
                                                and np.isfinite(self.tessellate) and self.tessellate >= 0):
            raise RefsoftError(f"tessellate must be a threshold >= 0 (or None), got {self.tessellate!r}")
        if isinstance(self.max_level, bool) or not isinstance(self.max_level, (int, np.integer)) \
                or not 0 <= self.max_level <= 8:
            raise RefsoftError(f"max_level must be an integer in [0, 8], got {self.max_level!r}")
        for name in SKIPS + ("adaptive_widen", "coherence", "refine"):
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise RefsoftError(f"{name} must be True or False, got {getattr(self, name)!r}")

    def without_skips(self) -> "RenderOptions":
        """The same options with every exact skip off (the reference the skips are tested
        against)."""
        return replace(self, **dict.fromkeys(SKIPS, False))


@dataclass
class Frame:
    """One rendered frame: the DESIGN section 7 arrays (``arrays``) and timings (ms)."""

    index: int
    arrays: dict
    time_ms: dict
    iterations: dict = field(default_factory=dict)
    skipped: dict = field(default_factory=dict)

    @property
    def image(self) -> np.ndarray:
        return self.arrays["image"]


def _stencil_box(stencil):
    """(r0, r1, c0, c1): the bounding box of a non-empty stencil."""
    rows = np.flatnonzero(stencil.any(axis=1))
    cols = np.flatnonzero(stencil.any(axis=0))
    return int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1


def _virtual_parts(scene, meshes, refl):
    """The reflected geometry of one reflector, one part per non-reflector object:
    ``(virtual (n, 3) float64, normals (n, 3), faces (m, 3) int64 local, face_obj (m,) int32,
    flags (n,) uint8)``."""
    # eye-relative virtual vertices moved to world space in float64: far from the origin the
    # float32 world output would round them (1/16 unit at 1e6)
    virtual = refl.virtual64 if refl.virtual64 is not None else refl.virtual.astype(np.float64)
    flags = refl.result.flags
    parts, start = [], 0
    for k, obj in enumerate(scene.objects, start=1):
        if obj.reflector:
            continue
        mesh = meshes[k - 1]
        n = mesh.n_vertices
        parts.append((virtual[start:start + n], mesh.normals, mesh.faces.astype(np.int64),
                      np.full(mesh.n_faces, k, dtype=np.int32), flags[start:start + n]))
        start += n
    return parts


def _tessellated_parts(scene, meshes, refl, verts, opt, eye):
    """One part holding the reflected geometry after :func:`refsoft.search.tessellate.tessellate`, and
    that function's counts."""
    from ..search.tessellate import tessellate

    faces, face_obj, normals, start = [], [], [], 0
    for k, obj in enumerate(scene.objects, start=1):
        if obj.reflector:
            continue
        mesh = meshes[k - 1]
        faces.append(mesh.faces.astype(np.int64) + start)
        face_obj.append(np.full(mesh.n_faces, k, dtype=np.int32))
        normals.append(mesh.normals)
        start += mesh.n_vertices
    res = refl.result
    t = tessellate(refl.gbuffer, eye, verts, np.concatenate(normals), np.concatenate(faces), np.concatenate(face_obj),
                   res.pixel, res.flags, opt.tessellate, opt.max_level, opt.neighbourhood, opt.inverse, opt.cap,
                   surface=refl.surface)
    n0 = len(verts)
    new = t["vertices"][n0:]
    m = len(new)
    res_new = SearchResult(t["pixel"][n0:], np.zeros(m), np.zeros(m), np.ones(m, np.int32), t["flags"][n0:],
                           res.neighbourhood, res.inverse, res.cap)
    surface = None if refl.surface is None else tuple(a[n0:] for a in t["surface"][:2])
    rel = virtual_vertices(refl.gbuffer, res_new, new, relative=True, surface=surface)
    virtual = np.concatenate([refl.virtual64, rel.astype(np.float64) + refl.gbuffer.origin])
    counts = {"vertices_searched": int(t["searched"]), "levels": int(t["levels"]), "triangles": int(len(t["faces"]))}
    return [(virtual, t["normals"], t["faces"], t["face_obj"], t["flags"])], counts


def _virtual_relative(gb, res, verts, eye, refine):
    """Virtual vertices relative to the G-buffer's origin, from sub-texel points if ``refine``;
    and those points (P, N, offset) or None."""
    if not (refine and len(verts) and gb.mask.any()):
        return virtual_vertices(gb, res, verts, relative=True), None
    surface = refine_points(gb, eye, verts, res)
    return virtual_vertices(gb, res, verts, relative=True, surface=surface[:2]), surface


def _virtual_pass(scene, parts, camera, stencil, box, inverse, cull=True):
    """Rasterize the virtual scene of one reflector with the view camera, inside its stencil.

    ``parts`` (:func:`_virtual_parts`, or one part of tessellated geometry) hold virtual
    vertices, normals, faces, face object ids and flags. Only the stencil's bounding box
    ``box = (r0, r1, c0, c1)`` is rasterized (the same pixels as the whole view, cropped). With
    ``cull``, parts whose virtual vertices all lie beyond one side of the box are left out
    (:func:`refsoft.search.skips.outside_box`: they cover none of its pixels), and so are such
    triangles. Returns, over the box: colour (h, w, 3) float32, reflected object id (h, w)
    int32, covered (h, w) bool, and the number of parts culled.
    """
    vp = camera.view_proj()
    bounds = skips.box_planes(box, camera.width, camera.height)
    bad = CULLED | (HIDDEN if inverse == "discard" else 0)
    faces, face_obj, normals, clips = [], [], [], []
    n_culled = 0
    offset = 0
    for virtual, nrm_v, f, fobj, flags in parts:
        clip = _setup.transform_points(virtual, vp)
        if cull and skips.outside_box(clip, bounds):
            n_culled += 1
            continue
        keep = ~np.any(flags[f] & bad, axis=1)  # triangles whose vertices all have a V'
        faces.append(f[keep] + offset)
        face_obj.append(fobj[keep])
        normals.append(nrm_v)
        clips.append(clip)
        offset += len(clip)
    r0, r1, c0, c1 = box
    h, w = r1 - r0, c1 - c0
    colour = np.zeros((h, w, 3), dtype=np.float32)
    rid = np.zeros((h, w), dtype=np.int32)
    faces = np.concatenate(faces) if faces else np.zeros((0, 3), np.int64)
    if len(faces) == 0:
        return colour, rid, np.zeros((h, w), dtype=bool), n_culled
    face_obj = np.concatenate(face_obj)
    clip = np.concatenate(clips)
    if cull:  # triangles beyond one side of the box: not set up (the order of the others is kept)
        keep = ~skips.triangles_outside_box(clip, np.ascontiguousarray(faces, dtype=np.int64), *bounds)
        faces, face_obj = faces[keep], face_obj[keep]
        if len(faces) == 0:
            return colour, rid, np.zeros((h, w), dtype=bool), n_culled
    frags = rasterize(clip, faces, camera.width, camera.height, region=box)
    inside = frags.mask & stencil[r0:r1, c0:c1]
    nrm = interpolate(frags, np.concatenate(normals), faces, np.float32, normalize=True)
    colors = np.vstack([np.zeros(3), [o.color for o in scene.objects]]).astype(np.float32)
    obj = np.where(inside, face_obj[np.maximum(frags.triangle, 0)], 0)
    colour[inside] = shade(nrm[inside], colors[obj[inside]])
    rid[inside] = obj[inside]
    return colour, rid, inside, n_culled


def composite(colour, reflected, view_color, vcol, vid, covered, box, reflectivity):
    """DESIGN section 5's composite over ``box = (r0, r1, c0, c1)``, in place: where the virtual
    scene covers the stencil, ``colour = rho * virtual + (1 - rho) * reflector`` (float32) and
    ``reflected`` takes the virtual object id.

    Parameters
    ----------
    colour : ndarray (H, W, 3) float32, written
    reflected : ndarray (H, W) int32, written
    view_color : ndarray (H, W, 3) float32
        The main view's colour (the reflector's own).
    vcol, vid, covered : ndarray (h, w, 3) float32, (h, w) int32, (h, w) bool
        The virtual pass over the box.
    reflectivity : float
    """
    r0, r1, c0, c1 = box
    rho = np.float32(reflectivity)
    out_c = colour[r0:r1, c0:c1]
    out_c[covered] = rho * vcol[covered] + (np.float32(1) - rho) * view_color[r0:r1, c0:c1][covered]
    reflected[r0:r1, c0:c1][covered] = vid[covered]


def _gbuffer_outputs(gb, k):
    """The DESIGN section 7 G-buffer arrays of reflector ``k``: world-space float32 positions,
    zero where not covered (as the rasterizer's maps), and float32 normals."""
    position = limits.zeros(gb.position.shape, np.float32)
    if gb.mask.any():
        r0, r1, c0, c1 = _stencil_box(gb.mask)  # only the covered box is converted
        m = gb.mask[r0:r1, c0:c1, None]
        world = gb.position[r0:r1, c0:c1].astype(np.float64) + gb.origin
        position[r0:r1, c0:c1] = np.where(m, world, 0.0)
    return {f"gbuffer_position_{k}": position, f"gbuffer_normal_{k}": np.asarray(gb.normal, dtype=np.float32)}


@dataclass
class _Last:
    """What a driver remembers of a reflector's last frame, for the reuse skip."""

    key: tuple  # (G-buffer camera key, reflector transform, widen used)
    gbuffer: object
    result: object
    transforms: dict  # object id -> Transform of the vertices searched


def _empty_gbuffer(camera, precision):
    """The G-buffer the rasterizer makes of a mesh it draws no pixel of (the eye as origin)."""
    from ..raster import PRECISIONS, GBuffer

    dt = PRECISIONS[precision]
    h, w = camera.height, camera.width
    return GBuffer(limits.zeros((h, w, 3), dt), limits.zeros((h, w, 3), dt), limits.zeros((h, w), bool),
                   (0, 0, np.zeros((0, 0), np.float32)), (0, 0, np.zeros((0, 0), np.int32)),
                   camera.view_proj(), np.asarray(camera.eye, dtype=np.float64))


class FrameDriver:
    """Renders a scene frame by frame, keeping each reflector's previous reflection pixels (and,
    for the reuse skip, its last G-buffer and search results)."""

    def __init__(self, scene: Scene, options: RenderOptions | None = None, memory_limit=None):
        from ..limits import check_frame_memory

        if not isinstance(scene, Scene):
            raise RefsoftError(f"scene must be a refsoft.Scene, got {type(scene).__name__}")
        if options is not None and not isinstance(options, RenderOptions):
            raise RefsoftError(f"options must be a RenderOptions, got {type(options).__name__}")
        if not scene.reflector_ids:
            raise RefsoftError(f"scene {scene.name!r} has no reflector: nothing to reflect "
                               "(mark an object with reflector = true)")
        self.scene = scene
        self.options = options or RenderOptions()
        check_frame_memory(scene, self.options, 1, memory_limit)
        self.previous = {}
        self._last = {}
        self._static_meshes = {}  # world meshes of objects that do not move (reused, unchanged)

    def _world_meshes(self, frame):
        scene = self.scene
        moving = set() if scene.animation is None else set(scene.animation.object_keys)
        meshes = []
        for k, obj in enumerate(scene.objects, start=1):
            if obj.name in moving:
                meshes.append(scene.world_mesh(k, frame))
            else:
                if k not in self._static_meshes:
                    self._static_meshes[k] = scene.world_mesh(k, frame)
                meshes.append(self._static_meshes[k])
        return meshes

    def _reflect(self, k, frame, camera, verts, owner, transforms, skipped):
        """Reflector ``k``'s G-buffer, search and virtual vertices, with the exact skips.
        Returns (Reflection, G-buffer ms, search ms)."""
        scene, opt = self.scene, self.options
        t0 = time.perf_counter()
        proxy = scene.world_mesh(k, frame, proxy=True)
        widen = opt.widen
        if opt.adaptive_widen and widen != 1.0:
            if not skips.projection_clipped(_setup.transform_points(proxy.vertices, camera.view_proj())):
                widen = 1.0
                skipped["widen_off"].append(k)
        gcam = gbuffer_camera(scene, frame, widen, opt.gbuffer_size)
        key = (skips.camera_key(gcam), transforms[k], widen)
        last = self._last.get(k)
        same = opt.reuse and last is not None and last.key == key and len(last.result) == len(verts)
        if same:
            gb = last.gbuffer
            skipped["gbuffers_reused"].append(k)
        elif opt.cull_reflectors and skips.outside_frustum(_setup.transform_points(proxy.vertices, gcam.view_proj())):
            gb = _empty_gbuffer(gcam, opt.precision)
            skipped["reflectors_outside_view"].append(k)
        else:
            gb = gbuffer(proxy, gcam, opt.precision, origin=gcam.eye)
        t1 = time.perf_counter()
        prev = self.previous.get(k) if opt.coherence else None
        if last is not None and last.key[2] != widen:
            prev = None  # the G-buffer's pixel grid changed: restart
        prev = coherent_starts(prev, len(verts), gb.mask.shape)
        eye = camera.eye
        if same:
            moved = [j for j, tr in transforms.items() if last.transforms.get(j) != tr]
            reuse = ~np.isin(owner, moved) & skips.reusable(last.result, opt.coherence, opt.inverse)
            res = self._merged_search(gb, eye, verts, prev, last.result, reuse)
            skipped["searches_reused"][str(k)] = int(reuse.sum())
        else:
            res = search(gb, eye, verts, opt.neighbourhood, opt.inverse, prev, opt.cap)
        rel, surface = _virtual_relative(gb, res, verts, eye, opt.refine)
        world64 = rel.astype(np.float64) + gb.origin
        refl = Reflection(k, gb, res, world64.astype(rel.dtype), world64, surface)
        if opt.reuse:
            self._last[k] = _Last(key, gb, res, {j: transforms[j] for j in transforms})
        return refl, 1000 * (t1 - t0), 1000 * (time.perf_counter() - t1)

    def _merged_search(self, gb, eye, verts, prev, last, reuse):
        """Search the vertices not in ``reuse``; the others keep ``last``'s pixel, score and
        margin with the iterations and flags the search would give them."""
        opt = self.options
        todo = np.flatnonzero(~reuse)
        it, fl = skips.reused_result(last, opt.coherence)
        pixel, score, margin = last.pixel.copy(), last.score.copy(), last.margin.copy()
        iterations, flags = it.copy(), fl.copy()
        if len(todo):
            new = search(gb, eye, verts[todo], opt.neighbourhood, opt.inverse,
                         None if prev is None else prev[todo], opt.cap)
            pixel[todo], score[todo], margin[todo] = new.pixel, new.score, new.margin
            iterations[todo], flags[todo] = new.iterations, new.flags
            cap = new.cap
        else:
            cap = last.cap
        return SearchResult(pixel, score, margin, iterations, flags, opt.neighbourhood, opt.inverse, cap)

    def render_frame(self, frame: int) -> Frame:
        """Render one frame (with coherence from the last frame rendered by this driver)."""
        scene, opt = self.scene, self.options
        if scene.animation is not None and not 0 <= frame < scene.n_frames:
            raise RefsoftError(f"frame must be in [0, {scene.n_frames - 1}], got {frame}")
        times = dict.fromkeys(STAGES, 0.0)
        skipped = {"reflectors_outside_view": [], "gbuffers_reused": [], "searches_reused": {},
                   "virtual_objects_culled": {}, "widen_off": []}
        t0 = time.perf_counter()
        camera = scene.camera_at(frame)
        t = time.perf_counter()
        meshes = self._world_meshes(frame)  # once per frame; static objects once per driver
        view = color_pass(meshes, [o.color for o in scene.objects], camera)
        times["main"] += 1000 * (time.perf_counter() - t)
        verts, owner = scene_vertices(scene, frame, meshes)
        transforms = {j: scene.transform_at(j, frame) for j in range(1, len(scene.objects) + 1)}
        colour = view.color.copy()
        reflected = np.full(view.object_id.shape, -1, dtype=np.int32)
        full = (0, camera.height, 0, camera.width)
        arrays = {}
        iterations = {}
        tessellation = {}
        for k in scene.reflector_ids:
            stencil = view.object_id == k
            reflected[stencil] = 0
            refl, t_gb, t_search = self._reflect(k, frame, camera, verts, owner, transforms, skipped)
            times["gbuffer"] += t_gb
            times["search"] += t_search
            self.previous[k] = refl.result.pixel
            t = time.perf_counter()
            if stencil.any():
                box = _stencil_box(stencil) if opt.crop_virtual else full
                if opt.tessellate is None:
                    parts = _virtual_parts(scene, meshes, refl)
                else:
                    parts, counts = _tessellated_parts(scene, meshes, refl, verts, opt, camera.eye)
                    tessellation[str(k)] = counts
                    times["tessellate"] = times.get("tessellate", 0.0) + 1000 * (time.perf_counter() - t)
                    t = time.perf_counter()
                vcol, vid, covered, n_culled = _virtual_pass(scene, parts, camera, stencil, box, opt.inverse,
                                                             opt.cull_virtual)
                skipped["virtual_objects_culled"][str(k)] = n_culled
                times["virtual"] += 1000 * (time.perf_counter() - t)
                t = time.perf_counter()
                composite(colour, reflected, view.color, vcol, vid, covered, box, scene.object_by_id(k).reflectivity)
                times["composite"] += 1000 * (time.perf_counter() - t)
            gb, res = refl.gbuffer, refl.result
            arrays.update(_gbuffer_outputs(gb, k))
            arrays.update({
                f"gbuffer_mask_{k}": gb.mask,
                f"gbuffer_view_proj_{k}": gb.view_proj,
                f"reflection_pixel_{k}": res.pixel.astype(np.int32),
                f"virtual_vertex_{k}": refl.virtual.astype(np.float32),
                f"iterations_{k}": res.iterations.astype(np.int32),
                f"flags_{k}": res.flags.astype(np.uint8),
                f"vertex_object_{k}": owner.astype(np.int32),
                f"score_{k}": res.score,
                f"margin_{k}": res.margin,
            })
            it = res.iterations[(res.flags & CULLED) == 0]
            iterations[str(k)] = {"mean": float(it.mean()) if len(it) else 0.0, "max": int(it.max()) if len(it) else 0}
        t = time.perf_counter()
        image = to_uint8(colour)
        times["composite"] += 1000 * (time.perf_counter() - t)
        times["total"] = 1000 * (time.perf_counter() - t0)
        arrays.update(image=image, object_id=np.asarray(view.object_id, dtype=np.int32), reflected_id=reflected)
        if opt.tessellate is not None:
            skipped["tessellation"] = tessellation  # reported beside the skips (what was added, not skipped)
        return Frame(frame, arrays, times, iterations, skipped)


def frame_stats(frames) -> dict:
    """The ``stats.json`` content for rendered frames (DESIGN section 7)."""
    out = {"frames": [{"frame": f.index, "time_ms": {k: round(v, 3) for k, v in f.time_ms.items()},
                       "iterations": f.iterations, "skipped": f.skipped} for f in frames]}
    means = [np.mean([v["mean"] for v in f.iterations.values()]) for f in frames if f.iterations]
    out["summary"] = {"max_frame_mean_iterations": float(max(means)) if means else 0.0,
                      "total_mean_iterations": float(np.mean(means)) if means else 0.0,
                      "frames": len(frames)}
    return out


def write_frame(out_dir, frame: Frame):
    """Write ``frame_NNNN.npz`` (every array) and ``frame_NNNN.png`` atomically."""
    import os

    from ..io import write_npz, write_png

    base = os.path.join(os.fspath(out_dir), f"frame_{frame.index:04d}")
    write_npz(base + ".npz", **frame.arrays)
    write_png(base + ".png", frame.image)


def frame_indices(scene: Scene, frames=None) -> list:
    """Frame indices from a ``frames`` argument: None (every frame), a count N (0 .. N-1) or a
    sequence of indices; checked against the animation's length."""
    if frames is None:
        indices = list(range(scene.n_frames))
    elif isinstance(frames, (int, np.integer)) and not isinstance(frames, bool):
        if frames < 1:
            raise RefsoftError(f"frames must be positive, got {frames}")
        if scene.animation is not None and frames > scene.n_frames:
            raise RefsoftError(f"scene {scene.name!r} has {scene.n_frames} frames, asked for {frames}")
        indices = list(range(int(frames)))
    else:
        indices = [int(f) for f in frames]
    if scene.animation is not None:
        bad = [f for f in indices if not 0 <= f < scene.n_frames]
        if bad:
            raise RefsoftError(f"frame {bad[0]} is outside [0, {scene.n_frames - 1}]")
    elif any(f < 0 for f in indices):
        raise RefsoftError("frame indices must be >= 0")
    return indices


def run_frames(renderer, indices, out=None, progress=False, desc="frames", keep=True, write=None) -> list:
    """``renderer.render_frame(f)`` for each index in order, each frame written to ``out`` (when
    given) as soon as it is done; a tqdm bar on a terminal when ``progress`` and several frames.

    ``write``: the indices to write (default: all). ``keep=False`` drops each frame's arrays
    once written (the returned frames keep their timings), so a long run holds one frame."""
    import os

    if out is not None:
        os.makedirs(out, exist_ok=True)
    it = indices
    if progress and len(indices) > 1:
        from tqdm import tqdm

        it = tqdm(indices, desc=desc, unit="frame", disable=None)  # no bar off a terminal
    done = []
    for f in it:
        fr = renderer.render_frame(f)
        if out is not None and (write is None or f in write):
            write_frame(out, fr)
        if not keep:
            fr.arrays = {}
        done.append(fr)
    return done


def render(scene, frames=None, out=None, progress=False, memory_limit=None, keep=True, write=None,
           width=None, height=None, **options):
    """Render frames of a scene (the Python face of ``refsoft render``).

    Parameters
    ----------
    scene : Scene or str
        A scene or a built-in name / TOML path.
    frames : int or sequence of int, optional
        A number of frames (0 .. n-1) or explicit frame indices (rendered in order, coherent
        from one to the next). Default: every frame of the animation (1 for a static scene).
    out : str or PathLike, optional
        Folder to write ``frame_NNNN.npz``, ``frame_NNNN.png`` and ``stats.json`` into.
    progress : bool
        Show a tqdm progress bar.
    width, height : int, optional
        Image size (replaces the scene camera's).
    memory_limit : int or str, optional
        Refuse (:class:`refsoft.errors.LimitError`) a render estimated to need more (e.g.
        ``"4G"``; default ``$REFSOFT_MEMORY_LIMIT`` or 4 GiB; see :mod:`refsoft.limits`).
    keep : bool
        Keep every frame's arrays in the returned frames (``False``: only timings and stats,
        so a long render to ``out`` holds one frame at a time).
    write : set of int, optional
        Frame indices to write to ``out`` (default all).
    **options
        :class:`RenderOptions` fields (``neighbourhood``, ``inverse``, ``widen``, ...).

    Returns
    -------
    frames : list of Frame
    stats : dict
        The ``stats.json`` content (of the written frames when ``write`` is given).
    """
    import os

    from ..io import write_json
    from ..scene.builtin import load_scene

    if not isinstance(scene, Scene):
        scene = load_scene(scene, width=width, height=height)
    elif width is not None or height is not None:
        from dataclasses import replace as _replace

        scene = _replace(scene, camera=_replace(scene.camera, **{k: v for k, v in (("width", width),
                                                                                  ("height", height)) if v is not None}))
    from ..limits import check_frame_memory

    opts = RenderOptions(**options)
    indices = frame_indices(scene, frames)
    driver = FrameDriver(scene, opts, memory_limit)
    check_frame_memory(scene, opts, len(indices) if keep else 1, memory_limit)
    done = run_frames(driver, indices, out, progress, f"render {scene.name}", keep, write)
    stats = frame_stats(done if write is None else [f for f in done if f.index in write])
    if out is not None:
        write_json(os.path.join(out, "stats.json"), stats)
    return done, stats
