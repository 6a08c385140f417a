"""Scratch memory kept per thread between calls: the large arrays a stage makes for one reflector
and consumes before it returns (the exact drawing's candidates, the traced acceptance's
hierarchy). Made afresh for every reflector, their pages are faulted in anew each time, which
costs as much as filling them (about 60 MB a frame for the ants' eyes at 640x480)."""

from __future__ import annotations

import threading

import numpy as np

#: Per calling thread, the memory of :func:`kept` by name.
_local = threading.local()


def kept(name, shape, dtype=np.float64):
    """An array of ``shape`` and ``dtype`` (contents undefined, as ``np.empty``'s) over memory kept
    for ``name`` per calling thread between calls, grown when too small. The caller must be done
    with it before the same thread asks for ``name`` again."""
    shape = (shape,) if np.isscalar(shape) else tuple(shape)
    size = int(np.prod(shape, dtype=np.int64)) * np.dtype(dtype).itemsize
    memory = getattr(_local, "arrays", None)
    if memory is None:
        memory = _local.arrays = {}
    block = memory.get(name)
    if block is None or len(block) < size:
        block = memory[name] = np.empty(size + size // 4, np.uint8)  # room to grow by a quarter
    return block[:size].view(dtype).reshape(shape)
