"""The first run's warm-up process (refsoft._warmup) and the kernels' compile lock
(refsoft._numba._compile_once): the warm-up compiles the kernels a render calls, with the same
types; a kernel's lock file is exclusive across processes."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

import refsoft
from refsoft import _numba, _warmup
from refsoft.cli import commands
from refsoft.options import RenderOptions

OPTIONS = [{"preset": "accurate"}, {"preset": "paper"}, {"preset": "accurate", "precision": "float64"}]
#: The main view's raster kernels (refsoft/raster/_kernels.py): the command's own first work.
MAIN_VIEW_RASTER = {"_bin_count", "_bin_fill", "count_clip_triangles", "emit_clip_triangles", "raster_tiles",
                    "shade_visible", "vertex_setup"}


CHILD = r"""
import json, sys
import refsoft
from refsoft import _numba, _warmup
options = json.loads(sys.argv[1])
_warmup.warm(options)
warmed = {d: set(d.signatures) for d in _numba.KERNELS}
refsoft.render(sys.argv[2] if len(sys.argv) > 2 else "sphere", frames=2, width=80, height=60, **options)
print(json.dumps({"warmed": sorted(d.py_func.__name__ for d in _numba.KERNELS if warmed.get(d)),
                  "types": {d.py_func.__name__: len(warmed[d]) for d in _numba.KERNELS if warmed.get(d)},
                  "new": sorted(d.py_func.__name__ for d in _numba.KERNELS if set(d.signatures) - warmed.get(d, set()))}))
"""


@pytest.mark.parametrize("options", OPTIONS, ids=lambda o: "-".join(map(str, o.values())))
def test_a_render_after_the_warm_up_calls_its_kernels_with_the_same_types(options):
    """In a process of its own (every kernel unloaded at the start): the warm-up, then a render
    with the same options, which must call no kernel with types the warm-up did not."""
    out = subprocess.run([sys.executable, "-c", CHILD, json.dumps(options)], capture_output=True, text=True,
                         check=True)
    got = json.loads(out.stdout.strip().splitlines()[-1])
    exact = RenderOptions(**options).draw == "exact"
    # the virtual triangles rasterized (the paper preset) or drawn exactly (the accurate one)
    assert "search_lanes" in got["warmed"] and ("accept_untracked" if exact else "shade_visible") in got["warmed"]
    # only the G-buffer's interpolation, which the warm-up's ray-cast ball does not need, may be
    # new; and, drawn exactly, the main view's raster, which the command compiles first itself
    allowed = {"interpolate_pair"} | (MAIN_VIEW_RASTER if exact else set())
    assert set(got["new"]) <= allowed, got["new"]
    # the kernels compiled ahead of the frame's order were called with the render's types only
    primed = {"virtual_from_points", "_triangles_skipped", "edge_errors", "to_uint8_flat"}
    calls = {name: got["types"].get(name, 0) for name in primed}
    if options["preset"] == "accurate":  # which calls all four
        assert calls == dict.fromkeys(primed, 1), calls
    assert max(calls.values()) <= 1, calls


WRITER_CHILD = r"""
import json, sys, tempfile
import refsoft
from refsoft import _numba, _warmup
_warmup.warm({"preset": "accurate"})
warmed = {d: set(d.signatures) for d in _numba.KERNELS}
from refsoft.io import neighbour
encoded, plain = [], neighbour.neighbour_deflate
def counted(*a, **k):
    got = plain(*a, **k)
    encoded.append(got is not None)
    return got
neighbour.neighbour_deflate = counted
with tempfile.TemporaryDirectory() as out:
    refsoft.render("kitchen", frames=1, width=640, height=480, out=out)
print(json.dumps({"warmed": sorted(d.py_func.__name__ for d in _numba.KERNELS if warmed.get(d)),
                  "encoded": sum(encoded),
                  "new": sorted(d.py_func.__name__ for d in _numba.KERNELS if set(d.signatures) - warmed.get(d, set()))}))
"""


def test_the_warm_up_compiles_the_frame_writers_picture_encoder():
    """The README's job writes its frames' flat pictures with the encoder of refsoft.io.neighbour:
    the warm-up compiles it with the types the writer calls it with (a frame written after it
    compiles no new specialisation of the encoder)."""
    out = subprocess.run([sys.executable, "-c", WRITER_CHILD], capture_output=True, text=True, check=True)
    got = json.loads(out.stdout.strip().splitlines()[-1])
    assert "_encode" in got["warmed"] and got["encoded"] > 0  # the frame's pictures went through it
    assert not {"_encode", "_run"} & set(got["new"]), got["new"]


def test_the_warm_up_compiles_the_enumeration_of_every_image():
    """With ``images="all"`` the warm-up compiles the enumeration's kernels (the ball's render
    skips it as convex) with the types a render on a mirror that is not convex calls them with."""
    from refsoft.search import _images

    options = {"preset": "accurate"}
    out = subprocess.run([sys.executable, "-c", CHILD, json.dumps(options), "concave"], capture_output=True, text=True,
                         check=True)
    got = json.loads(out.stdout.strip().splitlines()[-1])
    top = {"enumerate_all", "dilated_base"}  # called from Python (their callees compile with them)
    mine = {name for name in dir(_images) if hasattr(getattr(_images, name), "signatures")}
    assert top <= mine and top <= set(got["warmed"]), got["warmed"]
    assert not mine & set(got["new"]), got["new"]


def test_ball_gbuffer_is_a_ball_seen_by_the_camera():
    scene = refsoft.load_scene("sphere", width=64, height=48)
    cam = scene.camera_at(0)
    proxy = scene.world_mesh(scene.reflector_ids[0], 0, proxy=True)
    gb = _warmup.ball_gbuffer(proxy, cam, "float32", cam.eye)
    assert gb.position.dtype == np.float32 and gb.position.shape == (48, 64, 3) and gb.mask.any()
    centre = proxy.vertices.mean(axis=0)
    radius = np.linalg.norm(proxy.vertices - centre, axis=1).max()
    world = gb.position[gb.mask].astype(np.float64) + cam.eye
    np.testing.assert_allclose(np.linalg.norm(world - centre, axis=1), radius, rtol=1e-5)
    np.testing.assert_allclose(np.linalg.norm(gb.normal[gb.mask], axis=1), 1, rtol=1e-5)
    real = refsoft.raster.gbuffer(proxy, cam, "float32", origin=cam.eye)
    assert (real.mask != gb.mask).mean() < 0.05  # the icosphere proxy and its bounding ball


def test_start_only_when_it_can_help(monkeypatch):
    monkeypatch.setenv("REFSOFT_WARMUP", "0")
    assert _warmup.start({"preset": "accurate"}) is None
    monkeypatch.delenv("REFSOFT_WARMUP")
    assert _warmup.start({"method": "ldt"}) is None and _warmup.start({"method": "envmap"}) is None


def test_first_run_notice_starts_and_ends_the_warm_up(monkeypatch):
    started = []

    class Process:
        killed = False

        def poll(self):
            return None if not self.killed else -9

        def kill(self):
            self.killed = True

        def wait(self):
            return -9

    monkeypatch.setattr(_numba, "kernels_cached", lambda: False)
    monkeypatch.setattr(_warmup, "start", lambda options: started.append(options) or Process())
    notice = commands._FirstRunNotice("render", 35, warm={"preset": "paper"})
    notice()
    assert notice.compiling and started == [{"preset": "paper"}]
    notice.close()
    assert notice.process.killed
    monkeypatch.setattr(_numba, "kernels_cached", lambda: True)
    cached = commands._FirstRunNotice("render", 35, warm={"preset": "paper"})
    cached()
    cached.close()
    assert not cached.compiling and cached.process is None and len(started) == 1


def test_a_first_run_starts_the_warm_up_before_the_scene_and_ends_it_on_bad_input(monkeypatch, tmp_path):
    from refsoft.cli import main

    events = []

    class Process:
        def poll(self):
            return None

        def kill(self):
            events.append("killed")

        def wait(self):
            return -9

    real_load = commands._scene
    monkeypatch.setattr(_numba, "kernels_cached", lambda: False)
    monkeypatch.setattr(_warmup, "start", lambda options: events.append("started") or Process())
    monkeypatch.setattr(commands, "_scene", lambda args: events.append("scene") or real_load(args))
    assert main(["render", "sphere", "--frames", "2", "--frame", "1", "--out", str(tmp_path / "o")]) == 2
    assert events == ["started", "scene", "killed"]
    assert not (tmp_path / "o").exists()


def test_every_kernel_compiles_behind_its_lock():
    assert all(getattr(d.compile, "__name__", "") == "compile" and d.compile.__qualname__.startswith("_compile_once")
               for d in _numba.KERNELS)


def test_lock_file_is_exclusive_across_processes():
    d = _numba.KERNELS[0]
    probe = ("import fcntl, os, sys\n"
             "fd = os.open(sys.argv[1], os.O_RDWR)\n"
             "try:\n    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)\n    print('free')\n"
             "except BlockingIOError:\n    print('held')\n")
    f = d.py_func
    path = os.path.join(d._cache._cache_path, f"{f.__qualname__}-{f.__code__.co_firstlineno}.lock")
    with _numba._lock_file(d):
        assert os.path.exists(path)
        held = subprocess.run([sys.executable, "-c", probe, path], capture_output=True, text=True, check=True)
    free = subprocess.run([sys.executable, "-c", probe, path], capture_output=True, text=True, check=True)
    assert held.stdout.strip() == "held" and free.stdout.strip() == "free"


def test_the_warm_up_process_imports_this_refsoft_wherever_it_starts(tmp_path, monkeypatch):
    """Started from a folder holding another ``refsoft`` (a source tree beside an installed
    package), the process still runs the refsoft that started it, whose cache the command reads."""
    (tmp_path / "refsoft").mkdir()
    (tmp_path / "refsoft" / "__init__.py").write_text("raise SystemExit(3)\n")
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("REFSOFT_WARMUP", raising=False)
    process = _warmup.start({"preset": "paper"})
    assert process is not None and process.wait(timeout=600) == 0
