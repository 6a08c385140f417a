"""spec section 10: no kernel reads or writes out of bounds for any input that passes
validation. A subset of the suite (the stress suite, the rasterizer against its naive version,
the skips tests on their own scene, the search traces) runs again in a child process
with ``NUMBA_BOUNDSCHECK=1`` and an empty Numba cache, so every kernel is recompiled with
bounds checks (an out-of-bounds access raises IndexError instead of reading memory)."""

import os
import subprocess
import sys

SUBSET = ["tests/test_stress.py", "tests/raster/test_raster_vs_naive.py", "tests/search/test_skips.py",
          "tests/search/test_search.py::test_trace_ends_where_the_kernel_ends_for_every_vertex",
          "tests/search/test_search.py::test_trace_records_every_candidate", "tests/ldt/test_pixel_search.py",
          "tests/envmap/test_envmap.py"]

PROBE = """
import numpy as np
from refsoft.raster import _setup
try:
    _setup._plane_distance(np.zeros(1), 0, 1.0, 1.0)  # reads c[2], c[3] of a 1-element array
except IndexError:
    print("checked")
"""


class Child:
    """The bounds-checked run of :data:`SUBSET`, in a child process with its own empty Numba cache.

    It recompiles every kernel it reaches (minutes of one core) while the rest of the suite runs
    on the other: ``conftest.py`` starts it when this test is collected (:meth:`start`) and the
    test waits for its verdict. Output goes to a file in its own temporary folder, removed with
    it at the session's end (:meth:`close`)."""

    def __init__(self):
        import tempfile

        self.root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
        self.folder = tempfile.mkdtemp(prefix="refsoft-boundscheck-")
        self.env = dict(os.environ, NUMBA_BOUNDSCHECK="1", NUMBA_CACHE_DIR=os.path.join(self.folder, "numba-cache"))
        self.log = os.path.join(self.folder, "pytest.log")
        # the built-in animations of test_skips are left out here (minutes with bounds checks); the
        # stress suite and the skips' own scene reach the same kernels
        with open(self.log, "wb") as out:
            self.process = subprocess.Popen(
                [sys.executable, "-m", "pytest", "-q", "-x", "-p", "no:cacheprovider", "-k", "not builtin", *SUBSET],
                env=self.env, cwd=self.root, stdin=subprocess.DEVNULL, stdout=out, stderr=subprocess.STDOUT)

    def result(self, timeout=3000):
        """(exit status, the run's output)."""
        code = self.process.wait(timeout=timeout)
        with open(self.log, encoding="utf-8", errors="replace") as f:
            return code, f.read()

    def close(self):
        import shutil

        if self.process.poll() is None:
            self.process.kill()
            self.process.wait()
        shutil.rmtree(self.folder, ignore_errors=True)


#: The child started at collection (None until then, or when this test is not collected).
CHILD = None


def start():
    """Start the child (once); ``conftest.py`` calls this when the test is collected."""
    global CHILD
    if CHILD is None:
        CHILD = Child()
    return CHILD


def test_subset_passes_with_numba_boundscheck():
    child = start()  # already running when the session was collected with conftest.py's hook
    probe = subprocess.run([sys.executable, "-c", PROBE], env=child.env, cwd=child.root, capture_output=True,
                           text=True, timeout=600)
    assert probe.stdout.strip() == "checked", probe.stdout + probe.stderr  # the flag reached refsoft's kernels
    code, said = child.result()
    assert code == 0, said[-6000:]
    assert " passed" in said and "skipped" not in said.rstrip().splitlines()[-1]
