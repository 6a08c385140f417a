"""The CRC-32 of two byte strings joined, from their CRC-32s: zlib's ``crc32_combine64`` (through
ctypes: Python's zlib module does not expose it)."""

from __future__ import annotations

import zlib

_COMBINE = []  # [zlib's crc32_combine64 or None], looked up at the first call


def combine():
    """zlib's ``crc32_combine64(crc1, crc2, len2)``, or None where the C library is not found."""
    if not _COMBINE:
        _COMBINE.append(crc32_combine())
    return _COMBINE[0]


def crc32_combine():
    """zlib's ``crc32_combine64(crc1, crc2, len2)`` (the CRC-32 of two byte strings joined, from
    their CRC-32s and the second's length) from the zlib library Python's zlib module is linked to,
    through ctypes (the module does not expose it); None where it is not found or disagrees with
    ``zlib.crc32`` (checked once)."""
    import ctypes
    import sys

    names = {"linux": ("libz.so.1",), "darwin": ("libz.1.dylib", "libz.dylib")}.get(sys.platform, ())
    for name in names:
        try:
            fn = ctypes.CDLL(name).crc32_combine64
        except (OSError, AttributeError):
            continue
        fn.argtypes = (ctypes.c_ulong, ctypes.c_ulong, ctypes.c_int64)
        fn.restype = ctypes.c_ulong
        head, tail = b"refsoft", bytes(1000) + b"\x01"
        if fn(zlib.crc32(head), zlib.crc32(tail), len(tail)) == zlib.crc32(head + tail):
            return fn
    return None
