"""Shared Numba settings: every kernel is compiled with these flags (spec section 2)."""

import numba
import numpy as np
from numba import types
from numba.extending import overload

#: fastmath=False: no reassociation, no FMA contraction. error_model="numpy": inf/NaN like a GPU.
KERNEL_OPTIONS = dict(cache=True, fastmath=False, error_model="numpy", nogil=True)


def kernel(fn=None, *, parallel=False, inline=False):
    """``numba.njit`` with refsoft's fixed options (optionally ``parallel=True``; ``inline=True``
    inlines a small helper into its callers at Numba's level)."""

    def wrap(f):
        extra = {"inline": "always"} if inline else {}
        return numba.njit(parallel=parallel, **KERNEL_OPTIONS, **extra)(f)

    return wrap(fn) if fn is not None else wrap


def like(value, prototype):
    """``value`` converted to the float type of ``prototype`` (a float32 or float64 scalar).

    Kernels take ``fp``, a scalar of the working precision (``np.float32(0)`` or
    ``np.float64(0)``), and write their float constants as ``like(2.0, fp)``; the conversion is
    resolved when the kernel is compiled (no call at run time), unlike a function passed as an
    argument."""
    return type(prototype)(value)


@overload(like, inline="always")
def _like_impl(value, prototype):
    if prototype == types.float32:
        return lambda value, prototype: np.float32(value)
    if prototype == types.float64:
        return lambda value, prototype: np.float64(value)
    return None


def kernels_cached(minimum: int = 20) -> bool:
    """Whether Numba's cache already holds compiled kernels of refsoft (at least ``minimum``
    index files under the package's ``__pycache__`` folders, or under ``$NUMBA_CACHE_DIR``):
    False on a first run, which compiles them (tens of seconds)."""
    import glob
    import os

    root = os.environ.get("NUMBA_CACHE_DIR") or os.path.dirname(os.path.abspath(__file__))
    return len(glob.glob(os.path.join(root, "**", "*.nbi"), recursive=True)) >= minimum
