"""Each pipeline stage on its own, per paper scene at 1024x768 (frame 1, default options, the
first reflector; JIT warm-up excluded): G-buffer raster, search cold and coherent (started at
frame 0's pixels), virtual raster over the stencil's box, composite, main view, and the
ray-traced truth of the frame.

Run: ``pytest benchmarks/test_bench_stages.py --benchmark-columns=min,median,rounds``.
"""

import numpy as np
import pytest

import refsoft
from refsoft.raster import color_pass
from refsoft.search.reflect import reflect, reflector_gbuffer
from refsoft.scene import scene_vertices
from refsoft.frame.driver import composite
from refsoft.search.virtual import virtual_parts as _virtual_parts, virtual_pass as _virtual_pass
from refsoft.seam import stencil_box as _stencil_box
from refsoft.search import search

SCENES = ["kitchen", "ufo", "ants"]
STAGES = ["gbuffer", "search_cold", "search_coherent", "virtual", "composite", "main", "truth"]


@pytest.fixture(scope="module", params=SCENES)
def case(request):
    scene = refsoft.load_scene(request.param, width=1024, height=768)
    k = scene.reflector_ids[0]
    _, _, r0 = reflect(scene, 0, [k])
    verts, owner, r1 = reflect(scene, 1, [k], previous={k: r0[k].result.pixel})
    meshes = [scene.world_mesh(i, 1) for i in range(1, len(scene.objects) + 1)]
    view = color_pass(meshes, [o.color for o in scene.objects], scene.camera_at(1))
    stencil = view.object_id == k
    return dict(name=request.param, scene=scene, k=k, verts=verts, prev=r0[k].result.pixel, refl=r1[k], meshes=meshes,
                view=view, stencil=stencil, box=_stencil_box(stencil))


@pytest.mark.parametrize("stage", STAGES)
def test_stage(benchmark, case, stage):
    scene, k, refl = case["scene"], case["k"], case["refl"]
    eye = scene.camera_at(1).eye
    gb = refl.gbuffer
    benchmark.group = f"stages {case['name']} 1024x768"
    if stage == "gbuffer":
        fn = lambda: reflector_gbuffer(scene, k, 1)  # noqa: E731
    elif stage == "search_cold":
        fn = lambda: search(gb, eye, case["verts"])  # noqa: E731
    elif stage == "search_coherent":
        fn = lambda: search(gb, eye, case["verts"], previous=case["prev"])  # noqa: E731
    elif stage == "virtual":
        fn = lambda: _virtual_pass(scene, _virtual_parts(scene, case["meshes"], refl), scene.camera_at(1),  # noqa: E731
                                   case["stencil"], case["box"], "plane")
    elif stage == "composite":
        vcol, vid, covered, _ = _virtual_pass(scene, _virtual_parts(scene, case["meshes"], refl), scene.camera_at(1),
                                              case["stencil"], case["box"], "plane")
        colour = case["view"].color.copy()
        reflected = np.full(colour.shape[:2], -1, np.int32)
        fn = lambda: composite(colour, reflected, case["view"].color, vcol, vid, covered, case["box"], 1.0)  # noqa: E731
    elif stage == "main":
        fn = lambda: color_pass(case["meshes"], [o.color for o in scene.objects], scene.camera_at(1))  # noqa: E731
    else:
        from refsoft.truth.raytrace import TruthRenderer

        tr = TruthRenderer(scene, exact=False)
        tr.render_frame(0)
        fn = lambda: tr.render_frame(1)  # noqa: E731
    fn()  # compile outside the timing
    benchmark.extra_info["scene"] = case["name"]
    benchmark.pedantic(fn, rounds=5)
