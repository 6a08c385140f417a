"""Small passes run on the calling thread only.

A parallel loop (:func:`refsoft._parallel.parallel_range`) hands part of its range to a pool
thread: submitting the part, waking the thread and taking the part back when the thread has not
started it cost tens of microseconds, more than a small pass takes on one thread. So refsoft runs
a pass's per-triangle front end on one thread up to ``SERIAL_MAX_TRIANGLES`` triangles, a whole
pass over a small box (a reflector's virtual pass) on one thread, and per-vertex passes of
microseconds (transforming points, a search's bookkeeping around its walks, virtual vertices) on
one thread up to ``SERIAL_MAX_VERTICES`` vertices. Outputs do not depend on the thread count (each parallel loop
writes disjoint outputs), so the choice changes only the time.

Under these thresholds the per-triangle front end and the per-vertex passes call
:func:`refsoft._parallel.parallel_range` with ``serial=True``; a whole pass over a small box runs
inside :func:`one_thread` (:func:`serial_if_small`), which sets the thread count that
``parallel_range`` reads (:func:`refsoft._parallel.thread_count`). Either way the same kernel
runs, compiled once for both.
"""

from .._parallel import one_thread  # noqa: F401  (the passes' import of it)

#: Passes over at most this many pixels run on one thread (a 128 x 128 box).
SERIAL_MAX_PIXELS = 1 << 14
#: Triangle setup, binning and the virtual pass's triangle test of at most this many triangles run on
#: one thread (under a millisecond; a pass of more is split, which is faster from here on).
SERIAL_MAX_TRIANGLES = 1 << 14
#: Per-vertex passes (transforms, a search's bookkeeping, virtual vertices) run on one thread up
#: to this many vertices (under a millisecond; the walks themselves stay parallel).
SERIAL_MAX_VERTICES = 1 << 16


def serial_if_small(pixels: int):
    """:func:`one_thread` when ``pixels`` <= SERIAL_MAX_PIXELS."""
    return one_thread(pixels <= SERIAL_MAX_PIXELS)
