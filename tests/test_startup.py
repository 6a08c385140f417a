"""Start-up (docs/benchmarks.md, "Start-up and first run"): the command line's help and scene list
load neither Numba nor trimesh; a float32 one-frame render, its kernels cached, loads each kernel
it runs once, in float32, and compiles nothing; the command's render loads neither SciPy (refused
to Numba's probes of it alone) nor imageio. Each case runs in a child process, which
starts with nothing loaded."""

import json
import os
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
#: Packages a command that renders nothing must not import.
HEAVY = {"numba", "llvmlite", "trimesh", "scipy", "embreex", "imageio", "PIL", "tqdm", "matplotlib"}
#: Kernels a one-frame render of the sphere loads from the cache (the accurate preset: the
#: G-buffer, the search, its refinement (the reflection pixels' check, one pass where NumPy's
#: took several, and the steps), the tessellation and the cut's passes, the exact drawing:
#: its candidates' screen positions, choice and gather, their second images by the mirror rule
#: (the vertices imaged again, those whose image moved, the faces with such a corner and their
#: copies interleaved: four kernels where NumPy's passes over every vertex and face cost more),
#: rays (each row's eye rays in a loop of their own, which vectorizes), their origins' bounds (what
#: a candidate's triangle can reach no nearer than), the area the candidates' bounds cover (which
#: acceptance pays), acceptance and shading, the main view, and the G-buffer's world positions for
#: the outputs).
LOADED_KERNELS = 41

MODULES = """
import json, sys
from refsoft._start import main
try:
    code = main(sys.argv[1:])
except SystemExit as exc:
    code = exc.code
print(json.dumps([code, sorted({m.split(".")[0] for m in sys.modules})]))
"""

RENDER = """
import inspect, json
import refsoft
from refsoft import _numba
refsoft.render("sphere", frames=1, width=160, height=120)
rows = []
for d in _numba.KERNELS:
    params = list(inspect.signature(d.py_func).parameters)
    for sig in d.signatures:
        fp = str(sig[params.index("fp")]) if "fp" in params else None
        rows.append([f"{d.py_func.__module__}.{d.py_func.__name__}", fp, bool(d.stats.cache_hits.get(sig))])
from numba.np import arraymath
print(json.dumps(rows + [arraymath._HAVE_BLAS]))
"""

#: The command's one-frame render, then what it loaded; then Numba asked for a BLAS as compiling
#: ``np.dot`` would ask (the refusal was the probes' alone).
COMMAND_RENDER = """
import json, sys
from refsoft._start import SkipScipyProbes, main
code = main(sys.argv[1:])
registries = "numba.np.arraymath" in sys.modules
loaded = sorted(m for m in sys.modules if m.split(".")[0] in ("scipy", "imageio", "PIL")
                or m in ("numba.np.arrayobj", "numba.np.ufunc.omppool", "numba.np.ufunc.workqueue",
                         "numba.np.ufunc.tbbpool"))
from numba.np import arraymath, linalg
linalg.ensure_blas()
print(json.dumps([code, loaded, arraymath._HAVE_BLAS, "scipy.linalg" in sys.modules, SkipScipyProbes in sys.meta_path,
                  registries]))
"""


def _run(code, *args):
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    r = subprocess.run([sys.executable, "-c", code, *args], cwd=ROOT, env=env, capture_output=True, text=True,
                       timeout=900)
    assert r.returncode == 0, r.stderr[-3000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("args", [["--help"], ["scenes"], ["render", "--help"]])
def test_help_and_the_scene_list_load_no_kernels(args):
    code, modules = _run(MODULES, *args)
    assert code == 0
    assert not HEAVY & set(modules), sorted(HEAVY & set(modules))


def test_a_float32_frame_loads_each_of_its_kernels_once_in_float32():
    *first, _ = _run(RENDER)  # compiles whatever is not cached yet
    *rows, have_blas = _run(RENDER)  # a start-up with the kernels cached
    assert have_blas is True  # the library leaves Numba's probes alone (SciPy is a test dependency)
    # no float64 variant anywhere, not even among the helpers a first run compiles
    assert [r for r in first + rows if r[1] not in (None, "float32")] == []
    names = [r[0] for r in rows]
    assert sorted({n for n in names if names.count(n) > 1}) == []  # one specialisation per kernel
    assert [r[0] for r in rows if not r[2]] == []  # every one loaded from the cache, none compiled
    assert len(rows) <= LOADED_KERNELS, names


def test_the_commands_render_loads_neither_scipy_nor_imageio_nor_numbas_array_module(tmp_path):
    args = ["render", "sphere", "--frames", "1", "--width", "160", "--height", "120", "--out"]
    _run(COMMAND_RENDER, *args, str(tmp_path / "first"))  # compiles whatever is not cached yet
    code, loaded, have_blas, linalg_after, finder, registries = _run(COMMAND_RENDER, *args, str(tmp_path / "s"))
    # its kernels cached, the command loaded them without Numba's registries, to the same outputs
    assert registries is False
    for name in ("frame_0000.png", "frame_0000.npz"):
        assert (tmp_path / "s" / name).read_bytes() == (tmp_path / "first" / name).read_bytes(), name
    assert code == 0 and (tmp_path / "s" / "frame_0000.png").is_file()
    assert [m for m in loaded if m.startswith(("scipy", "imageio"))] == []
    # no kernel it loaded allocates (Numba's array module stays unloaded), and Numba's threading
    # layer was never started (refsoft's pool runs the parallel loops)
    assert [m for m in loaded if m.startswith("numba")] == []
    assert [m for m in loaded if m.startswith("PIL")] == []  # the frame's PNG: zlib's, Pillow not loaded
    assert have_blas is False  # Numba's probes were refused ...
    assert linalg_after is True and finder is False  # ... and only they: the finder is gone, SciPy imports again


def test_pngs_written_through_pillow_decode_to_the_image_as_imageio_reads_it(tmp_path):
    import imageio.v3 as iio
    import numpy as np

    from refsoft.io import write_png

    rng = np.random.default_rng(5)
    images = {"rgb": rng.integers(0, 256, (37, 53, 3), dtype=np.uint8),
              "gray": rng.integers(0, 256, (20, 31), dtype=np.uint8),
              "view": rng.integers(0, 256, (40, 60, 3), dtype=np.uint8)[::2, ::3]}  # not contiguous
    for name, image in images.items():
        write_png(tmp_path / f"{name}.png", image)
        # the pixels, not the bytes: Pillow's and imageio's encoders may choose other compressions
        assert np.array_equal(iio.imread(tmp_path / f"{name}.png"), image), name


def test_the_garbage_collector_pause_ends_by_itself():
    """The command's start-up runs without cyclic collections, for a bounded time only."""
    import gc
    import time

    from refsoft._start import pause_gc

    assert gc.isenabled()
    try:
        pause_gc(0.05)
        assert not gc.isenabled()
        pause_gc(10.0)  # already paused: no second timer, the first still ends the pause
        deadline = time.monotonic() + 5.0
        while not gc.isenabled() and time.monotonic() < deadline:
            time.sleep(0.01)
        assert gc.isenabled()
    finally:
        gc.enable()


def test_the_command_starts_with_the_collector_paused():
    code = ("import contextlib, gc, io\nfrom refsoft import _start\n_start.GC_PAUSE_SECONDS = 60.0\n"
            "with contextlib.redirect_stdout(io.StringIO()):\n    _start.main(['scenes'])\nprint(gc.isenabled())")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
