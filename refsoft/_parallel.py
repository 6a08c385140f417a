"""Parallel loops run by a pool of Python threads over kernels compiled without parallel loops.

A kernel written as ``fn(lo, hi, *args)``, a plain loop over the iterations ``lo .. hi - 1`` that
writes disjoint outputs, is run by :func:`parallel_range` over ``0 .. n - 1`` split into one
contiguous part per thread (the first on the calling thread), as Numba splits a ``prange`` loop;
a part the pool's threads have not started when the calling thread is done is run by the calling
thread.
Kernels release the GIL (``nogil``), so the parts run at once. The results are those of one
thread, bit for bit.

Why not ``prange``: Numba compiles a parallel loop's body a second time, as a function of its own
with a wrapper for each array it reads, which costs 0.5-5 s of CPU per kernel on a first run
(0.05 s for each array the loop uses, more for a large body); the same kernel without the parallel
loop compiles in a fraction of that. The thread count is Numba's (:func:`thread_count`:
``NUMBA_NUM_THREADS`` and ``numba.set_num_threads`` apply), or 1 inside :func:`one_thread`; the
pool's threads wait for work without spinning, and on a busy machine, where the pool's thread may
not run for milliseconds, the calling thread does not wait for it to start.
"""

import threading
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager

import numba

_pool = None
_pool_lock = threading.Lock()
#: Per calling thread: ``single`` is True inside :func:`one_thread`.
_local = threading.local()


def _executor() -> ThreadPoolExecutor:
    global _pool
    with _pool_lock:
        if _pool is None:
            _pool = ThreadPoolExecutor(max(1, numba.config.NUMBA_NUM_THREADS - 1),
                                       thread_name_prefix="refsoft-parallel")
        return _pool


def thread_count() -> int:
    """The parts a parallel loop of the calling thread splits into: 1 inside :func:`one_thread`,
    else Numba's thread count (``NUMBA_NUM_THREADS``, or what ``numba.set_num_threads`` set for
    this thread). While nothing in the process has asked Numba for it, that is
    ``NUMBA_NUM_THREADS``, read without ``numba.get_num_threads()``, which loads Numba's
    threading layer (its OpenMP or workqueue library, about 8 ms of a command's start) for
    parallel regions refsoft never runs."""
    if getattr(_local, "single", False):
        return 1
    from numba.np.ufunc import parallel

    if not getattr(parallel, "_is_initialized", True):  # no set_num_threads in this process yet
        return numba.config.NUMBA_NUM_THREADS
    return numba.get_num_threads()


@contextmanager
def one_thread(when: bool = True):
    """Run the parallel loops called inside on the calling thread alone when ``when`` is true
    (:func:`thread_count` is 1 there; other threads are not affected)."""
    if not when:
        yield
        return
    before = getattr(_local, "single", False)
    _local.single = True
    try:
        yield
    finally:
        _local.single = before


def parts(n: int, threads: int) -> list:
    """Bounds of ``threads`` contiguous parts of ``range(n)`` (equal sizes within one)."""
    return [n * i // threads for i in range(threads + 1)]


def parallel_range(fn, n: int, *args, serial: bool = False, work=None) -> None:
    """``fn(lo, hi, *args)`` over ``range(n)``, split into one part per thread (Numba's thread
    count), the first part on the calling thread. A part no other thread has started by the time
    the calling thread is done with its own is taken back and run by the calling thread, so a busy
    machine (the pool's thread not yet scheduled) costs no wait. Waits for every part; raises the
    first error, if any, once all have ended. ``serial=True`` runs ``fn(0, n, *args)`` on the
    calling thread alone (a pass too small to gain from other threads: the same results).

    ``work``: a function returning a tuple of new work arrays, called once per part, whose arrays
    follow ``args`` in that part's call (``fn(lo, hi, *args, *work())``): a kernel's scratch
    memory, made here so that no kernel allocates (a kernel that allocates makes every process
    that loads it import Numba's array implementation, 0.05-0.07 s)."""
    n = int(n)
    threads = 1 if serial else min(thread_count(), n)
    extra = work if work is not None else tuple
    if threads <= 1:
        fn(0, n, *args, *extra())
        return
    b = parts(n, threads)
    futures = [_executor().submit(fn, b[i], b[i + 1], *args, *extra()) for i in range(1, threads)]
    error = None
    try:
        fn(b[0], b[1], *args, *extra())
        for i, f in enumerate(futures, start=1):
            if f.cancel():  # not started by the pool: this thread runs it
                fn(b[i], b[i + 1], *args, *extra())
    except BaseException as exc:  # parts already started still write into the caller's arrays: wait for them
        error = exc
        for f in futures:
            f.cancel()
    for f in futures:
        if not f.cancelled():
            exc = f.exception()
            if error is None and exc is not None:
                error = exc
    if error is not None:
        raise error
