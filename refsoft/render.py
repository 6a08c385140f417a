"""The frame driver (DESIGN sections 1, 5 and 7): reflection stage, virtual raster inside each
reflector's stencil, main pass and composite, frame after frame.

Only :class:`FrameDriver` keeps state between frames: each reflector's reflection pixels of the
previous frame (frame-to-frame coherence).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from . import constants
from .errors import RefsoftError
from .raster import _setup, color_pass, interpolate, rasterize, shade, to_uint8
from .reflect import reflect_one, scene_vertices
from .scene import Scene
from .search import CULLED, HIDDEN, INVERSE_MODES, NEIGHBOURHOODS

STAGES = ("gbuffer", "search", "virtual", "main", "composite")


@dataclass(frozen=True)
class RenderOptions:
    """Options of :func:`render` (defaults reproduce the paper's method).

    Parameters
    ----------
    neighbourhood : {"cross", "box"}
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
    """

    neighbourhood: str = "cross"
    inverse: str = "plane"
    widen: float = 1.0
    gbuffer_size: tuple | None = None
    precision: str = "float32"
    coherence: bool = True
    cap: int | None = None

    def __post_init__(self):
        if self.neighbourhood not in NEIGHBOURHOODS:
            raise RefsoftError(f"search must be one of {list(NEIGHBOURHOODS)}, got {self.neighbourhood!r}")
        if self.inverse not in INVERSE_MODES:
            raise RefsoftError(f"inverse must be one of {list(INVERSE_MODES)}, got {self.inverse!r}")
        if self.precision not in ("float32", "float64"):
            raise RefsoftError(f"precision must be float32 or float64, got {self.precision!r}")
        if not (isinstance(self.widen, (int, float)) and np.isfinite(self.widen) and self.widen >= 1.0):
            raise RefsoftError(f"widen must be a number >= 1, got {self.widen!r}")


@dataclass
class Frame:
    """One rendered frame: the DESIGN section 7 arrays (``arrays``) and timings (ms)."""

    index: int
    arrays: dict
    time_ms: dict
    iterations: dict = field(default_factory=dict)

    @property
    def image(self) -> np.ndarray:
        return self.arrays["image"]


def _stencil_box(stencil):
    """(r0, r1, c0, c1): the bounding box of a non-empty stencil."""
    rows = np.flatnonzero(stencil.any(axis=1))
    cols = np.flatnonzero(stencil.any(axis=0))
    return int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1


def _virtual_pass(scene, meshes, camera, refl, stencil, box, inverse):
    """Rasterize the virtual scene of one reflector with the view camera, inside its stencil.

    Only the stencil's bounding box ``box = (r0, r1, c0, c1)`` is rasterized (the same pixels as
    the whole view, cropped). Returns, over that box: colour (h, w, 3) float32, reflected object
    id (h, w) int32, covered (h, w) bool.
    """
    res = refl.result
    virtual = refl.virtual.astype(np.float64)
    faces, face_obj, normals = [], [], []
    start = 0
    for k, obj in enumerate(scene.objects, start=1):
        if obj.reflector:
            continue
        mesh = meshes[k - 1]
        f = mesh.faces.astype(np.int64) + start
        bad = CULLED | (HIDDEN if inverse == "discard" else 0)
        keep = ~np.any(res.flags[f] & bad, axis=1)  # triangles whose vertices all have a V'
        faces.append(f[keep])
        face_obj.append(np.full(int(keep.sum()), k, dtype=np.int32))
        normals.append(mesh.normals)
        start += mesh.n_vertices
    r0, r1, c0, c1 = box
    h, w = r1 - r0, c1 - c0
    colour = np.zeros((h, w, 3), dtype=np.float32)
    rid = np.zeros((h, w), dtype=np.int32)
    faces = np.concatenate(faces) if faces else np.zeros((0, 3), np.int64)
    if len(faces) == 0:
        return colour, rid, np.zeros((h, w), dtype=bool)
    face_obj = np.concatenate(face_obj)
    clip = _setup.transform_points(virtual, camera.view_proj())
    frags = rasterize(clip, faces, camera.width, camera.height, region=box)
    inside = frags.mask & stencil[r0:r1, c0:c1]
    nrm = interpolate(frags, np.concatenate(normals), faces, np.float32, normalize=True)
    colors = np.vstack([np.zeros(3), [o.color for o in scene.objects]]).astype(np.float32)
    obj = np.where(inside, face_obj[np.maximum(frags.triangle, 0)], 0)
    colour[inside] = shade(nrm[inside], colors[obj[inside]])
    rid[inside] = obj[inside]
    return colour, rid, inside


def _gbuffer_outputs(gb, k):
    """The DESIGN section 7 G-buffer arrays of reflector ``k``: world-space float32 positions,
    zero where not covered (as the rasterizer's maps), and float32 normals."""
    position = np.zeros(gb.position.shape, dtype=np.float32)
    if gb.mask.any():
        r0, r1, c0, c1 = _stencil_box(gb.mask)  # only the covered box is converted
        m = gb.mask[r0:r1, c0:c1, None]
        world = gb.position[r0:r1, c0:c1].astype(np.float64) + gb.origin
        position[r0:r1, c0:c1] = np.where(m, world, 0.0)
    return {f"gbuffer_position_{k}": position, f"gbuffer_normal_{k}": np.asarray(gb.normal, dtype=np.float32)}


class FrameDriver:
    """Renders a scene frame by frame, keeping each reflector's previous reflection pixels."""

    def __init__(self, scene: Scene, options: RenderOptions | None = None):
        if not isinstance(scene, Scene):
            raise RefsoftError(f"scene must be a refsoft.Scene, got {type(scene).__name__}")
        self.scene = scene
        self.options = options or RenderOptions()
        self.previous = {}
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

    def render_frame(self, frame: int) -> Frame:
        """Render one frame (with coherence from the last frame rendered by this driver)."""
        scene, opt = self.scene, self.options
        if scene.animation is not None and not 0 <= frame < scene.n_frames:
            raise RefsoftError(f"frame must be in [0, {scene.n_frames - 1}], got {frame}")
        times = dict.fromkeys(STAGES, 0.0)
        t0 = time.perf_counter()
        camera = scene.camera_at(frame)
        t = time.perf_counter()
        meshes = self._world_meshes(frame)  # once per frame; static objects once per driver
        view = color_pass(meshes, [o.color for o in scene.objects], camera)
        times["main"] += 1000 * (time.perf_counter() - t)
        verts, owner = scene_vertices(scene, frame, meshes)
        colour = view.color.copy()
        reflected = np.full(view.object_id.shape, -1, dtype=np.int32)
        arrays = {}
        iterations = {}
        for k in scene.reflector_ids:
            stencil = view.object_id == k
            reflected[stencil] = 0
            prev = self.previous.get(k) if opt.coherence else None
            refl, t_gb, t_search = reflect_one(scene, k, frame, verts, opt.neighbourhood, opt.inverse, opt.widen,
                                               opt.gbuffer_size, opt.precision, prev, opt.cap)
            times["gbuffer"] += t_gb
            times["search"] += t_search
            self.previous[k] = refl.result.pixel
            t = time.perf_counter()
            if stencil.any():
                box = _stencil_box(stencil)
                r0, r1, c0, c1 = box
                vcol, vid, covered = _virtual_pass(scene, meshes, camera, refl, stencil, box, opt.inverse)
                times["virtual"] += 1000 * (time.perf_counter() - t)
                t = time.perf_counter()
                rho = np.float32(scene.object_by_id(k).reflectivity)
                out_c = colour[r0:r1, c0:c1]
                out_c[covered] = rho * vcol[covered] + (np.float32(1) - rho) * view.color[r0:r1, c0:c1][covered]
                reflected[r0:r1, c0:c1][covered] = vid[covered]
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
        return Frame(frame, arrays, times, iterations)


def frame_stats(frames) -> dict:
    """The ``stats.json`` content for rendered frames (DESIGN section 7)."""
    out = {"frames": [{"frame": f.index, "time_ms": {k: round(v, 3) for k, v in f.time_ms.items()},
                       "iterations": f.iterations} for f in frames]}
    means = [np.mean([v["mean"] for v in f.iterations.values()]) for f in frames if f.iterations]
    out["summary"] = {"max_frame_mean_iterations": float(max(means)) if means else 0.0,
                      "total_mean_iterations": float(np.mean(means)) if means else 0.0,
                      "frames": len(frames)}
    return out


def write_frame(out_dir, frame: Frame):
    """Write ``frame_NNNN.npz`` (every array) and ``frame_NNNN.png`` atomically."""
    import os

    from .io import write_npz, write_png

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


def run_frames(renderer, indices, out=None, progress=False, desc="frames") -> list:
    """``renderer.render_frame(f)`` for each index in order, each frame written to ``out`` (when
    given) as soon as it is done; a tqdm bar on a terminal when ``progress`` and several frames."""
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
        if out is not None:
            write_frame(out, fr)
        done.append(fr)
    return done


def render(scene, frames=None, out=None, progress=False, **options):
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
    **options
        :class:`RenderOptions` fields (``neighbourhood``, ``inverse``, ``widen``, ...).

    Returns
    -------
    frames : list of Frame
    stats : dict
        The ``stats.json`` content.
    """
    import os

    from .io import write_json
    from .scenes import load_scene

    if not isinstance(scene, Scene):
        scene = load_scene(scene)
    opts = RenderOptions(**options)
    indices = frame_indices(scene, frames)
    done = run_frames(FrameDriver(scene, opts), indices, out, progress, f"render {scene.name}")
    stats = frame_stats(done)
    if out is not None:
        write_json(os.path.join(out, "stats.json"), stats)
    return done, stats
