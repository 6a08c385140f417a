"""Keep freed memory for reuse (glibc only).

On the virtual machines refsoft is measured on, a page fault costs about 2 microseconds, and a
1024x768 G-buffer touches about 30 MB of fresh pages per call: without reuse, page faults would
be most of the run time. glibc returns large blocks to the kernel on ``free`` (they are
``mmap``-ed), so every call faults them in again. :func:`retain_freed_memory` raises glibc's
mmap and trim thresholds so that freed blocks stay in the heap and are reused, as a GPU driver
keeps its framebuffers. It changes the whole process's allocator, so refsoft never calls it on
import: the ``refsoft`` command and the benchmarks call it; library users may.
"""

from __future__ import annotations

import ctypes
import ctypes.util

# glibc mallopt parameters (malloc.h)
_M_TRIM_THRESHOLD = -1
_M_TOP_PAD = -2
_M_MMAP_THRESHOLD = -3

#: Blocks up to this size come from the heap (glibc's maximum for 64-bit: 32 MiB).
MMAP_THRESHOLD = 32 * 1024 * 1024
#: Free heap memory kept before returning any to the kernel.
TRIM_THRESHOLD = 1024 * 1024 * 1024


def retain_freed_memory() -> bool:
    """Ask glibc to keep freed memory for reuse. Returns False where that is not possible."""
    name = ctypes.util.find_library("c")
    if not name:
        return False
    try:
        libc = ctypes.CDLL(name)
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
    mallopt.restype = ctypes.c_int
    ok = mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD) == 1
    ok &= mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD) == 1
    ok &= mallopt(_M_TOP_PAD, 64 * 1024 * 1024) == 1
    return bool(ok)
