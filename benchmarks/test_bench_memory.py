"""Peak resident memory of a two-frame ``refsoft render`` process at 1024x768 (the accurate
preset; the layered depth textures and the environment map on the kitchen; see ``CASES``), beside the resident
set of a process that has loaded the same kernels and scene (the baseline the memory guard does
not count) and the guard's estimate for that run (``benchmarks/peak_rss.py`` says how each is
taken).

The time each round takes (two processes) is recorded but is not the point: ``extra_info`` holds,
in MiB, the render's peak (``peak_rss_mib``: min, median and max over the rounds), the baseline's
resident set, the peak above it and the estimate, and their ratio.

Run: ``pytest benchmarks/test_bench_memory.py --benchmark-columns=rounds,median``.
"""

import statistics

import pytest

from peak_rss import measure

#: The paper scenes, two cheap built-in ones, the methods with their own estimates on the kitchen,
#: the closest to their estimates found (a bowl filling much of the view, the hierarchy search's
#: pyramid) and full tessellation.
CASES = [("kitchen", ()), ("ufo", ()), ("ants", ()), ("sphere", ()), ("planar", ()),
         ("kitchen", ("--method", "ldt")), ("kitchen", ("--method", "envmap")),
         ("concave", ()), ("planar", ("--method", "hierarchy")),
         ("kitchen", ("--tessellate", "0")), ("planar", ("--tessellate", "0")), ("sphere", ("--tessellate", "0"))]
ROUNDS = 3
MIB = 1 << 20


@pytest.mark.parametrize("name, options", CASES, ids=[" ".join((n,) + o) for n, o in CASES])
def test_peak_memory(benchmark, name, options):
    measure(name, options)  # Numba's cache filled outside the rounds (a compile's own memory is not the run's)
    benchmark.group = "peak memory 1024x768, 2 frames"
    runs = []
    benchmark.pedantic(lambda: runs.append(measure(name, options)), rounds=ROUNDS, iterations=1)

    def mib(key):
        return [round(r[key] / MIB, 1) for r in runs]

    over = statistics.median(r["over_baseline"] for r in runs)
    est = runs[0]["estimate"]
    benchmark.extra_info.update({
        "command": f"python -m refsoft render {name} --width 1024 --height 768 --frames 2 --out DIR --overwrite"
                   + "".join(f" {o}" for o in options),
        "peak_rss_mib": [min(mib("peak_rss")), statistics.median(mib("peak_rss")), max(mib("peak_rss"))],
        "baseline_rss_mib": statistics.median(mib("baseline_rss")),
        "baseline_peak_rss_mib": statistics.median(mib("baseline_peak_rss")),
        "over_baseline_mib": [min(mib("over_baseline")), round(over / MIB, 1), max(mib("over_baseline"))],
        "estimate_mib": round(est / MIB, 1),
        "estimate_parts_mib": {k: round(v / MIB, 1) for k, v in runs[0]["estimate_parts"].items()},
        "estimate_over_peak": round(est / max(max(r["over_baseline"] for r in runs), 1), 2),
        "kernels_compiled": [r["kernels_compiled"] for r in runs],
        "kernels_loaded": runs[0]["kernels_loaded"], "baseline_kernels_loaded": runs[0]["baseline_kernels_loaded"],
    })
