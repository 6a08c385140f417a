"""An array's bytes cut into runs for the npz writer: runs of units that repeat one short pattern
(written from a cache, :mod:`refsoft.io.deflate`) and runs of other bytes (deflated by zlib).

A unit is ``unit`` bytes of the array (the last, shorter one is always "other"); a run of
repeating units is one whose bytes, from its first, repeat its first ``period`` bytes. The cut
depends on the bytes only (not on which pages were read to find it), so a rerun writes the same
file.
"""

from __future__ import annotations

import numpy as np

from .pages import PAGE


def untouched_units(unread, n_units: int, unit: int):
    """(U,) bool: whether unit ``u`` (bytes ``u * unit:(u + 1) * unit``) lies in pages never touched;
    ``unread`` is what :meth:`refsoft.io.pages.PageMap.untouched` said of the array (or None:
    every unit is read)."""
    if unread is None or n_units == 0:
        return np.zeros(n_units, bool)
    addr, flags = unread
    first = addr // PAGE
    starts = addr + np.arange(n_units, dtype=np.int64) * unit
    lo = starts // PAGE - first
    hi = (starts + unit - 1) // PAGE - first
    touched = np.concatenate(([0], np.cumsum(~flags)))  # touched pages before each page
    return touched[hi + 1] == touched[lo]


def repeating_runs(data, unit: int, period: int, untouched=None, shortest: int = 1) -> list:
    """The runs of (n,) uint8 ``data``.

    Parameters
    ----------
    data : (n,) uint8 ndarray
    unit : int
        Bytes of a unit, a multiple of ``period`` or of 8.
    period : int
        Bytes of the repeated pattern, a multiple of 8.
    untouched : (n // unit,) bool ndarray, optional
        Units known to be zero bytes without reading them (:func:`untouched_units`).
    shortest : int
        Units of the shortest repeating run: a shorter one counts as other bytes (its own
        deflate block would cost more than zlib takes over it in the stream).

    Returns
    -------
    list of (int, int, bytes or None)
        ``(lo, hi, pattern)`` in order, covering ``data``: ``data[lo:hi]`` repeats ``pattern``
        (``period`` bytes) from ``lo``, or ``pattern`` is None (other bytes).
    """
    n = data.size // unit
    if n < shortest or n == 0:  # no run long enough to repeat
        return [(0, data.size, None)] if data.size else []
    k, wu = period // 8, unit // 8
    read = np.arange(n) if untouched is None else np.flatnonzero(~untouched)  # the units read
    rep = np.ones(n, bool)  # untouched units: zeros
    pat = np.zeros((n, k), np.uint64)
    cross = np.zeros(n, bool)  # unit u's last words continue its pattern into unit u + 1's
    if read.size:
        units = data[:n * unit].reshape(n, unit)
        w = (units if read.size == n else units[read]).view(np.uint64)  # (r, wu)
        flat = w.reshape(-1)
        same = np.ones(flat.size, bool)
        np.equal(flat[k:], flat[:-k], out=same[:-k])  # the word `period` bytes on: the same
        same = same.reshape(read.size, wu)
        rep[read] = same[:, :wu - k].all(axis=1)
        # across a boundary only where the next unit read is the next unit
        cross[read[:-1]] = same[:-1, wu - k:].all(axis=1) & (np.diff(read) == 1)
        pat[read] = w[:, :k]
    zero = ~pat.any(axis=1)
    # adjacent repeating units are one run when the pattern carries over: read across the
    # boundary, or zeros meeting zeros
    join = rep[:-1] & rep[1:] & (cross[:-1] | (zero[:-1] & zero[1:]))
    start = np.ones(n, bool)
    start[1:] = (rep[1:] != rep[:-1]) | (rep[1:] & ~join)
    bounds = np.flatnonzero(start).tolist() + [n]
    runs = []
    for a, b in zip(bounds[:-1], bounds[1:]):
        pattern = pat[a].tobytes() if rep[a] and b - a >= shortest else None
        if pattern is None and runs and runs[-1][2] is None:  # other bytes after other bytes: one run
            runs[-1] = (runs[-1][0], b * unit, None)
        else:
            runs.append((a * unit, b * unit, pattern))
    if data.size > n * unit:  # the last, partial unit
        if runs[-1][2] is None:
            runs[-1] = (runs[-1][0], data.size, None)
        else:
            runs.append((n * unit, data.size, None))
    return runs
