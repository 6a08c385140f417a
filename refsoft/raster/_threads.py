"""Small passes run on the calling thread only.

A parallel kernel hands half its loop to the other threads and waits for them; on a busy
machine a worker may not run for tens of milliseconds, far longer than a small pass takes on
one thread. Outputs do not depend on the thread count (each parallel loop writes disjoint
outputs), so the choice changes only the time.
"""

from contextlib import contextmanager

import numba

#: Passes over at most this many pixels run on one thread (a 256 x 256 box).
SERIAL_MAX_PIXELS = 1 << 16


@contextmanager
def serial_if_small(pixels: int):
    """Run the Numba kernels called inside on one thread when ``pixels`` <= SERIAL_MAX_PIXELS
    (Numba's thread count is per calling thread: other threads are not affected)."""
    if pixels > SERIAL_MAX_PIXELS:
        yield
        return
    n = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        yield
    finally:
        numba.set_num_threads(n)
