"""Small passes on one thread (refsoft.raster._threads): the thread count inside and after, the
same results on one thread and split among threads."""

import os
import subprocess
import sys

from refsoft._parallel import thread_count
from refsoft.raster._threads import SERIAL_MAX_PIXELS, one_thread, serial_if_small


def test_serial_if_small_sets_one_thread_inside_and_restores_the_count():
    before = thread_count()
    with serial_if_small(SERIAL_MAX_PIXELS):
        assert thread_count() == 1
        with serial_if_small(SERIAL_MAX_PIXELS + 1):  # nested: still one thread inside
            assert thread_count() == 1
        assert thread_count() == 1
    assert thread_count() == before
    with serial_if_small(SERIAL_MAX_PIXELS + 1):
        assert thread_count() == before
    try:
        with serial_if_small(10):
            raise ValueError("inside")
    except ValueError:
        pass
    assert thread_count() == before


def test_one_thread_only_when_asked():
    before = thread_count()
    with one_thread(False):
        assert thread_count() == before
    with one_thread():
        assert thread_count() == 1
    assert thread_count() == before


def test_the_thread_count_is_numbas_without_starting_its_threading_layer():
    """NUMBA_NUM_THREADS while nothing asked Numba (its threading layer stays unloaded), then
    what numba.set_num_threads sets for the calling thread."""
    code = ("import numba\nfrom numba.np.ufunc import parallel\nfrom refsoft._parallel import thread_count\n"
            "a = thread_count()\nloaded = parallel._is_initialized\nnumba.set_num_threads(1)\n"
            "print(a, loaded, thread_count())")
    env = {**os.environ, "NUMBA_NUM_THREADS": "2"}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["2", "False", "1"]


def test_no_kernel_has_a_parallel_loop():
    """Every kernel is compiled without Numba's parallel lowering: loops run on several threads
    are kernels over a range, called by refsoft._parallel.parallel_range."""
    import importlib

    from refsoft import _numba

    for name in ("raster", "raster.layers", "search", "search._hierarchy", "search._virtual", "search.skips",
                 "search.refine", "search.tessellate", "truth.analytic", "raster._rays", "ldt._search"):
        importlib.import_module(f"refsoft.{name}")  # every module that defines kernels
    assert len(_numba.KERNELS) > 50
    parallel = [d.py_func.__qualname__ for d in _numba.KERNELS
                if d.targetoptions.get("parallel") or "prange" in d.py_func.__code__.co_names]
    assert parallel == []


def test_binning_on_one_thread_and_split_among_threads_lists_each_tile_in_index_order():
    """bin_triangles against a plain loop over tiles and triangles, on the calling thread alone
    and split among threads: the same lists, each in triangle order."""
    import numpy as np

    from refsoft.raster._kernels import BIN_CHUNKS, bin_triangles

    rng = np.random.default_rng(7)
    tile, tiles_x, tiles_y, r0, c0 = 16, 5, 4, 3, 10
    n = 40 * BIN_CHUNKS + 3  # chunks of unequal sizes
    lo_c = rng.integers(c0, c0 + tiles_x * tile, n)
    lo_r = rng.integers(r0, r0 + tiles_y * tile, n)
    bbox = np.stack([lo_c, np.minimum(lo_c + rng.integers(0, 40, n), c0 + tiles_x * tile - 1),
                     lo_r, np.minimum(lo_r + rng.integers(0, 40, n), r0 + tiles_y * tile - 1)], axis=1).astype(np.int32)
    valid = rng.random(n) < 0.8
    want = [[t for t in range(n) if valid[t]
             and (bbox[t, 0] - c0) // tile <= k % tiles_x <= (bbox[t, 1] - c0) // tile
             and (bbox[t, 2] - r0) // tile <= k // tiles_x <= (bbox[t, 3] - r0) // tile]
            for k in range(tiles_x * tiles_y)]
    for serial in (True, False):
        starts, items = bin_triangles(valid, bbox, tile, tiles_x, tiles_y, r0, c0, serial=serial)
        assert starts.dtype == np.int64 and items.dtype == np.int32
        assert [items[starts[k]:starts[k + 1]].tolist() for k in range(tiles_x * tiles_y)] == want
        assert starts[-1] == len(items) == sum(map(len, want))


def test_small_passes_equal_the_parallel_kernels(monkeypatch):
    """The raster front end and the point transform on the calling thread alone (small inputs)
    and split among threads (thresholds set to 0): the same arrays, bit for bit."""
    import numpy as np

    import refsoft
    from refsoft import raster
    from refsoft.raster import _setup

    scene = refsoft.load_scene("kitchen", width=160, height=120)
    cam = scene.camera
    mesh = refsoft.scene.mesh.concatenate([scene.world_mesh(k) for k in range(1, len(scene.objects) + 1)])
    runs = []
    for small in (True, False):
        if not small:
            monkeypatch.setattr(raster, "SERIAL_MAX_TRIANGLES", 0)
            monkeypatch.setattr(_setup, "SERIAL_MAX_VERTICES", 0)
        clip = _setup.transform_points(mesh.vertices, cam.view_proj())
        frags = raster.rasterize(clip, mesh.faces, cam.width, cam.height)
        runs.append([clip, frags.depth, frags.triangle, frags.index, *frags.setup.values()])
    assert len(runs[0][-1])  # the clip-triangle table B: some triangles were clipped
    for a, b in zip(*runs):
        assert a.dtype == b.dtype
        np.testing.assert_array_equal(a, b)
