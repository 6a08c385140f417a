"""Shared helpers of the benchmark commands: CSV and markdown writers, median timing."""

from __future__ import annotations

import csv
import io
import os
import time

import numpy as np


def write_csv(path, rows, columns):
    from ..io import atomic_path

    with atomic_path(path) as tmp:
        with open(tmp, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=columns, extrasaction="ignore")
            w.writeheader()
            for r in rows:
                w.writerow({k: _fmt(r.get(k)) for k in columns})


def _fmt(v):
    if isinstance(v, float):
        return f"{v:.6g}"
    return v


def _cell(v) -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def markdown_table(rows, columns, headers=None) -> str:
    headers = headers or columns
    out = io.StringIO()
    out.write("| " + " | ".join(headers) + " |\n")
    out.write("|" + "|".join("---" if i == 0 else "---:" for i in range(len(columns))) + "|\n")
    for r in rows:
        out.write("| " + " | ".join(_cell(r.get(c, "")) for c in columns) + " |\n")
    return out.getvalue()


def write_text(path, text):
    from ..io import atomic_path

    with atomic_path(path) as tmp:
        with open(tmp, "w") as fh:
            fh.write(text)


def median_time(fn, repeats: int) -> tuple[float, object]:
    """Median wall time (ms) of ``repeats`` calls of ``fn()`` and the last result."""
    times, result = [], None
    for _ in range(max(int(repeats), 1)):
        t = time.perf_counter()
        result = fn()
        times.append(1000 * (time.perf_counter() - t))
    return float(np.median(times)), result


def machine() -> dict:
    import platform

    import numba

    return {"cpu": platform.processor() or platform.machine(), "cores": os.cpu_count(),
            "python": platform.python_version(), "numpy": np.__version__, "numba": numba.__version__,
            "threads": numba.get_num_threads()}


def progress(items, desc, enabled):
    if not enabled or len(items) < 2:
        return items
    from tqdm import tqdm

    return tqdm(items, desc=desc, unit="run", disable=None)


def plt_or_none():
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return None
    return plt
