"""Coherent frames on a shared machine: how OpenMP's waiting threads change a frame's time.

Each case renders the kitchen at 1024x768 (accurate preset) in a process of its own, since
OpenMP reads its wait policy once per process: frames 0 and 1 untimed (kernels loaded), then
three times a fresh frame 0 and the coherent frames 1-3, and reports the median and the minimum
of those nine coherent frames' ``time_ms["total"]``. The policies: ``PASSIVE``, what refsoft
sets (a thread with no work sleeps at once); ``default``, OpenMP's own (a waiting thread spins a
while before it sleeps; what Numba does unless told); and one thread (``NUMBA_NUM_THREADS=1``).
With ``competitor=1`` a busy process runs beside the render for its whole run, as another job on
a shared 2-core machine does. The benchmark's own time is the whole process; ``extra_info`` holds
the frame times that matter, the threading layer and the load average.

Run: ``pytest benchmarks/test_bench_threads.py --benchmark-columns=rounds,median``.
"""

import json
import os
import subprocess
import sys

import pytest

SCENE = "kitchen"
POLICIES = ["PASSIVE", "default", "one thread"]

CHILD = r"""
import json, os, statistics, sys, time
policy = sys.argv[1]
import refsoft._numba  # sets OMP_WAIT_POLICY=PASSIVE unless set
if policy == "default":
    del os.environ["OMP_WAIT_POLICY"]  # OpenMP's pool is not loaded yet: it starts with its own default
import numba, refsoft
refsoft.render(sys.argv[2], frames=2, width=1024, height=768)
times = []
for _ in range(3):
    frames, stats = refsoft.render(sys.argv[2], frames=4, width=1024, height=768)
    times += [f["time_ms"]["total"] for f in stats["frames"][1:]]
print(json.dumps({"median_ms": statistics.median(times), "min_ms": min(times),
                  "layer": numba.threading_layer(), "threads": numba.get_num_threads(),
                  "load": os.getloadavg()[0]}))
"""


def _child(policy):
    env = dict(os.environ)
    env.pop("OMP_WAIT_POLICY", None)
    if policy == "one thread":
        env["NUMBA_NUM_THREADS"] = "1"
    out = subprocess.run([sys.executable, "-c", CHILD, policy, SCENE], env=env, capture_output=True, text=True,
                         check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("competitor", [0, 1])
@pytest.mark.parametrize("policy", POLICIES)
def test_coherent_frame_by_wait_policy(benchmark, policy, competitor):
    _child(policy)  # Numba's cache filled outside the round
    benchmark.group = f"{SCENE} 1024x768 coherent frame, {competitor} busy process(es) beside it"
    busy = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(competitor)]
    try:
        got = {}
        benchmark.pedantic(lambda: got.update(_child(policy)), rounds=1, iterations=1)
    finally:
        for p in busy:
            p.kill()
            p.wait()
    benchmark.extra_info.update({k: round(v, 1) if isinstance(v, float) else v for k, v in got.items()})
    assert got["median_ms"] > 0 and (got["threads"] == 1) == (policy == "one thread" or numba_threads() == 1)


def numba_threads():
    import numba

    return numba.config.NUMBA_NUM_THREADS
