"""The memory guard (spec section 10): estimate what a run will hold before allocating it, and
refuse clearly above a limit.

The limit is, in order: the ``memory_limit`` argument (CLI ``--memory-limit``), the environment
variable ``REFSOFT_MEMORY_LIMIT``, :data:`refsoft.constants.MEMORY_LIMIT_BYTES`. Sizes accept
plain bytes or a suffix: ``512M``, ``4G``, ``1.5GiB``.

The estimate counts the arrays a frame keeps (its spec section 7 outputs) and the largest working set
of one stage (a reflector's G-buffer, packed copy and search arrays; the rasterizer's per-pixel
and per-triangle buffers), from byte counts per pixel, vertex and triangle listed below. It is
an estimate (1.3x-3.4x the peak resident memory a render adds to a process that loaded its kernels
and scene, on the built-in scenes at 1024x768: docs/benchmarks.md, "Peak memory against the
memory guard"; within 3x of the traced peak: tests/frame/test_limits.py), meant to stop a typo
like ``--width 100000`` before the machine swaps, not to budget tightly.
"""

from __future__ import annotations

import mmap
import os
import re

import numpy as np

from . import constants
from .errors import LimitError, RefsoftError

#: Bytes per view pixel: colour (float32 x 3, twice: view and composite), object id, reflected
#: id, depth, clip triangle and input triangle ids, interpolated normals (float32 x 3), 8-bit image.
VIEW_BYTES_PER_PIXEL = 12 * 2 + 4 * 5 + 12 + 3
#: Bytes per G-buffer pixel kept in a frame's outputs: float32 positions and normals, mask.
GBUFFER_OUTPUT_BYTES_PER_PIXEL = 12 + 12 + 1
#: Bytes per G-buffer pixel the driver keeps for the reuse skip, at a precision of ``p`` bytes:
#: the last G-buffer's positions and normals (3p each), mask, depth and triangle ids.
GBUFFER_REUSE_BYTES = {4: 6 * 4 + 9, 8: 6 * 8 + 9}
#: Working bytes per G-buffer pixel at a precision of ``p`` bytes: positions and normals (3p
#: each), depth, triangle and clip-triangle ids.
GBUFFER_WORK_BYTES = {4: 6 * 4 + 12, 8: 6 * 8 + 12}
#: The hierarchy search packs P, N and U per G-buffer pixel (9p bytes) and builds a pyramid over
#: the square of the next power of two: a sphere and a cone (8p) per texel, a third more for the
#: levels above, twice over while the levels are concatenated.
HIERARCHY_PACKED_FLOATS = 9
HIERARCHY_TEXEL_FLOATS = 8 * 2 * 4 / 3
#: The enumeration of every reflection point (``images="all"``, on a reflector that may give a
#: vertex several) packs the G-buffer and builds its dilated pyramid as the hierarchy search does,
#: and per vertex holds its count, up to MAX_IMAGES pixels (2 int32), the walk's pixel (2 int64)
#: and its statistics (4 int64)...
IMAGES_VERTEX_WORK_BYTES = 4 + constants.MAX_IMAGES * 8 + 16 + 32
#: ...and keeps per vertex its count and offset (int32, int64) and per image its pixel (2 int32),
#: virtual vertex (3 float64), sheet and vertex (int32), for this many images a vertex (an
#: estimate: the built-in concave bowl and torus average 1.2 to 1.6)...
IMAGES_PER_VERTEX = 2
IMAGES_VERTEX_OUTPUT_BYTES = 12 + IMAGES_PER_VERTEX * (8 + 24 + 4 + 4)
#: Bytes per searched vertex and reflector kept in the outputs: pixel (2 int32), virtual vertex
#: (3 float32), iterations, flags, object id, score and margin (float64 at most).
VERTEX_OUTPUT_BYTES = 8 + 12 + 4 + 1 + 4 + 16
#: Working bytes per vertex: world position (float64 x 3), clip coordinates (4 float64), the
#: search's key, order and rank (3 int64), its relative vertex and start twice (as prepared, then
#: in search order: 2 x (24 + 8), float64 at most), its results in search order (8 + 8 + 8 + 4 +
#: 1; the results put back are the kept outputs), virtual vertices in float64.
VERTEX_WORK_BYTES = 24 + 32 + 24 + 2 * (24 + 8) + 29 + 24
#: Working bytes per triangle in the rasterizer's setup (snapped coordinates, depths, 1/w,
#: bounding box, edge biases, bins).
TRIANGLE_WORK_BYTES = 24 + 48 + 32 + 16 + 24 + 16
#: Adaptive tessellation and the cut at the silhouette grow one reflector's reflected geometry:
#: at most this many triangles per reflected triangle is assumed (measured 1.1x-3.2x on the
#: built-in scenes with the accurate preset). Full tessellation (threshold 0) splits every
#: triangle 1-to-4 at every level: 4 ** ``max_level`` per reflected triangle is counted then (the
#: triangles it may make; measured 29x-34x at 3 levels on kitchen, planar and sphere at 1024x768,
#: whose culled triangles are not split)...
REFINED_GROWTH = 4
#: ...each holding its faces, object id, parent, edge keys and the split's temporaries...
REFINED_TRIANGLE_BYTES = 128
#: The exact drawing (``draw="exact"``, :mod:`refsoft.search.exact`) per candidate triangle: its
#: corners' indices (24), real corners (72, float64), view positions (48), bounds (32), dilation
#: and index (8 each), object id (4), flags (2), and its vertices' clip coordinates (32) at most.
EXACT_TRIANGLE_BYTES = 232
#: ... and per pixel of the reflector's box: the reflected ray (48), its flag, the stencil and
#: visible triangle cropped (1 + 1 + 8), the nearest hit, its candidate and barycentrics (8 + 8 +
#: 16).
EXACT_PIXEL_BYTES = 90
#: Candidate triangles per reflected triangle counted for the exact drawing after the
#: tessellation and the cut (the accurate preset's one level: measured 1.01x-1.08x on sphere,
#: kitchen, ufo and ants at 640x480), or
#: :func:`refined_growth` for full tessellation.
EXACT_GROWTH = 2
#: ...and half a new vertex (a triangulated surface has about half as many vertices as
#: triangles), holding its position, normal and virtual vertex (float64 x 3 each), pixel (2
#: int32), flags and sub-texel point, normal and offset (8 floats, float64 at most): twice, as
#: each level's arrays are concatenated with the earlier ones.
REFINED_VERTEX_BYTES = 2 * (3 * 24 + 8 + 1 + 8 * 8)

#: The layered depth textures, per reflected object, texel and layer: depth, back depth, normal
#: (float32 x 3) and triangle id; per texel: the raw and paired layer counts and the mismatch
#: mask. Layers are counted at the most the build peels (8), or 1 with ``ldt_layers=1``.
LDT_TEXEL_LAYER_BYTES = 4 + 4 + 12 + 4
LDT_TEXEL_BYTES = 3
LDT_MAX_LAYERS = 8
#: The LDT's per-pixel outputs per frame pixel: ray origin, direction and hit (float32 x 3),
#: distance, residual, margin, sample and step counts (4 bytes), face, layer, faces and objects
#: counts, flags (1 byte), texel (2 int16); and each object's distance (float32).
LDT_PIXEL_BYTES = 3 * 12 + 5 * 4 + 5 + 4
LDT_OBJECT_PIXEL_BYTES = 4
#: The environment map per reflector and texel: colour (float32 x 3) and object id.
ENVMAP_TEXEL_BYTES = 12 + 4

_UNITS = {"": 1, "b": 1, "k": 1 << 10, "kb": 1 << 10, "kib": 1 << 10, "m": 1 << 20, "mb": 1 << 20, "mib": 1 << 20,
          "g": 1 << 30, "gb": 1 << 30, "gib": 1 << 30, "t": 1 << 40, "tb": 1 << 40, "tib": 1 << 40}


def parse_bytes(text) -> int:
    """``"4G"`` -> 4294967296. Accepts an int, or a number with an optional unit (k, M, G, T,
    optionally followed by B or iB; powers of 1024)."""
    if isinstance(text, bool):
        raise RefsoftError(f"memory limit must be a size like 4G or 512M, got {text!r}")
    if isinstance(text, int):
        value = text
    else:
        m = re.fullmatch(r"\s*([0-9]*\.?[0-9]+)\s*([a-zA-Z]*)\s*", str(text))
        if not m or m.group(2).lower() not in _UNITS:
            raise RefsoftError(f"memory limit must be a size like 4G or 512M, got {text!r}")
        value = int(float(m.group(1)) * _UNITS[m.group(2).lower()])
    if value <= 0:
        raise RefsoftError(f"memory limit must be positive, got {text!r}")
    return value


def memory_limit(limit=None) -> int:
    """The limit in bytes: ``limit`` if given, else ``$REFSOFT_MEMORY_LIMIT``, else the default."""
    if limit is not None:
        return parse_bytes(limit)
    env = os.environ.get("REFSOFT_MEMORY_LIMIT")
    if env:
        return parse_bytes(env)
    return constants.MEMORY_LIMIT_BYTES


def human(n: float) -> str:
    """Bytes in a short human form: ``1.5 GiB``."""
    for unit in ("B", "KiB", "MiB", "GiB"):
        if n < 1024 or unit == "GiB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1024
    return f"{n:.1f} TiB"  # pragma: no cover


def frame_bytes(scene, options, frames_kept: int = 1) -> dict:
    """Estimated bytes of a render: what ``frames_kept`` frames keep and the largest stage.

    Parameters
    ----------
    scene : Scene
    options : RenderOptions
    frames_kept : int
        Frames whose arrays stay in memory (all of them for ``render(out=None)``).

    Returns
    -------
    dict
        ``view``, ``gbuffers``, ``vertices`` (kept per frame, with every image of every vertex
        on a reflector that may give several under ``images="all"``), ``cache`` (the driver's last
        G-buffers and results, for the reuse skip), ``work`` (transient buffers of the stages)
        and ``total``, in bytes.
    """
    import math

    cam = scene.camera
    view_px = cam.width * cam.height
    if options.method == "ldt":
        return _ldt_bytes(scene, options, view_px, frames_kept)
    if options.method == "envmap":
        return _envmap_bytes(scene, options, view_px, frames_kept)
    if options.gbuffer_size is not None:
        g_px = int(options.gbuffer_size[0]) * int(options.gbuffer_size[1])
    else:
        g_px = math.ceil(cam.width * options.widen) * math.ceil(cam.height * options.widen)
    p = 8 if options.precision == "float64" else 4
    n_refl = len(scene.reflector_ids)
    n_verts = sum(o.mesh.n_vertices for o in scene.objects if not o.reflector)
    n_tris = sum(o.mesh.n_faces for o in scene.objects)
    kept_view = view_px * VIEW_BYTES_PER_PIXEL
    kept_gb = n_refl * g_px * GBUFFER_OUTPUT_BYTES_PER_PIXEL
    kept_v = n_refl * n_verts * VERTEX_OUTPUT_BYTES
    cache = n_refl * (g_px * GBUFFER_REUSE_BYTES[p] + n_verts * VERTEX_OUTPUT_BYTES) if options.reuse else 0
    # the rasterizer's passes (the main view, each G-buffer) and a reflector's stages after its
    # G-buffer (search, tessellation, cut, drawing) run one after another: the larger of the two
    # transient sets, beside the vertices' arrays, which live through the frame
    raster = g_px * GBUFFER_WORK_BYTES[p] + n_tris * TRIANGLE_WORK_BYTES + view_px * 16
    work = 0
    if options.tessellate is not None or options.silhouette == "clip":
        n_reflected = sum(o.mesh.n_faces for o in scene.objects if not o.reflector)
        work += n_reflected * refined_growth(options) * REFINED_TRIANGLE_BYTES
        work += int(n_reflected * (refined_growth(options) - 1) / 2 * REFINED_VERTEX_BYTES)
    if getattr(options, "draw", "raster") == "exact":  # one reflector drawn at a time
        n_reflected = sum(o.mesh.n_faces for o in scene.objects if not o.reflector)
        growth = refined_growth(options) if options.tessellate == 0 else EXACT_GROWTH
        work += n_reflected * growth * EXACT_TRIANGLE_BYTES + view_px * EXACT_PIXEL_BYTES
    if options.gbuffer_size is not None:
        side = max(int(options.gbuffer_size[0]), int(options.gbuffer_size[1]))
    else:
        side = math.ceil(max(cam.width, cam.height) * options.widen)
    pyramid_bytes = g_px * HIERARCHY_PACKED_FLOATS * p + int((1 << max(side - 1, 0).bit_length()) ** 2
                                                             * HIERARCHY_TEXEL_FLOATS * p)
    if options.method == "hierarchy":
        work += pyramid_bytes
    n_several = _reflectors_with_several(scene) if getattr(options, "images", "one") == "all" else 0
    if n_several:
        # one reflector enumerated at a time; its images kept with the frame
        work += pyramid_bytes + n_verts * IMAGES_VERTEX_WORK_BYTES
        kept_v += n_several * n_verts * IMAGES_VERTEX_OUTPUT_BYTES
    work = n_verts * VERTEX_WORK_BYTES + max(raster, work)
    kept = (kept_view + kept_gb + kept_v) * max(int(frames_kept), 1)
    return {"view": kept_view, "gbuffers": kept_gb, "vertices": kept_v, "cache": cache, "work": work,
            "total": kept + cache + work}


def _reflectors_with_several(scene) -> int:
    """Reflectors of ``scene`` that may give a vertex several reflection points (the render's own
    decision, :func:`refsoft.search.convex.several_possible`, cached per mesh: the render does
    not make it again)."""
    from .search.convex import several_possible  # the decision lives with the search

    objs = [scene.objects[k - 1] for k in scene.reflector_ids]
    return sum(bool(several_possible(o.closed_proxy if o.closed_proxy is not None else o.mesh)) for o in objs)


def refined_growth(options) -> int:
    """Triangles per reflected triangle counted for the tessellation and the silhouette's cut:
    :data:`REFINED_GROWTH`, or 4 ** ``max_level`` when larger for full tessellation (threshold 0:
    every triangle not culled is split at every level)."""
    if options.tessellate == 0:
        return max(REFINED_GROWTH, 4 ** int(options.max_level))
    return REFINED_GROWTH


def _ldt_bytes(scene, options, view_px, frames_kept):
    n_targets = sum(1 for o in scene.objects if not o.reflector)
    n_tris = sum(o.mesh.n_faces for o in scene.objects)
    layers = 1 if options.ldt_layers == 1 else LDT_MAX_LAYERS
    texels = 6 * options.ldt_resolution ** 2
    textures = n_targets * texels * (layers * LDT_TEXEL_LAYER_BYTES + LDT_TEXEL_BYTES)
    kept_view = view_px * VIEW_BYTES_PER_PIXEL
    kept_px = view_px * (LDT_PIXEL_BYTES + n_targets * LDT_OBJECT_PIXEL_BYTES)
    # the build's peel: a face's fragments per layer (depth, triangle, normals), float64 work
    work = texels // 6 * 64 + n_tris * TRIANGLE_WORK_BYTES + view_px * (16 + LDT_PIXEL_BYTES)
    kept = (kept_view + kept_px) * max(int(frames_kept), 1)
    return {"view": kept_view, "gbuffers": 0, "vertices": 0, "pixels": kept_px, "textures": textures, "cache": 0,
            "work": work, "total": kept + textures + work}


def _envmap_bytes(scene, options, view_px, frames_kept):
    n_refl = len(scene.reflector_ids)
    n_tris = sum(o.mesh.n_faces for o in scene.objects)
    texels = 6 * options.envmap_resolution ** 2
    # each reflector's cube map is kept in its frame's outputs (colour, id) and, for reuse, by the
    # method; a face's raster works at float64 over R^2 texels
    kept_px = view_px * (1 + 4) + n_refl * texels * ENVMAP_TEXEL_BYTES
    textures = n_refl * texels * ENVMAP_TEXEL_BYTES
    kept_view = view_px * VIEW_BYTES_PER_PIXEL
    work = texels // 6 * 64 + n_tris * TRIANGLE_WORK_BYTES + view_px * (16 + 3 * 3 * 8)
    kept = (kept_view + kept_px) * max(int(frames_kept), 1)
    return {"view": kept_view, "gbuffers": 0, "vertices": 0, "pixels": kept_px, "textures": textures, "cache": 0,
            "work": work, "total": kept + textures + work}


def textures_of(options) -> str:
    return "layered depth textures" if options.method == "ldt" else "cube maps"


def check_frame_memory(scene, options, frames_kept: int = 1, limit=None) -> dict:
    """Raise :class:`LimitError` when :func:`frame_bytes` exceeds the limit; return the estimate."""
    est = frame_bytes(scene, options, frames_kept)
    lim = memory_limit(limit)
    if est["total"] > lim:
        kept = f" x {frames_kept} frames kept" if frames_kept > 1 else ""
        if "textures" in est:
            raise LimitError(
                f"this render needs about {human(est['total'])} ({textures_of(options)} {human(est['textures'])}, "
                f"view and per-pixel outputs {human(est['view'] + est['pixels'])}{kept}, working set "
                f"{human(est['work'])}), above the memory limit of {human(lim)}: lower --{options.method}-resolution "
                f"or --width/--height, or raise --memory-limit (or REFSOFT_MEMORY_LIMIT)")
        raise LimitError(
            f"this render needs about {human(est['total'])} (view {human(est['view'])}, G-buffers "
            f"{human(est['gbuffers'])}, vertices {human(est['vertices'])}{kept}, reuse cache {human(est['cache'])}, "
            f"working set {human(est['work'])}), "
            f"above the memory limit of {human(lim)}: lower --width/--height or --widen, or raise --memory-limit "
            f"(or REFSOFT_MEMORY_LIMIT)")
    return est


#: Arrays at least this large come from :func:`zeros` as fresh anonymous memory.
LAZY_ZEROS_BYTES = 1 << 20


def zeros(shape, dtype) -> np.ndarray:
    """A zero-filled array whose pages the operating system supplies, already zero, on first
    touch: for the full-size maps of which a frame writes only a reflector's box.

    ``np.zeros`` gets large blocks from the C allocator, which, once freed blocks are reused
    (glibc raises its mmap threshold after the first free), clears every byte: about 2 ms per
    1024x768x3 float32 map, several per reflector and frame. An anonymous ``mmap`` is zero and
    costs only the pages written. It is private: a page only read (the frame's writer reads the
    whole map) is the kernel's one zero page, where a shared mapping gets a page of its own,
    cleared, on the first read (about 36,000 per `ants` frame at 1024x768). Small arrays use
    ``np.zeros``.
    """
    dt = np.dtype(dtype)
    count = int(np.prod(shape, dtype=np.int64))
    if count * dt.itemsize < LAZY_ZEROS_BYTES:
        return np.zeros(shape, dtype=dt)
    if hasattr(mmap, "MAP_PRIVATE") and hasattr(mmap, "MAP_ANONYMOUS"):
        buf = mmap.mmap(-1, count * dt.itemsize, flags=mmap.MAP_PRIVATE | mmap.MAP_ANONYMOUS)
    else:  # Windows: no flags
        buf = mmap.mmap(-1, count * dt.itemsize)
    return np.frombuffer(buf, dtype=dt, count=count).reshape(shape)


def maps(shape, *dtypes) -> list:
    """Uninitialised arrays of ``shape``, one per dtype, carved from one block of memory.

    NumPy asks the kernel for transparent huge pages for a block of 4 MiB or more: the first
    touch of a 1024x768 map then costs a few 2 MiB page faults instead of 768 faults of 4 KiB
    (three separate 3 MiB maps took 4.7 ms to fill, one block holding them 0.4 ms). The maps
    share the block: it lives as long as any of them.
    """
    count = int(np.prod(shape, dtype=np.int64))
    sizes = [count * np.dtype(dt).itemsize for dt in dtypes]
    align = max(np.dtype(dt).itemsize for dt in dtypes)
    offsets, total = [], 0
    for size in sizes:
        offsets.append(total)
        total += -(-size // align) * align
    block = np.empty(max(total, 1), dtype=np.uint8)
    return [block[o:o + n].view(dt).reshape(shape) for o, n, dt in zip(offsets, sizes, dtypes)]

