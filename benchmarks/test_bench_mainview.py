"""The main view and the virtual pass of the paper scenes at 1024x768 (frame 1): refsoft against
Mesa llvmpipe drawing the same triangles with the same outputs, same run.

- main view: :func:`refsoft.raster.color_pass` of every object (shaded colour, object id, depth)
  against :func:`peers.llvmpipe_main_view`;
- virtual pass: :func:`refsoft.search.virtual.virtual_pass` of each reflector (the virtual
  triangles of frame 1, rendered right after frame 0 with the default options, inside the
  reflector's stencil box) against :func:`peers.llvmpipe_virtual_pass` scissored to that box.

Run: ``pytest benchmarks/test_bench_mainview.py --benchmark-columns=min,median,rounds``.
"""

import numpy as np
import pytest

import refsoft
from peers import llvmpipe_available, llvmpipe_main_view, llvmpipe_virtual_pass
from refsoft import raster
from refsoft.frame import FrameDriver
from refsoft.search import method as search_method
from refsoft.search.virtual import virtual_pass

SCENES = ["kitchen", "ufo", "ants"]
FRAME = 1
_CACHE = {}


def frame_inputs(name):
    """The scene, frame 1's world meshes, colours and camera, and each reflector's
    ``virtual_pass`` arguments as the frame driver gave them (frame 1 after frame 0)."""
    if name not in _CACHE:
        scene = refsoft.load_scene(name, width=1024, height=768)
        driver = FrameDriver(scene)
        driver.render_frame(FRAME - 1)
        calls = []
        original = search_method.virtual_pass

        def record(*args):
            calls.append(args)
            return original(*args)

        search_method.virtual_pass = record
        try:
            driver.render_frame(FRAME)
        finally:
            search_method.virtual_pass = original
        _CACHE[name] = (scene, driver._world_meshes(FRAME), [o.color for o in scene.objects], scene.camera_at(FRAME),
                        calls)
    return _CACHE[name]


def _need_llvmpipe():
    reason = llvmpipe_available()
    if reason:
        pytest.skip(f"llvmpipe peer not available: {reason}")


@pytest.mark.parametrize("name", SCENES)
def test_refsoft_main_view(benchmark, name):
    _, meshes, colors, camera, _ = frame_inputs(name)
    raster.color_pass(meshes, colors, camera)  # compile / warm up outside the timing
    benchmark.group = f"main view {name} 1024x768"
    view = benchmark(raster.color_pass, meshes, colors, camera)
    benchmark.extra_info["triangles"] = int(sum(m.n_faces for m in meshes))
    benchmark.extra_info["covered_share"] = float((view.object_id > 0).mean())


@pytest.mark.parametrize("name", SCENES)
def test_llvmpipe_main_view(benchmark, name):
    _need_llvmpipe()
    _, meshes, colors, camera, _ = frame_inputs(name)
    peer = llvmpipe_main_view(meshes, colors, camera)
    try:
        peer.draw()
        benchmark.group = f"main view {name} 1024x768"
        benchmark(peer.draw)
        # the same picture: object ids agree except on a few edge pixels (depth rounding)
        _, ids, _ = peer.read()
        ours = raster.color_pass(meshes, colors, camera).object_id
        benchmark.extra_info["id_pixels_that_differ"] = int((ids != ours).sum())
        assert (ids != ours).mean() < 0.01
    finally:
        peer.release()


def _reflector_cases():
    return [(name, i) for name, n in (("kitchen", 1), ("ufo", 1), ("ants", 8)) for i in range(n)]


def _call(name, i):
    calls = frame_inputs(name)[4]
    if i >= len(calls):
        pytest.skip(f"{name} has {len(calls)} reflectors with a virtual pass in frame {FRAME}")
    return calls[i]


@pytest.mark.parametrize("name,i", _reflector_cases())
def test_refsoft_virtual_pass(benchmark, name, i):
    args = _call(name, i)
    virtual_pass(*args)
    benchmark.group = f"virtual pass {name} reflector {i} 1024x768"
    colour, rid, covered, _ = benchmark(virtual_pass, *args)
    r0, r1, c0, c1 = args[4]
    benchmark.extra_info["box_pixels"] = int((r1 - r0) * (c1 - c0))
    benchmark.extra_info["covered_pixels"] = int(covered.sum())
    benchmark.extra_info["triangles"] = int(sum(len(p[2]) for p in args[1]))


@pytest.mark.parametrize("name,i", _reflector_cases())
def test_llvmpipe_virtual_pass(benchmark, name, i):
    _need_llvmpipe()
    scene, parts, camera, stencil, box, inverse = _call(name, i)[:6]
    peer = llvmpipe_virtual_pass(scene, parts, camera, box, inverse)
    try:
        peer.draw()
        benchmark.group = f"virtual pass {name} reflector {i} 1024x768"
        benchmark(peer.draw)
        _, ids, _ = peer.read()
        r0, r1, c0, c1 = box
        _, rid, covered, _ = virtual_pass(*_call(name, i))
        theirs = np.where(stencil[r0:r1, c0:c1], ids[r0:r1, c0:c1], 0)
        benchmark.extra_info["id_pixels_that_differ"] = int((theirs != rid).sum())
        assert (theirs != rid).mean() < 0.02
    finally:
        peer.release()
