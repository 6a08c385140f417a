"""Parallel loops on refsoft's thread pool (refsoft._parallel): the parts, the thread count,
errors, and the same bytes on one thread and on several."""

import threading

import numba
import numpy as np
import pytest

from refsoft._numba import kernel
from refsoft._parallel import parallel_range, parts
from refsoft.raster._threads import one_thread


@kernel
def _square_root_sum(lo, hi, x, out):
    for i in range(lo, hi):
        out[i] = np.sqrt(x[i]) + x[i] * np.float32(0.5)


@pytest.mark.parametrize("n, threads", [(0, 2), (1, 2), (7, 2), (8, 3), (1000, 4), (5, 8)])
def test_parts_cover_the_range_once_in_order(n, threads):
    b = parts(n, threads)
    assert b[0] == 0 and b[-1] == n and len(b) == threads + 1
    assert all(lo <= hi for lo, hi in zip(b, b[1:]))
    assert max(hi - lo for lo, hi in zip(b, b[1:])) - min(hi - lo for lo, hi in zip(b, b[1:])) <= 1


def test_the_same_bytes_on_one_thread_and_on_several():
    x = np.random.default_rng(3).random(100_003, dtype=np.float32)
    got = []
    for threads in (1, numba.config.NUMBA_NUM_THREADS):
        out = np.full_like(x, np.nan)
        numba.set_num_threads(threads)
        try:
            parallel_range(_square_root_sum, len(x), x, out)
        finally:
            numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
        got.append(out)
    want = np.sqrt(x) + x * np.float32(0.5)
    for out in got:
        assert out.tobytes() == want.tobytes()


def test_parts_run_on_as_many_threads_as_numba_counts():
    seen = []
    lock = threading.Lock()

    def record(lo, hi):
        with lock:
            seen.append((lo, hi, threading.get_ident()))

    parallel_range(record, 10)
    threads = min(numba.get_num_threads(), 10)
    assert sorted((lo, hi) for lo, hi, _ in seen) == list(zip(parts(10, threads), parts(10, threads)[1:]))
    assert any(t == threading.get_ident() for lo, _, t in seen if lo == 0)  # the first part: this thread
    seen.clear()
    with one_thread():
        parallel_range(record, 10)
    assert [(lo, hi) for lo, hi, _ in seen] == [(0, 10)] and seen[0][2] == threading.get_ident()


def test_serial_runs_the_whole_range_on_the_calling_thread():
    seen = []
    parallel_range(lambda lo, hi, tag: seen.append((lo, hi, tag, threading.get_ident())), 10, "x", serial=True)
    assert seen == [(0, 10, "x", threading.get_ident())]
    x = np.random.default_rng(4).random(1001, dtype=np.float32)
    out = np.full_like(x, np.nan)
    parallel_range(_square_root_sum, len(x), x, out, serial=True)
    assert out.tobytes() == (np.sqrt(x) + x * np.float32(0.5)).tobytes()


def test_an_error_in_a_part_is_raised_after_every_part_has_ended():
    ended = []

    def part(lo, hi):
        if hi == 4:  # the last part (the only one on one thread)
            raise ValueError(f"part {lo}")
        threading.Event().wait(0.05)
        ended.append(lo)

    with pytest.raises(ValueError, match="part"):
        parallel_range(part, 4)
    # on several threads the calling thread's part finished before the error was raised
    assert ended == ([0] if numba.get_num_threads() > 1 else [])


def test_parts_the_pool_has_not_started_run_on_the_calling_thread():
    """With the pool's threads all busy, the calling thread runs every part itself, at once."""
    from refsoft import _parallel

    release = threading.Event()
    pool = _parallel._executor()
    blockers = [pool.submit(release.wait, 10) for _ in range(pool._max_workers)]
    seen = []
    try:
        parallel_range(lambda lo, hi: seen.append((lo, hi, threading.get_ident())), 10)
    finally:
        release.set()
        for f in blockers:
            f.result()
    threads = min(numba.get_num_threads(), 10)
    assert [(lo, hi) for lo, hi, _ in seen] == list(zip(parts(10, threads), parts(10, threads)[1:]))
    assert {t for _, _, t in seen} == {threading.get_ident()}
