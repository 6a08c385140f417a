"""Small passes run on the calling thread only.

A parallel kernel hands part of its loop to the other threads and waits for them; on a busy
machine a worker may not run for several milliseconds, longer than a small pass takes on one
thread. So, like llvmpipe, whose vertex processing, triangle setup and binning run on the
calling thread, refsoft runs a pass's per-triangle front end on one thread up to
``SERIAL_MAX_TRIANGLES`` triangles, a whole pass over a small box (a reflector's virtual
pass) on one thread, and per-vertex passes of microseconds (transforming points, a search's
bookkeeping around its walks, virtual vertices) on one thread up to ``SERIAL_MAX_VERTICES``
vertices. Outputs do not depend on the thread count (each parallel loop writes
disjoint outputs), so the choice changes only the time.

The per-triangle front end and the per-vertex passes call their kernels' serial variants
(:func:`variant`: the same functions compiled without parallel loops), which compile faster;
a run whose inputs stay under these thresholds never compiles their parallel variants. The
per-pixel passes over small boxes run their parallel kernels on one thread (:func:`one_thread`),
since the main view needs those kernels parallel anyway.
"""

from contextlib import contextmanager

import numba

#: Passes over at most this many pixels run on one thread (a 256 x 256 box).
SERIAL_MAX_PIXELS = 1 << 16
#: Triangle setup and binning of at most this many triangles run on one thread (about 10 ms).
SERIAL_MAX_TRIANGLES = 1 << 18
#: Per-vertex passes (transforms, a search's bookkeeping, virtual vertices) run on one thread up
#: to this many vertices (under a millisecond; the walks themselves stay parallel).
SERIAL_MAX_VERTICES = 1 << 16


@contextmanager
def one_thread(when: bool = True):
    """Run the Numba kernels called inside on one thread when ``when`` is true (Numba's thread
    count is per calling thread: other threads are not affected)."""
    if not when:
        yield
        return
    n = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        yield
    finally:
        numba.set_num_threads(n)


def variant(kernel, small: bool):
    """``kernel.serial`` (the kernel compiled without parallel loops, :func:`refsoft._numba.kernel`)
    when ``small``, else the parallel kernel: the same results either way."""
    return kernel.serial if small else kernel


def serial_if_small(pixels: int):
    """:func:`one_thread` when ``pixels`` <= SERIAL_MAX_PIXELS."""
    return one_thread(pixels <= SERIAL_MAX_PIXELS)
