"""The memory guard (refsoft.limits): sizes, the limit's sources, refusals, and the estimate
against what a frame really allocates."""

import tracemalloc

import numpy as np
import pytest

import refsoft
from refsoft import cli
from refsoft.errors import LimitError, RefsoftError
from refsoft.limits import check_frame_memory, frame_bytes, memory_limit, parse_bytes
from refsoft.frame import FrameDriver, RenderOptions, render
from refsoft.truth.raytrace import render_truth as truth


@pytest.mark.parametrize("text, value", [("4G", 4 << 30), ("512M", 512 << 20), ("1.5GiB", 3 << 29), ("100", 100),
                                         (2048, 2048), ("64kb", 64 << 10), (" 2 g ", 2 << 30)])
def test_parse_bytes(text, value):
    assert parse_bytes(text) == value


@pytest.mark.parametrize("text", ["", "G", "4X", "-1G", "0", "four", True, "1e9"])
def test_parse_bytes_refuses(text):
    with pytest.raises(RefsoftError, match="memory limit"):
        parse_bytes(text)


def test_limit_sources(monkeypatch):
    monkeypatch.delenv("REFSOFT_MEMORY_LIMIT", raising=False)
    assert memory_limit() == refsoft.constants.MEMORY_LIMIT_BYTES
    monkeypatch.setenv("REFSOFT_MEMORY_LIMIT", "3G")
    assert memory_limit() == 3 << 30
    assert memory_limit("1G") == 1 << 30  # the argument wins


def test_estimate_grows_with_what_it_counts():
    scene = refsoft.load_scene("ants", width=160, height=120)
    base = frame_bytes(scene, RenderOptions())
    assert frame_bytes(scene, RenderOptions(precision="float64"))["total"] > base["total"]
    assert frame_bytes(scene, RenderOptions(widen=2.0))["gbuffers"] == pytest.approx(4 * base["gbuffers"], rel=0.05)
    assert frame_bytes(scene, RenderOptions(), frames_kept=10)["total"] > 9 * (base["view"] + base["gbuffers"])
    assert frame_bytes(scene, RenderOptions(reuse=False))["cache"] == 0 < base["cache"]


@pytest.mark.parametrize("name", ["sphere", "ants"])
def test_estimate_bounds_the_traced_peak(name):
    """The estimate is above what NumPy allocates for one frame (tracemalloc's peak) and within
    3x of it (measured 1.3x-2.3x at 640x480 on sphere, kitchen, ufo, ants)."""
    scene = refsoft.load_scene(name, width=320, height=240)
    FrameDriver(scene).render_frame(0)  # compiled, caches warm
    tracemalloc.start()
    try:
        FrameDriver(scene).render_frame(0)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    est = frame_bytes(scene, RenderOptions())["total"]
    assert peak < est < 3 * peak, (peak, est)


@pytest.mark.parametrize("name", ["planar", "sphere"])
def test_hierarchy_estimate_bounds_its_traced_peak(name):
    """The hierarchy search packs the G-buffer and builds a pyramid, counted for it only, at the
    size of a mirror filling the G-buffer (the crop is not known before rendering): within 3x of
    the traced peak where the mirror fills much of the view (planar: 1.3x), above it for a
    small mirror (sphere: 4.1x)."""
    scene = refsoft.load_scene(name, width=320, height=240)
    opts = RenderOptions(method="hierarchy")
    FrameDriver(scene, opts).render_frame(0)
    tracemalloc.start()
    try:
        FrameDriver(scene, opts).render_frame(0)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    est = frame_bytes(scene, opts)["total"]
    assert peak < est, (peak, est)
    if name == "planar":
        assert est < 3 * peak, (peak, est)
    assert est > frame_bytes(scene, RenderOptions())["total"]


def test_render_over_the_limit_is_refused_before_any_work(tmp_path):
    with pytest.raises(LimitError, match=r"needs about .* above the memory limit of 1.0 MiB"):
        render("sphere", frames=1, out=tmp_path / "o", memory_limit="1M")
    assert not (tmp_path / "o").exists()
    scene = refsoft.load_scene("sphere", width=64, height=48)
    with pytest.raises(LimitError):
        check_frame_memory(scene, RenderOptions(), frames_kept=1, limit=1000)
    with pytest.raises(LimitError):
        truth(scene, frames=1, memory_limit=1000)


def test_keeping_every_frame_counts_every_frame():
    scene = refsoft.load_scene("quad", width=64, height=48)
    est = frame_bytes(scene, RenderOptions())
    limit = int(est["total"] + 1.5 * (est["view"] + est["gbuffers"] + est["vertices"]))
    render(scene, frames=4, keep=False, memory_limit=limit)  # one frame at a time: fits
    with pytest.raises(LimitError, match="x 4 frames kept"):
        render(scene, frames=4, keep=True, memory_limit=limit)


def test_cli_huge_image_is_refused_by_the_guard(tmp_path, capsys):
    out = tmp_path / "o"
    out.mkdir()
    (out / "frame_0000.png").write_bytes(b"keep me")
    assert cli.main(["render", "sphere", "--width", "16000", "--height", "4000", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "needs about" in err[0] and "--memory-limit" in err[0]
    assert (out / "frame_0000.png").read_bytes() == b"keep me" and sorted(p.name for p in out.iterdir()) == ["frame_0000.png"]
    assert cli.main(["render", "sphere", "--width", "64", "--height", "48", "--memory-limit", "64k",
                     "--out", str(out)]) == 2
    assert cli.main(["truth", "sphere", "--width", "64", "--height", "48", "--memory-limit", "lots",
                     "--out", str(out)]) == 2
    assert cli.main(["gbuffer", "sphere", "--width", "64", "--height", "48", "--memory-limit", "64k",
                     "--out", str(out)]) == 2
    assert sorted(p.name for p in out.iterdir()) == ["frame_0000.png"]


@pytest.mark.parametrize("shape, dtype", [((8, 8), np.float32), ((768, 1024, 3), np.float32), ((768, 1024), bool),
                                          ((600, 900), np.int32)])
def test_lazy_zeros_are_zero_writable_arrays(shape, dtype):
    from refsoft.limits import LAZY_ZEROS_BYTES, zeros

    a = zeros(shape, dtype)
    assert a.shape == shape and a.dtype == np.dtype(dtype) and a.flags.c_contiguous and a.flags.writeable
    assert not a.any()
    a.reshape(-1)[5] = 1
    assert np.count_nonzero(a) == 1 and a.reshape(-1)[5] == 1
    b = zeros(shape, dtype)  # fresh memory, not the block just written
    assert not b.any()
    base = a
    while getattr(base, "base", None) is not None:
        base = base.base
    import mmap

    base = base.obj if isinstance(base, memoryview) else base
    assert isinstance(base, mmap.mmap) == (a.nbytes >= LAZY_ZEROS_BYTES)


@pytest.mark.parametrize("shape", [(1, 1), (3, 5), (768, 1024)])
def test_maps_from_one_block_are_separate_aligned_arrays(shape):
    from refsoft.limits import maps

    a, b, c = maps(shape, np.float32, np.int32, np.uint8)
    for m, dt in ((a, np.float32), (b, np.int32), (c, np.uint8)):
        assert m.shape == shape and m.dtype == dt and m.flags.c_contiguous and m.flags.writeable
        assert m.ctypes.data % np.dtype(dt).itemsize == 0
    a.fill(1.5)
    b.fill(-1)
    c.fill(7)
    assert (a == 1.5).all() and (b == -1).all() and (c == 7).all()  # no overlap


def test_full_size_gbuffer_from_lazy_maps_equals_the_uncropped_one():
    import refsoft
    from refsoft import raster

    scene = refsoft.load_scene("sphere", width=1024, height=768)
    cam = scene.camera
    mesh = scene.world_mesh(1, 0, proxy=True)
    a = raster.gbuffer(mesh, cam, origin=cam.eye)
    b = raster.gbuffer(mesh, cam, origin=cam.eye, crop=False)
    for field in ("position", "normal", "mask", "depth", "triangle"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field), err_msg=field)


@pytest.mark.parametrize("method, option, what", [("ldt", "ldt_resolution", "layered depth textures"),
                                                  ("envmap", "envmap_resolution", "cube maps")])
def test_per_pixel_method_estimate_counts_its_textures_and_bounds_the_traced_peak(method, option, what):
    """The layered depth textures (counted at the most layers the build peels, 8) and the cube
    maps: above the traced peak of a first frame, which builds them, and growing as R^2."""
    scene = refsoft.load_scene("sphere", width=160, height=120)
    opts = RenderOptions(method=method, **{option: 64})
    FrameDriver(scene, opts).render_frame(0)  # compiled
    tracemalloc.start()
    try:
        FrameDriver(scene, opts).render_frame(0)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    est = frame_bytes(scene, opts)
    assert peak < est["total"], (peak, est)
    assert frame_bytes(scene, RenderOptions(method=method, **{option: 128}))["textures"] == 4 * est["textures"]
    if method == "ldt":
        assert frame_bytes(scene, RenderOptions(method="ldt", ldt_resolution=64, ldt_layers=1))["textures"] \
            < est["textures"]
    flag = "--" + option.replace("_", "-")
    with pytest.raises(LimitError, match=f"{what} .* {flag}"):
        check_frame_memory(scene, RenderOptions(method=method, **{option: 4096}), limit="1G")


def test_images_estimate_counts_the_enumeration_and_bounds_its_traced_peak():
    """With every image (``images="all"``) on a mirror that is not convex, the enumeration's
    packed G-buffer, dilated pyramid and per-vertex arrays are counted, and the estimate stays
    above the traced peak; a convex mirror's estimate is the same either way (it is skipped)."""
    scene = refsoft.load_scene("concave", width=160, height=120)
    one, every = frame_bytes(scene, RenderOptions(images="one")), frame_bytes(scene, RenderOptions(images="all"))
    assert every["work"] > one["work"] and every["vertices"] > one["vertices"]
    ball = refsoft.load_scene("sphere", width=160, height=120)
    assert frame_bytes(ball, RenderOptions(images="all")) == frame_bytes(ball, RenderOptions(images="one"))
    opts = RenderOptions(images="all")
    FrameDriver(scene, opts).render_frame(0)
    tracemalloc.start()
    try:
        fr = FrameDriver(scene, opts).render_frame(0)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert fr.report["images"], "the enumeration ran"
    assert peak < every["total"] < 3 * peak, (peak, every["total"])


def test_reading_lazy_zeros_takes_no_memory():
    """A lazily zeroed map only read (as the frame's writer reads a whole G-buffer) maps the
    kernel's zero page: the process's resident memory does not grow by the map's size (a shared
    anonymous mapping grows by all of it)."""
    import os

    from refsoft.limits import zeros

    if not os.path.exists("/proc/self/statm"):
        pytest.fail("needs Linux's /proc/self/statm")

    def resident():
        with open("/proc/self/statm") as fh:
            return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")

    a = zeros((2048, 4096), np.float32)  # 32 MiB
    before = resident()
    assert float(a.sum()) == 0.0
    assert resident() - before < a.nbytes // 8
