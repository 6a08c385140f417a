"""Boundary validators shared by every public function: each checks one value and raises a
:class:`refsoft.errors.RefsoftError` (or the subclass given) with a one-line message naming it.

Kernels never validate: the public function in front of them calls these first.
"""

from __future__ import annotations

import math

import numpy as np

from .errors import RefsoftError


def is_integer(value) -> bool:
    """An int or NumPy integer, and not a bool (``True`` is an int to Python)."""
    return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))


def is_number(value) -> bool:
    """A finite int or float (Python or NumPy), and not a bool."""
    return (isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))
            and math.isfinite(value))


def is_flag(value) -> bool:
    """A Python or NumPy bool."""
    return isinstance(value, (bool, np.bool_))


def flag(value, name: str, error=RefsoftError) -> bool:
    """``value`` must be True or False (Python or NumPy bool)."""
    if not is_flag(value):
        raise error(f"{name} must be True or False, got {value!r}")
    return bool(value)


def integer(value, name: str, minimum=None, maximum=None, error=RefsoftError) -> int:
    """``value`` must be an integer (not a bool) in ``[minimum, maximum]`` (either bound
    optional)."""
    ok = is_integer(value) and (minimum is None or value >= minimum) and (maximum is None or value <= maximum)
    if not ok:
        if minimum is not None and maximum is not None:
            want = f"an integer in [{minimum}, {maximum}]"
        elif minimum == 1:
            want = "a positive integer"
        elif minimum is not None:
            want = f"an integer >= {minimum}"
        else:
            want = "an integer"
        raise error(f"{name} must be {want}, got {value!r}")
    return int(value)


def number(value, name: str, minimum=None, maximum=None, what=None, error=RefsoftError) -> float:
    """``value`` must be a finite number (not a bool) in ``[minimum, maximum]``; ``what``
    replaces the description in the message."""
    ok = is_number(value) and (minimum is None or value >= minimum) and (maximum is None or value <= maximum)
    if not ok:
        if what is None:
            what = "a number" + (f" >= {minimum:g}" if minimum is not None else "") + \
                   (f" <= {maximum:g}" if maximum is not None else "")
        raise error(f"{name} must be {what}, got {value!r}")
    return float(value)


def choice(value, choices, name: str, error=RefsoftError):
    """``value`` must be one of ``choices``."""
    if not isinstance(value, str) or value not in choices:
        raise error(f"{name} must be one of {list(choices)}, got {value!r}")
    return value


def points(x, name: str, n=None, error=RefsoftError) -> np.ndarray:
    """``x`` as a finite (N, 3) float64 array (``n``: the required N)."""
    a = np.asarray(x, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != 3 or (n is not None and len(a) != n):
        raise error(f"{name} must have shape ({'N' if n is None else n}, 3), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise error(f"{name} has non-finite values")
    return a


def point(x, name: str, error=RefsoftError) -> np.ndarray:
    """``x`` as one finite 3-vector, float64 shape (3,)."""
    if np.size(x) != 3:
        raise error(f"{name} must be 3 numbers, got shape {np.shape(x)}")
    return points(np.reshape(x, (1, 3)), name, 1, error)[0]
