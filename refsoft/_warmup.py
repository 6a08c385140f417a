"""A first run's second process: it compiles the reflection stages' kernels while the command
compiles the main view's.

A render compiles its kernels as it first calls them, one after another, in pipeline order: the
main view's and the G-buffer's raster, then the search, the sub-texel refinement, the
tessellation and the cut, the virtual pass. On a machine with a second core, the command
(``refsoft render``, on a first run only) starts ``python -m refsoft._warmup OPTIONS`` beside
itself. This process runs one reflector's stages of the same options, search first, on a small
ball whose G-buffer it ray-casts with NumPy (no raster kernel needed to start), so that both
processes compile different kernels at the same time. Each kernel is compiled once: a process
that needs a kernel the other one is compiling waits for it and loads it from Numba's cache
(:func:`refsoft._numba._compile_once`). The command ends this process when it is done.

Nothing here changes an output: it only fills Numba's cache, with the types the command's
own calls have (``tests/test_warmup.py`` checks that a render after it compiles nothing the
warm-up compiled).
"""

from __future__ import annotations

import json
import os
import dataclasses
import subprocess
import sys
from types import SimpleNamespace

import numpy as np

#: The ball's G-buffer size: large enough for walks of several steps, small enough to take no time.
SIZE = (64, 48)


def start(options: dict):
    """Start the warm-up process for a render with these :class:`refsoft.RenderOptions` keyword
    arguments (preset included); None for the methods without a vertex search, when there is
    only one core, or when ``REFSOFT_WARMUP=0``."""
    if (options.get("method") in ("ldt", "envmap") or (os.cpu_count() or 1) < 2
            or os.environ.get("REFSOFT_WARMUP", "1") == "0"):
        return None
    # started in the folder that holds this refsoft package: ``-m`` imports from the working
    # folder first, and a source tree there (as in CI) would fill another package's cache
    home = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    return subprocess.Popen([sys.executable, "-m", "refsoft._warmup", json.dumps(options)], cwd=home,
                            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def stop(process) -> None:
    """End the warm-up process (its cache files are written whole or not at all)."""
    if process is not None and process.poll() is None:
        process.kill()
        process.wait()


def ball_gbuffer(mesh, camera, precision, origin):
    """The G-buffer of the sphere bounding ``mesh`` (centre the vertices' mean, radius the
    largest distance to it) seen by ``camera``, by ray casting in NumPy, laid out as
    :func:`refsoft.raster.gbuffer` lays its own out (the same array types)."""
    from .raster import GBuffer

    dt = np.dtype(precision)
    w, h = camera.width, camera.height
    centre = mesh.vertices.mean(axis=0)
    radius = np.linalg.norm(mesh.vertices - centre, axis=1).max()
    col, row = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    ndc = np.stack([2 * col / w - 1, 1 - 2 * row / h, np.ones_like(col), np.ones_like(col)], axis=-1)
    far = ndc @ np.linalg.inv(camera.view_proj()).T
    d = far[..., :3] / far[..., 3:] - camera.eye
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    oc = camera.eye - centre
    b = d @ oc
    disc = b * b - (oc @ oc - radius * radius)
    mask = disc > 0
    t = -b - np.sqrt(np.where(mask, disc, 0))
    hit = camera.eye + t[..., None] * d
    pos = np.where(mask[..., None], hit - origin, 0).astype(dt)
    nrm = np.where(mask[..., None], (hit - centre) / radius, 0).astype(dt)
    return GBuffer(pos, nrm, mask, (0, 0, np.zeros((0, 0), np.float32)), (0, 0, np.zeros((0, 0), np.int32)),
                   camera.view_proj(), np.asarray(origin, dtype=np.float64))


def warm(options: dict) -> None:
    """One reflector's stages of a render with ``options`` (RenderOptions keyword arguments) on
    the built-in ``sphere`` scene at :data:`SIZE`.

    The order is the one that keeps both processes busy: the search first (the command needs it
    right after the main view's raster, its own first work); then the kernels that come after
    the sub-texel refinement, called on the ball's search results through the functions the
    render calls them through (the same types), while the command, done with its raster,
    compiles the refinement itself; then two frames of the reflector's stages (a fresh and a
    coherent search: whatever is left, the exact drawing's acceptance by the candidates' loop),
    the composite's conversion to 8 bits and the frame writer's encoder of flat pictures; last
    what only some scenes need: with
    ``images="all"`` the enumeration of every image (which the ball's own render skips as
    convex), and the traced acceptance."""
    from . import constants
    from .frame.driver import composite
    from .options import RenderOptions
    from .raster import to_uint8
    from .scene import load_scene
    from .search import method as vertex_search
    from .search import search
    from .search.reflect import coherent_starts, gbuffer_camera
    from .seam import FrameView

    opts = RenderOptions(**options)
    if opts.tessellate is not None and opts.tessellate_span > 1:  # the small ball's edges are
        # short: a span of 1 measures some of them, so that the tessellation's kernels are compiled
        # (with the same types) whatever the span
        opts = dataclasses.replace(opts, tessellate_span=1)
    scene = load_scene("sphere", width=SIZE[0], height=SIZE[1])
    method = vertex_search.VertexSearch(scene, opts)
    method.make_gbuffer = ball_gbuffer
    k = scene.reflector_ids[0]
    meshes = [scene.world_mesh(j) for j in range(1, len(scene.objects) + 1)]
    transforms = {j: scene.transform_at(j, 0) for j in range(1, len(scene.objects) + 1)}
    camera = scene.camera_at(0)
    # no main view is rasterized here: the exact drawing's reflected rays start on the ball's
    # first triangle, which gives its kernels the render's types
    stencil = ball_gbuffer(scene.world_mesh(k, 0, proxy=True), camera, "float32", camera.eye).mask
    main = SimpleNamespace(triangle=np.where(stencil, 0, -1).astype(np.int64))
    view = FrameView(scene, 0, camera, meshes, main, transforms)
    proxy = scene.world_mesh(k, 0, proxy=True)
    gcam = gbuffer_camera(scene, 0, opts.widen, opts.gbuffer_size)
    gb = ball_gbuffer(proxy, gcam, opts.precision, gcam.eye)
    verts = view.vertices
    found = search(gb, camera.eye, verts, opts.neighbourhood, opts.inverse,
                   coherent_starts(None, len(verts), gb.mask.shape), opts.cap, method=opts.method)
    _after_refinement(opts, gb, found, verts, camera)
    # the ball's stencil is small enough that its candidates crowd: its frames would take the
    # traced acceptance, which most scenes' mirrors never need; they take the candidates' loop
    # here, and the traced acceptance is compiled last
    cover, constants.EXACT_TRACE_COVER = constants.EXACT_TRACE_COVER, float("inf")
    try:
        for _ in range(2):
            res = method.reflect(view, k, stencil)
    finally:
        constants.EXACT_TRACE_COVER = cover
    if res.box is not None:
        colour = np.zeros(stencil.shape + (3,), np.float32)
        reflected = np.full(stencil.shape, -1, np.int32)
        composite(colour, reflected, colour.copy(), res.colour, res.reflected_id, res.covered, res.box, 1.0)
        to_uint8(colour)
    _picture_encoder()
    if opts.images == "all":
        # the ball is convex, so its render skips the enumeration: compiled here, after what every
        # scene needs, for the scenes whose mirrors are not (the render calls it with these types)
        from .search.images import find_images

        find_images(gb, camera.eye, verts, found)
    if opts.draw in ("exact", "edges"):
        _both_acceptances()


def _picture_encoder() -> None:
    """The frame writer's encoder of flat pictures (:mod:`refsoft.io.neighbour`), through the PNG
    writer as a render's frames call it (a flat image, written to a temporary folder)."""
    import tempfile

    from .frame.outputs import FRAME_LEVEL
    from .io import write_png_rows

    with tempfile.TemporaryDirectory() as folder:
        write_png_rows(os.path.join(folder, "flat.png"), np.zeros((256, 256, 3), np.uint8), FRAME_LEVEL)


def _both_acceptances() -> None:
    """Compile both ways of the exact drawing's acceptance (the candidates' own loop and the
    traced one: the ball's frames take one of them, a scene's mirror may need the other), with
    the types the render calls them with (C-ordered arrays made by :func:`refsoft.search.
    acceptance.nearest`'s callers)."""
    from .search import acceptance

    valid = np.ones((1, 1), bool)
    origin, direction = np.zeros((1, 1, 3)), np.ones((1, 1, 3))
    screen, bbox, dilate = np.zeros((1, 3, 2)), np.zeros((1, 4), np.int64), np.ones(1)
    cand = acceptance.Candidates(None, np.zeros((1, 3, 3)), None, None, np.zeros(1, np.int64), 0)
    for traced in (False, True):
        acceptance.nearest(cand, None, None, (0, 1, 0, 1), rays=(valid, origin, direction),
                           screen=(screen, bbox, dilate), runs=False, traced=traced)


def _after_refinement(opts, gb, res, verts, camera) -> None:
    """Compile, in the order a frame needs them after the refinement, the kernels these options
    call there: the virtual vertices from sub-texel points, the virtual pass's triangle test, the
    tessellation's edge errors and the 8-bit conversion; each through the function the render
    calls it through, which fixes its argument types (``tests/test_warmup.py`` checks that the
    render then compiles none of them again)."""
    from .raster import to_uint8
    from .search import skips, virtual_vertices
    from .search.tessellate import edge_errors

    n = min(len(verts), 8)
    if opts.refine and n:
        surface = np.zeros((len(verts), 3), gb.position.dtype)
        virtual_vertices(gb, res, verts, relative=True, surface=(surface, surface), rule=opts.virtual, eye=camera.eye)
    skips.triangles_skipped(np.zeros((3, 4)), np.zeros((1, 3), np.int64), np.zeros(3, np.uint8), 0,
                            skips.box_planes((0, 1, 0, 1), camera.width, camera.height) if opts.cull_virtual else None,
                            serial=True)
    if opts.tessellate is not None and n:
        offset = np.zeros((n, 2), gb.position.dtype) if opts.refine else None
        edge_errors(gb, camera.eye, verts[:n], verts[:n][::-1], res.pixel[:n], res.pixel[:n][::-1], offset, offset)
    to_uint8(np.zeros((1, 1, 3), np.float32))


if __name__ == "__main__":
    warm(json.loads(sys.argv[1]))
