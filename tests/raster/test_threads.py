"""Small passes on one thread (refsoft.raster._threads): the thread count inside and after."""

import numba

from refsoft.raster._threads import SERIAL_MAX_PIXELS, one_thread, serial_if_small


def test_serial_if_small_sets_one_thread_inside_and_restores_the_count():
    before = numba.get_num_threads()
    with serial_if_small(SERIAL_MAX_PIXELS):
        assert numba.get_num_threads() == 1
    assert numba.get_num_threads() == before
    with serial_if_small(SERIAL_MAX_PIXELS + 1):
        assert numba.get_num_threads() == before
    try:
        with serial_if_small(10):
            raise ValueError("inside")
    except ValueError:
        pass
    assert numba.get_num_threads() == before


def test_one_thread_only_when_asked():
    before = numba.get_num_threads()
    with one_thread(False):
        assert numba.get_num_threads() == before
    with one_thread():
        assert numba.get_num_threads() == 1
    assert numba.get_num_threads() == before


def test_openmp_threads_wait_passively_unless_the_user_says_otherwise():
    """refsoft sets OMP_WAIT_POLICY=PASSIVE before Numba loads its OpenMP pool (which reads it
    once), and keeps a value the user set."""
    import os
    import subprocess
    import sys

    code = ("import os, sys, refsoft._numba; "
            "print(os.environ['OMP_WAIT_POLICY'], 'numba.np.ufunc.omppool' in sys.modules)")
    env = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["PASSIVE", "False"]
    env["OMP_WAIT_POLICY"] = "ACTIVE"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["ACTIVE", "False"]
