"""The memory guard's estimate with full tessellation (threshold 0), which splits every
reflected triangle not culled at every level: above what one frame allocates."""

import tracemalloc

import pytest

import refsoft
from refsoft.frame import FrameDriver, RenderOptions
from refsoft.limits import frame_bytes


@pytest.mark.parametrize("name", ["planar", "sphere"])
def test_full_tessellation_estimate_bounds_the_traced_peak(name):
    """tracemalloc's peak of a frame with full tessellation is below the estimate, which counts
    4 ** max_level triangles per reflected triangle (the frames make 21.5x on planar, 13.6x on
    sphere at this size; tracemalloc's peak is 2.0x and 1.3x an estimate of 4x)."""
    scene = refsoft.load_scene(name, width=320, height=240)
    opts = RenderOptions(tessellate=0.0, max_level=3, tessellate_span=0)  # every edge measured, every one split
    FrameDriver(scene, opts).render_frame(0)  # compiled, caches warm
    tracemalloc.start()
    try:
        frame = FrameDriver(scene, opts).render_frame(0)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    est = frame_bytes(scene, opts)["total"]
    assert peak < est, (peak, est)
    assert est > frame_bytes(scene, RenderOptions())["total"]
    # the triangles the tessellation made are within the count the estimate assumes
    n_reflected = sum(o.mesh.n_faces for o in scene.objects if not o.reflector)
    made = frame.report["skipped"]["tessellation"]["1"]["triangles"]
    assert 4 * n_reflected < made <= 4 ** opts.max_level * n_reflected


def test_full_tessellation_counts_its_levels():
    scene = refsoft.load_scene("planar", width=160, height=120)
    raster = dict(draw="raster")  # the tessellation's own count (the exact drawing's grows with it too)
    work = [frame_bytes(scene, RenderOptions(tessellate=0.0, max_level=m, **raster))["work"] for m in (1, 2, 3, 4)]
    assert work[0] == frame_bytes(scene, RenderOptions(max_level=1, **raster))["work"]  # 4 triangles either way
    assert work[1] < work[2] < work[3]
    assert (frame_bytes(scene, RenderOptions(max_level=4, **raster))["work"]
            == frame_bytes(scene, RenderOptions(**raster))["work"])
    exact = [frame_bytes(scene, RenderOptions(tessellate=0.0, max_level=m))["work"] for m in (1, 2, 3, 4)]
    assert all(e > w for e, w in zip(exact, work)) and exact[1] - work[1] < exact[2] - work[2]
