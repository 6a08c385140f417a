"""The frame driver (spec sections 1, 5 and 7): the main view, one reflection method per
reflector, the composite, frame after frame.

Per frame: the world meshes; the main view of every object (colour, object id, depth,
triangle); for each reflector in scene order, its stencil (the pixels where it is the visible
surface) and the method's :class:`refsoft.seam.ReflectorResult`; the composite of each result
into the picture; the 8-bit image. Only the method keeps state between frames (the vertex
search's coherence and reuse caches), and the driver its static objects' world meshes.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from .. import keys
from ..errors import RefsoftError
from ..raster import color_pass, to_uint8
from ..scene.model import Scene
from ..seam import FrameView
from ..options import RenderOptions
from .outputs import StatsFile, frame_stats, write_frame

#: Timing keys every frame reports after its method's own stages.
FRAME_STAGES = ("main", "composite")


@dataclass
class Frame:
    """One rendered frame.

    Attributes
    ----------
    index : int
    arrays : dict
        The spec section 7 arrays by key (:mod:`refsoft.keys`), in output order.
    time_ms : dict
        Milliseconds per stage, and ``total``.
    report : dict
        What the method reports beside the timings (``stats.json``).
    reflectors : dict of int -> ReflectorResult
        Each reflector's result, with the method's intermediates (``state``).
    """

    index: int
    arrays: dict
    time_ms: dict
    report: dict = field(default_factory=dict)
    reflectors: dict = field(default_factory=dict)

    @property
    def image(self) -> np.ndarray:
        """(H, W, 3) uint8."""
        return self.arrays[keys.IMAGE]

    @property
    def iterations(self) -> dict:
        """The vertex search's iterations per reflector (``report["iterations"]``)."""
        return self.report.get("iterations", {})

    @property
    def skipped(self) -> dict:
        """The vertex search's skips (``report["skipped"]``)."""
        return self.report.get("skipped", {})


def make_method(scene, options: RenderOptions):
    """The reflection method the options name, for ``scene``."""
    if options.method == "ldt":
        from ..ldt import LayeredDepthTextures

        return LayeredDepthTextures(scene, resolution=options.ldt_resolution, layers=options.ldt_layers,
                                    faces=options.ldt_faces, linear=options.ldt_linear, tau=options.ldt_tau,
                                    regions=options.ldt_regions, precision=options.precision)
    if options.method == "envmap":
        from ..envmap import EnvironmentMap

        return EnvironmentMap(scene, resolution=options.envmap_resolution, precision=options.precision)
    from ..search.method import VertexSearch

    return VertexSearch(scene, options)


class FrameDriver:
    """Renders a scene frame by frame with one reflection method.

    Parameters
    ----------
    scene : Scene
    options : RenderOptions, optional
    memory_limit : int or str, optional
        Refuse a render estimated to need more (:mod:`refsoft.limits`).
    method : reflection method, optional
        Any object with the :mod:`refsoft.seam` interface; default the one ``options`` names.
    """

    def __init__(self, scene: Scene, options: RenderOptions | None = None, memory_limit=None, method=None):
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
        self.method = make_method(scene, self.options) if method is None else method
        self._static_meshes = {}  # world meshes of objects that do not move (reused, unchanged)

    @property
    def previous(self) -> dict:
        """The vertex search's last reflection pixels per reflector (coherence)."""
        return getattr(self.method, "previous", {})

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

    def render_frame(self, frame: int) -> Frame:
        """Render one frame (coherent with the last frame this driver rendered)."""
        scene, method = self.scene, self.method
        if scene.animation is not None and not 0 <= frame < scene.n_frames:
            raise RefsoftError(f"frame must be in [0, {scene.n_frames - 1}], got {frame}")
        times = dict.fromkeys(tuple(method.stages) + FRAME_STAGES, 0.0)
        t0 = time.perf_counter()
        camera = scene.camera_at(frame)
        t = time.perf_counter()
        meshes = self._world_meshes(frame)  # once per frame; static objects once per driver
        view = color_pass(meshes, [o.color for o in scene.objects], camera)
        times["main"] += 1000 * (time.perf_counter() - t)
        fv = FrameView(scene, frame, camera, meshes, view,
                       {j: scene.transform_at(j, frame) for j in range(1, len(scene.objects) + 1)})
        colour = view.color.copy()
        reflected = np.full(view.object_id.shape, -1, dtype=np.int32)
        pixels = {name: np.full(view.object_id.shape + tuple(spec[0]), spec[2] if len(spec) > 2 else 0, dtype=spec[1])
                  for name, spec in method.pixel_arrays.items()}
        arrays, results = {}, {}
        for k in scene.reflector_ids:
            stencil = view.object_id == k
            reflected[stencil] = 0
            res = method.reflect(fv, k, stencil)
            results[k] = res
            for stage, ms in res.time_ms.items():
                times[stage] = times.get(stage, 0.0) + ms
            if res.box is not None:
                t = time.perf_counter()
                composite(colour, reflected, view.color, res.colour, res.reflected_id, res.covered, res.box,
                          scene.object_by_id(k).reflectivity)
                r0, r1, c0, c1 = res.box
                where = res.covered if res.pixel_mask is None else res.pixel_mask
                for name, a in res.pixels.items():
                    pixels[name][r0:r1, c0:c1][where] = a[where]
                times["composite"] += 1000 * (time.perf_counter() - t)
            arrays.update(res.arrays)
        t = time.perf_counter()
        image = to_uint8(colour)
        times["composite"] += 1000 * (time.perf_counter() - t)
        times["total"] = 1000 * (time.perf_counter() - t0)
        for name in getattr(method, "leading_axis_arrays", ()):  # (H, W, K) stored as (K, H, W)
            pixels[name] = np.ascontiguousarray(np.moveaxis(pixels[name], -1, 0))
        arrays.update({keys.IMAGE: image, keys.OBJECT_ID: np.asarray(view.object_id, dtype=np.int32),
                       keys.REFLECTED_ID: reflected}, **pixels)
        return Frame(frame, arrays, times, method.frame_report(results), results)


def composite(colour, reflected, view_color, vcol, vid, covered, box, reflectivity):
    """Blend one reflector's reflection into the frame over ``box = (r0, r1, c0, c1)``, in
    place: where the reflection covers the stencil, ``colour = rho * reflected colour + (1 - rho)
    * reflector colour`` (float32) and ``reflected`` takes the reflected object id.

    Parameters
    ----------
    colour : ndarray (H, W, 3) float32, written
    reflected : ndarray (H, W) int32, written
    view_color : ndarray (H, W, 3) float32
        The main view's colour (the reflector's own).
    vcol, vid, covered : ndarray (h, w, 3) float32, (h, w) int32, (h, w) bool
        The reflection over the box (:class:`refsoft.seam.ReflectorResult`).
    box : (int, int, int, int)
    reflectivity : float
    """
    r0, r1, c0, c1 = box
    rho = np.float32(reflectivity)
    out_c = colour[r0:r1, c0:c1]
    out_c[covered] = rho * vcol[covered] + (np.float32(1) - rho) * view_color[r0:r1, c0:c1][covered]
    reflected[r0:r1, c0:c1][covered] = vid[covered]


def frame_indices(scene: Scene, frames=None) -> list:
    """Frame indices from a ``frames`` argument: None (every frame), a count N (0 .. N-1) or a
    sequence of indices; checked against the animation's length."""
    from .. import validate

    if frames is None:
        indices = list(range(scene.n_frames))
    elif validate.is_integer(frames):
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


def _timed_write(out, frame):
    """:func:`write_frame`, and its wall and thread CPU milliseconds."""
    t, c = time.perf_counter(), time.thread_time()
    write_frame(out, frame)
    return 1000 * (time.perf_counter() - t), 1000 * (time.thread_time() - c)


def run_frames(renderer, indices, out=None, progress=False, desc="frames", keep=True, write=None, done=None,
               on_frame=None) -> list:
    """``renderer.render_frame(f)`` for each index in order, each frame written to ``out`` (when
    given) while the next one renders. With ``progress`` and several frames: a tqdm bar on a
    terminal, else (a log) a line every tenth of the run.

    A frame's files are written by one background thread (zlib releases the GIL while it
    compresses, so the renderer runs meanwhile), one frame after another, each file atomically; the run
    waits for a frame's files before it counts the frame as done, and on an error or an interrupt
    it still waits for the files being written. The bytes
    are those of a write in the main thread. The write's own times go into the frame's ``time_ms``
    as ``write`` (wall milliseconds in the writer's thread) and ``write_cpu`` (that thread's CPU
    milliseconds: the compression's cost, whatever else the cores run); ``total`` stays the
    render's, whose stages overlap the previous frame's write.

    ``write``: the indices to write (default: all). ``keep=False`` drops each frame's arrays and
    per-reflector results once written (the returned frames keep their timings and reports), so
    a long run holds at most two frames (one rendering, one being written). ``done``: a list the
    finished (rendered and written) frames are appended to as they finish (what was done when an
    interrupt stops the run); ``on_frame(done)`` is called after each."""
    import os
    import sys

    from .. import interrupt

    if out is not None:
        os.makedirs(out, exist_ok=True)
    done = [] if done is None else done
    it, lines = indices, 0
    if progress and len(indices) > 1:
        if sys.stderr.isatty():
            from tqdm import tqdm

            it = tqdm(indices, desc=desc, unit="frame")
        else:
            lines = max(1, -(-len(indices) // 10))
    t0 = time.perf_counter()
    writer = None
    if out is not None:
        from concurrent.futures import ThreadPoolExecutor

        writer = ThreadPoolExecutor(1, thread_name_prefix="refsoft-write")
    pending = []  # the frame whose files are being written, with its write (at most one)

    def finish():
        fr, written = pending.pop()
        if written is not None:
            # the write's error, if any, is raised here
            fr.time_ms["write"], fr.time_ms["write_cpu"] = written.result()
        if not keep:
            fr.arrays = {}
            fr.reflectors = {}
        done.append(fr)
        if on_frame is not None:
            on_frame(done)
        n = len(done)
        if lines and (n % lines == 0 or n == len(indices)):
            print(f"{desc}: {n}/{len(indices)} frames ({100 * n // len(indices)}%), "
                  f"{time.perf_counter() - t0:.1f} s", file=sys.stderr, flush=True)

    try:
        for f in it:
            interrupt.check()
            fr = renderer.render_frame(f)
            if pending:
                finish()
            writes = writer is not None and (write is None or f in write)
            pending.append((fr, writer.submit(_timed_write, out, fr) if writes else None))
        if pending:
            finish()
    finally:
        if pending:  # stopped by an error or an interrupt: the frame being written is still kept
            written = pending[0][1]
            if written is None or written.exception() is None:
                finish()
        if writer is not None:
            writer.shutdown(wait=True)
    return done


def resolve_scene(scene, width=None, height=None, subdivide=None) -> Scene:
    """A Scene from a Scene or a built-in name / TOML path, at ``width`` x ``height`` when
    given, with the loader subdivision override ``subdivide`` when given
    (:func:`refsoft.scene.apply_subdivision`)."""
    from ..scene.builtin import load_scene
    from ..scene.subdivide import apply_subdivision, check_override

    if not isinstance(scene, Scene):
        return load_scene(scene, subdivide=subdivide, width=width, height=height)
    if subdivide is not None:
        scene = apply_subdivision(scene, check_override(subdivide))
    if width is None and height is None:
        return scene
    return replace(scene, camera=replace(scene.camera, **{k: v for k, v in (("width", width), ("height", height))
                                                          if v is not None}))


def render(scene, frames=None, out=None, progress=False, memory_limit=None, keep=True, write=None,
           width=None, height=None, subdivide=None, preset="accurate", overwrite=False, on_start=None, **options):
    """Render frames of a scene (the Python face of ``refsoft render``).

    Parameters
    ----------
    scene : Scene or str
        A scene or a built-in name / TOML path.
    frames : int or sequence of int, optional
        A number of frames (0 .. n-1) or explicit frame indices (rendered in order, coherent
        from one to the next). Default: every frame of the animation (1 for a static scene).
    out : str or PathLike, optional
        Folder to write ``run.json``, ``frame_NNNN.npz``, ``frame_NNNN.png`` and ``stats.json``
        into; refused when it holds another run's files, unless ``overwrite``.
    progress : bool
        Show a tqdm progress bar.
    width, height : int, optional
        Image size (replaces the scene camera's).
    subdivide : float, optional
        Loader subdivision override (``L`` world units; 0 off; default the scene's own).
    memory_limit : int or str, optional
        Refuse (:class:`refsoft.errors.LimitError`) a render estimated to need more (e.g.
        ``"4G"``; default ``$REFSOFT_MEMORY_LIMIT`` or 4 GiB; see :mod:`refsoft.limits`).
    keep : bool
        Keep every frame's arrays in the returned frames (``False``: only timings and stats,
        so a long render to ``out`` holds one frame at a time).
    write : set of int, optional
        Frame indices to write to ``out`` (default all).
    preset : {"accurate", "paper"}
        The options not given take this preset's values (:data:`refsoft.options.PRESETS`).
    overwrite : bool
        Replace an earlier run's files in ``out``.
    on_start : callable, optional
        Called with no arguments once every input is checked and the folder prepared, just
        before the first frame (the command line prints its first-run notice there).
    **options
        :class:`RenderOptions` fields (``method``, ``neighbourhood``, ``inverse``, ``widen``, ...),
        each overriding the preset.

    Returns
    -------
    frames : list of Frame
    stats : dict
        The ``stats.json`` content (of the written frames when ``write`` is given).
    """
    import os

    from ..io import write_json
    from ..limits import check_frame_memory

    scene = resolve_scene(scene, width, height, subdivide)
    opts = RenderOptions(preset=preset, **options)
    indices = frame_indices(scene, frames)
    driver = FrameDriver(scene, opts, memory_limit)
    # kept: every frame, or (keep=False) the one rendering and the one being written
    check_frame_memory(scene, opts, len(indices) if keep else min(len(indices), 1 if out is None else 2), memory_limit)
    return run_to_folder(driver, indices, out, "render", opts, progress, keep, write, overwrite, on_start)


def run_to_folder(driver, indices, out, kind, options, progress=False, keep=True, write=None, overwrite=False,
                  on_start=None):
    """Run ``driver`` over ``indices`` into the folder ``out`` (when given): ``run.json`` first,
    each frame as it is done and ``stats.json`` after it (so a run stopped at any moment leaves the
    statistics of the frames it wrote). ``on_start()`` is called before the first frame. Returns
    (frames, stats)."""
    import os

    from .outputs import prepare_run_folder, run_manifest

    written = indices if write is None else [f for f in indices if f in write]
    if out is not None:
        prepare_run_folder(out, run_manifest(kind, driver.scene, written, options), overwrite)
    done = []
    if on_start is not None:
        on_start()

    def written_of(frames):
        return frames if write is None else [f for f in frames if f.index in write]

    def stats_of(frames):
        return frame_stats(written_of(frames), options)

    run_files = getattr(getattr(driver, "method", None), "run_files", None)
    written_once = []
    stats_file = StatsFile(options)  # each frame's entry encoded once, not at every rewrite

    def save(frames):
        stats_file.write(os.path.join(out, "stats.json"), written_of(frames))
        if run_files is not None and frames and not written_once:  # once, after the first frame
            from ..io import write_npz

            for name, arrays in run_files().items():
                write_npz(os.path.join(out, name + ".npz"), **arrays)
            written_once.append(True)

    try:
        run_frames(driver, indices, out, progress, f"{kind} {driver.scene.name}", keep, write, done,
                   None if out is None else save)
    finally:
        if out is not None:
            save(done)
    return done, stats_of(done)
