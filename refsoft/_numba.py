"""Shared Numba settings: every kernel is compiled with these flags (DESIGN section 2)."""

import numba

#: fastmath=False: no reassociation, no FMA contraction. error_model="numpy": inf/NaN like a GPU.
KERNEL_OPTIONS = dict(cache=True, fastmath=False, error_model="numpy", nogil=True)


def kernel(fn=None, *, parallel=False):
    """``numba.njit`` with refsoft's fixed options (optionally ``parallel=True``)."""

    def wrap(f):
        return numba.njit(parallel=parallel, **KERNEL_OPTIONS)(f)

    return wrap(fn) if fn is not None else wrap
