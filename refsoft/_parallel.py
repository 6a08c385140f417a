"""Parallel loops run by a pool of Python threads over kernels compiled without parallel loops.

A kernel written as ``fn(lo, hi, *args)``, a plain loop over the iterations ``lo .. hi - 1`` that
writes disjoint outputs, is run by :func:`parallel_range` over ``0 .. n - 1`` split into one
contiguous part per thread (the first on the calling thread), as Numba splits a ``prange`` loop.
Kernels release the GIL (``nogil``), so the parts run at once. The results are those of one
thread, bit for bit.

Why not ``prange``: Numba compiles a parallel loop's body a second time, as a function of its own
with a wrapper for each array it reads, which costs 0.5-5 s of CPU per kernel on a first run
(0.05 s for each array the loop uses, more for a large body); the same kernel without the parallel
loop compiles in a fraction of that. The thread count is Numba's (``numba.get_num_threads()``:
``NUMBA_NUM_THREADS``, ``numba.set_num_threads`` and :func:`refsoft.raster._threads.one_thread`
apply); the threads wait for work without spinning.
"""

import threading
from concurrent.futures import ThreadPoolExecutor

import numba

_pool = None
_pool_lock = threading.Lock()


def _executor() -> ThreadPoolExecutor:
    global _pool
    with _pool_lock:
        if _pool is None:
            _pool = ThreadPoolExecutor(max(1, numba.config.NUMBA_NUM_THREADS - 1),
                                       thread_name_prefix="refsoft-parallel")
        return _pool


def parts(n: int, threads: int) -> list:
    """Bounds of ``threads`` contiguous parts of ``range(n)`` (equal sizes within one)."""
    return [n * i // threads for i in range(threads + 1)]


def parallel_range(fn, n: int, *args, serial: bool = False) -> None:
    """``fn(lo, hi, *args)`` over ``range(n)``, split into one part per thread (Numba's thread
    count), the first part on the calling thread. Waits for every part; raises the first part's
    error, if any, once all have ended. ``serial=True`` runs ``fn(0, n, *args)`` on the calling
    thread alone (a pass too small to gain from other threads: the same results)."""
    n = int(n)
    threads = 1 if serial else min(numba.get_num_threads(), n)
    if threads <= 1:
        fn(0, n, *args)
        return
    b = parts(n, threads)
    futures = [_executor().submit(fn, b[i], b[i + 1], *args) for i in range(1, threads)]
    error = None
    try:
        fn(b[0], b[1], *args)
    except BaseException as exc:  # the other parts still write into the caller's arrays: wait for them
        error = exc
    for f in futures:
        exc = f.exception()
        if error is None and exc is not None:
            error = exc
    if error is not None:
        raise error
