"""Which pages of an array were never touched (Linux's ``/proc/self/pagemap``): such pages of a
lazily zeroed G-buffer read as zeros, and the npz writer need not read them."""

from __future__ import annotations

import bisect
import mmap
import os

import numpy as np

PAGE = mmap.PAGESIZE


class PageMap:
    """Which pages of an array were never touched, where Linux says so (``/proc/self/pagemap``).

    A page of an anonymous private mapping (what :func:`refsoft.limits.zeros` maps for the
    G-buffers, of which a frame writes only the reflector's box) that is neither present nor
    swapped out was never written: it reads as zeros, and reading it would cost a page fault
    (the kernel maps its zero page: ~0.6 us a page, 36,000 pages in an ``ants`` frame at
    1024x768). Only arrays whose memory is an ``mmap`` lying in one anonymous, private, writable
    mapping of ``/proc/self/maps`` (no file, no name) are asked about; anything else, or a
    system without these files, is None (the writer then reads the bytes)."""

    def __init__(self):
        self._ranges = None  # (starts, ends) of the anonymous private mappings, read once
        self._fd = None

    def _load(self) -> bool:
        if self._ranges is None:
            self._ranges = ([], [])
            if not hasattr(os, "pread"):
                return False
            try:
                with open("/proc/self/maps") as fh:
                    lines = fh.read().splitlines()
                self._fd = os.open("/proc/self/pagemap", os.O_RDONLY)
            except OSError:
                return False
            for line in lines:
                f = line.split()
                if len(f) == 5 and f[1] == "rw-p" and f[4] == "0":  # no path, no name: anonymous
                    lo, hi = f[0].split("-")
                    self._ranges[0].append(int(lo, 16))
                    self._ranges[1].append(int(hi, 16))
        return self._fd is not None

    def untouched(self, data):
        """For (n,) uint8 ``data``: (its address, (P,) bool per page it overlaps: never touched),
        or None when that cannot be told."""
        root = data
        while isinstance(root, np.ndarray) and root.base is not None:
            root = root.base
        if isinstance(root, memoryview):  # np.frombuffer's base
            root = root.obj
        if not isinstance(root, mmap.mmap) or data.size == 0 or not self._load():
            return None
        addr = data.__array_interface__["data"][0]
        starts, ends = self._ranges
        i = bisect.bisect_right(starts, addr) - 1
        if i < 0 or addr + data.size > ends[i]:
            return None
        first = addr // PAGE
        n = (addr + data.size - 1) // PAGE - first + 1
        try:
            raw = os.pread(self._fd, 8 * n, 8 * first)
        except OSError:
            return None
        if len(raw) != 8 * n:
            return None
        # bit 63: present, bit 62: swapped out; neither: never written since mapped
        return addr, (np.frombuffer(raw, np.uint64) >> np.uint64(62)) == 0

    def close(self):
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None
