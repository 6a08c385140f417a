"""Coherent frames on a shared machine: refsoft's thread pool against one thread.

Each case renders the kitchen at 1024x768 (accurate preset) in a process of its own: frames 0
and 1 untimed (kernels loaded), then three times a fresh frame 0 and the coherent frames 1-3, and
reports the median and the minimum of those nine coherent frames' ``time_ms["total"]``. The
cases: refsoft's parallel loops on Numba's thread count (``refsoft._parallel``: a pool of
threads, the calling thread taking back the parts the pool has not started) and one thread
(``NUMBA_NUM_THREADS=1``). With ``competitor=1`` a busy process runs beside the render for its
whole run, as another job on a shared 2-core machine does. The benchmark's own time is the whole
process; ``extra_info`` holds the frame times that matter, the thread count and the load average.

Run: ``pytest benchmarks/test_bench_threads.py --benchmark-columns=rounds,median``.
"""

import json
import os
import subprocess
import sys

import pytest

SCENE = "kitchen"
CASES = ["pool", "one thread"]

CHILD = r"""
import json, os, statistics, sys
import numba, refsoft
refsoft.render(sys.argv[2], frames=2, width=1024, height=768)
times = []
for _ in range(3):
    frames, stats = refsoft.render(sys.argv[2], frames=4, width=1024, height=768)
    times += [f["time_ms"]["total"] for f in stats["frames"][1:]]
print(json.dumps({"median_ms": statistics.median(times), "min_ms": min(times), "threads": numba.get_num_threads(),
                  "load": os.getloadavg()[0]}))
"""


def _child(case):
    env = dict(os.environ)
    if case == "one thread":
        env["NUMBA_NUM_THREADS"] = "1"
    out = subprocess.run([sys.executable, "-c", CHILD, case, SCENE], env=env, capture_output=True, text=True,
                         check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("competitor", [0, 1])
@pytest.mark.parametrize("case", CASES)
def test_coherent_frame_by_threads(benchmark, case, competitor):
    _child(case)  # Numba's cache filled outside the round
    benchmark.group = f"{SCENE} 1024x768 coherent frame, {competitor} busy process(es) beside it"
    busy = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(competitor)]
    try:
        got = {}
        benchmark.pedantic(lambda: got.update(_child(case)), rounds=1, iterations=1)
    finally:
        for p in busy:
            p.kill()
            p.wait()
    benchmark.extra_info.update({k: round(v, 1) if isinstance(v, float) else v for k, v in got.items()})
    assert got["median_ms"] > 0 and (got["threads"] == 1) == (case == "one thread" or numba_threads() == 1)


def numba_threads():
    import numba

    return numba.config.NUMBA_NUM_THREADS
