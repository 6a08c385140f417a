"""A frame's outputs on disk (spec section 7): ``frame_NNNN.npz`` (every array), ``frame_NNNN.png``
and ``stats.json``, each written atomically."""

from __future__ import annotations

import os

import numpy as np

from .. import keys
from ..io import write_npz, write_npz_level, write_png, write_png_rows

#: zlib level of ``frame_NNNN.npz`` and ``frame_NNNN.png`` in a run's folder: level 1 costs half of
#: level 6's CPU time for files ~10% (npz) and ~45% (PNG) larger, so that the background write
#: competes less with the next frame's render for the cores. The npz writer
#: (:func:`refsoft.io.write_npz_level`) also skips compressing the runs that repeat (the
#: G-buffers' zeros, the id maps' and image's background) and stores the high-entropy floats; the
#: PNG's rows are not filtered (:func:`refsoft.io.write_png_rows`).
#: (The golden set keeps ``np.savez_compressed``'s level 6: :func:`refsoft.io.write_npz`.)
FRAME_LEVEL = 1
#: zlib level of the float members' bytes outside their runs of zeros (a G-buffer's reflector
#: pixels): stored. Deflating them (zlib's run-length strategy) halves them at ~100 KB per CPU
#: millisecond, a tenth of what it buys on the id maps and the image (docs/benchmarks.md).
FRAME_FLOAT_LEVEL = 0


def frame_basename(index: int) -> str:
    """``frame_NNNN`` (four digits, more when needed)."""
    return f"frame_{index:04d}"


def write_frame(out_dir, frame):
    """Write ``frame_NNNN.npz`` (every array, in the order the frame holds them; the arrays
    ``np.savez_compressed`` would hold, bit for bit) and ``frame_NNNN.png`` (its rows unfiltered)
    atomically, both at zlib level :data:`FRAME_LEVEL`."""
    base = os.path.join(os.fspath(out_dir), frame_basename(frame.index))
    write_npz_level(base + ".npz", frame.arrays, FRAME_LEVEL, FRAME_FLOAT_LEVEL)
    write_png_rows(base + ".png", frame.arrays[keys.IMAGE], FRAME_LEVEL)


def frame_stats(frames, options=None) -> dict:
    """The ``stats.json`` content of rendered frames: the options (their preset and every
    resolved value, when given), per frame its stage milliseconds and what its reflection method
    reports (the vertex search: mean and max iterations per reflector, the skips taken; the
    truth: reflector pixels and hits); a summary over the frames (with the median write of a
    frame's files, wall and CPU milliseconds, when they were written)."""
    out = {} if options is None else {"options": options.as_dict()}
    out["frames"] = [frame_entry(f) for f in frames]
    out["summary"] = _summary(frames, options)
    return out


def frame_entry(frame) -> dict:
    """A frame's entry in ``stats.json``: its index, stage milliseconds (rounded to the
    microsecond) and what its reflection method reports."""
    return {"frame": frame.index, "time_ms": {k: round(v, 3) for k, v in frame.time_ms.items()}, **frame.report}


class StatsFile:
    """``stats.json`` written again after each frame of a run (:func:`frame_stats` of the frames
    so far, the bytes :func:`refsoft.io.write_json` writes): each frame's entry is encoded once
    and kept, so that a long run's rewrites cost the summary and the copy, not an encoding of
    every earlier frame."""

    #: Stands for the frames' entries in the encoded rest of the file.
    _HOLE = "\x00frames\x00"

    def __init__(self, options=None):
        self._options = options
        self._done = []  # (frame, its entry as JSON, indented as an item of the list)

    def text(self, frames) -> str:
        """The file's text for ``frames`` (a list that grows from one call to the next)."""
        import json

        keep = 0
        while keep < min(len(frames), len(self._done)) and self._done[keep][0] is frames[keep]:
            keep += 1
        del self._done[keep:]
        for f in frames[keep:]:
            entry = json.dumps(frame_entry(f), indent=1)
            self._done.append((f, "\n".join("  " + line for line in entry.split("\n"))))
        out = {} if self._options is None else {"options": self._options.as_dict()}
        out["frames"] = [self._HOLE] if frames else []
        out["summary"] = _summary(frames, self._options)
        text = json.dumps(out, indent=1)
        if frames:
            text = text.replace("  " + json.dumps(self._HOLE), ",\n".join(t for _, t in self._done), 1)
        return text + "\n"

    def write(self, path, frames) -> None:
        """Write the file for ``frames`` to ``path`` atomically."""
        from ..io import atomic_path

        with atomic_path(path) as tmp:
            with open(tmp, "w") as fh:
                fh.write(self.text(frames))


def _summary(frames, options) -> dict:
    """``stats.json``'s summary over ``frames``."""
    summary = {}
    means = [np.mean([v["mean"] for v in f.report["iterations"].values()]) for f in frames
             if f.report.get("iterations")]
    if any("iterations" in f.report for f in frames):
        summary["max_frame_mean_iterations"] = float(max(means)) if means else 0.0
        summary["total_mean_iterations"] = float(np.mean(means)) if means else 0.0
    ldt = [f.report["ldt"] for f in frames if "ldt" in f.report]
    if ldt:  # the layered depth textures: samples and bisection steps per reflector pixel
        pixels = sum(r["reflector_pixels"] for r in ldt)
        for name in ("linear_samples", "binary_steps"):
            total = sum(r[name]["mean"] * r["reflector_pixels"] for r in ldt)
            summary["ldt_" + name] = {"mean": total / pixels if pixels else 0.0,
                                      "max": max(r[name]["max"] for r in ldt)}
    if options is not None and options.method == "envmap":  # reflector pixels that show an object
        summary["envmap_hits"] = int(sum(f.report["hits"] for f in frames))
    summary["frames"] = len(frames)
    summary["median_total_ms"] = float(np.median([f.time_ms["total"] for f in frames])) if frames else 0.0
    writes = [f.time_ms["write"] for f in frames if "write" in f.time_ms]
    if writes:  # written by the background thread (run_frames): its own stage
        summary["median_write_ms"] = float(np.median(writes))
        summary["median_write_cpu_ms"] = float(np.median([f.time_ms["write_cpu"] for f in frames
                                                           if "write_cpu" in f.time_ms]))
    return summary


def write_gbuffers(scene, out, frame: int = 0, reflectors=None, widen: float = 1.0, precision="float32",
                   memory_limit=None) -> list:
    """Write each reflector's G-buffer as ``refsoft gbuffer`` does: ``gbuffer_K.npz``
    (``gbuffer_position`` world space, ``gbuffer_normal``, ``gbuffer_mask``, ``gbuffer_depth``,
    ``gbuffer_triangle``, ``gbuffer_view_proj``), ``gbuffer.png`` (positions | normals, one row
    per reflector) and ``view.png`` (the main view without reflections).

    Returns ``[(k, covered pixels, G-buffer width, height)]``.
    """
    from .. import raster, validate
    from ..search.reflect import check_reflector
    from ..visualize import normal_colors, position_colors, side_by_side

    validate.integer(frame, "frame", 0, None if scene.animation is None else scene.n_frames - 1)
    if not scene.reflector_ids:
        from ..errors import RefsoftError

        raise RefsoftError(f"scene {scene.name!r} has no reflector")
    ids = scene.reflector_ids if reflectors is None else [check_reflector(scene, k) for k in reflectors]
    from ..limits import check_frame_memory
    from ..options import RenderOptions

    check_frame_memory(scene, RenderOptions(widen=widen, precision=precision), 1, memory_limit)
    camera = scene.camera_at(frame)
    if widen != 1.0:
        camera = camera.widened(widen)
    os.makedirs(out, exist_ok=True)
    pictures, done = [], []
    for k in ids:
        gb = raster.gbuffer(scene.world_mesh(k, frame, proxy=True), camera, precision)
        write_npz(os.path.join(out, f"gbuffer_{k}.npz"), gbuffer_position=gb.position, gbuffer_normal=gb.normal,
                  gbuffer_mask=gb.mask, gbuffer_depth=gb.depth, gbuffer_triangle=gb.triangle,
                  gbuffer_view_proj=gb.view_proj)
        pictures.append(side_by_side(position_colors(gb.position, gb.mask), normal_colors(gb.normal, gb.mask)))
        done.append((k, int(gb.mask.sum()), camera.width, camera.height))
    view = raster.color_pass([scene.world_mesh(i + 1, frame) for i in range(len(scene.objects))],
                             [o.color for o in scene.objects], scene.camera_at(frame))
    write_png(os.path.join(out, "view.png"), view.image)
    write_png(os.path.join(out, "gbuffer.png"), np.concatenate(pictures, axis=0))
    return done


#: Format tag of ``run.json``.
RUN_FORMAT = "refsoft-run-1"
#: The files a run writes into its folder (and ``overwrite`` removes).
RUN_FILES = ("frame_[0-9]*.npz", "frame_[0-9]*.png", "stats.json", "run.json", "ldt_[0-9]*.npz")


def run_manifest(kind: str, scene, frames, options=None) -> dict:
    """``run.json``: what a run into a folder is (``kind``: "render" or "truth"), so that
    ``compare`` and later runs can tell whose frames a folder holds. ``vertices`` counts the
    vertices searched (the non-reflector objects'), ``vertices_all`` every object's (what
    ``refsoft scenes`` lists)."""
    from .. import __version__

    return {"format": RUN_FORMAT, "kind": kind, "scene": scene.name, "width": int(scene.camera.width),
            "height": int(scene.camera.height), "frames": [int(f) for f in frames],
            # searched: the non-reflector objects' vertices; all: every object's, as `refsoft scenes` counts
            "vertices": int(sum(o.mesh.n_vertices for o in scene.objects if not o.reflector)),
            "vertices_all": int(sum(o.mesh.n_vertices for o in scene.objects)),
            "reflectors": list(scene.reflector_ids), "options": None if options is None else options.as_dict(),
            "refsoft": __version__}


def prepare_run_folder(out, manifest: dict, overwrite: bool = False) -> None:
    """Make ``out`` this run's folder: refuse (:class:`refsoft.errors.RefsoftError`) when it holds
    another run's frames, unless ``overwrite``, which removes that run's files (and only those,
    :data:`RUN_FILES`); then write ``run.json``."""
    import glob
    import json

    from ..errors import RefsoftError
    from ..io import write_json

    out = os.fspath(out)
    if os.path.exists(out) and not os.path.isdir(out):
        raise RefsoftError(f"--out {out} is a file, not a folder")
    old = sorted(f for pattern in RUN_FILES for f in glob.glob(os.path.join(out, pattern)))
    if old and not overwrite:
        what = f"{sum(f.endswith('.npz') for f in old)} frame files"
        try:
            with open(os.path.join(out, "run.json")) as fh:
                prev = json.load(fh)
            what = (f"a {prev.get('kind', 'run')} of {prev.get('scene')!r}, {len(prev.get('frames', []))} frames at "
                    f"{prev.get('width')}x{prev.get('height')}")
        except (OSError, ValueError, AttributeError):
            pass
        raise RefsoftError(f"{out} already holds {what}; give --overwrite to replace it, or another --out")
    for f in old:
        os.unlink(f)
    os.makedirs(out, exist_ok=True)
    write_json(os.path.join(out, "run.json"), manifest)
