"""A slow, plainly correct reference of :func:`refsoft.io.runs.repeating_runs`: unit by unit,
byte by byte."""

from __future__ import annotations

import numpy as np


def _repeats(b, period):
    """Whether bytes ``b`` repeat their first ``period`` bytes."""
    return all(b[i] == b[i % period] for i in range(len(b)))


def naive_repeating_runs(data, unit, period, shortest=1):
    data = bytes(np.asarray(data, np.uint8))
    n = len(data) // unit
    runs = []  # [lo, hi, repeating]
    for u in range(n):
        lo, hi = u * unit, (u + 1) * unit
        rep = _repeats(data[lo:hi], period)
        if runs and rep and runs[-1][2] and _repeats(data[runs[-1][0]:hi], period):
            runs[-1][1] = hi
        elif runs and not rep and not runs[-1][2]:
            runs[-1][1] = hi
        else:
            runs.append([lo, hi, rep])
    out = []
    for lo, hi, rep in runs:
        pattern = data[lo:lo + period] if rep and (hi - lo) // unit >= shortest else None
        if pattern is None and out and out[-1][2] is None:
            out[-1] = (out[-1][0], hi, None)
        else:
            out.append((lo, hi, pattern))
    if len(data) > n * unit:
        if out and out[-1][2] is None:
            out[-1] = (out[-1][0], len(data), None)
        else:
            out.append((n * unit, len(data), None))
    return out
