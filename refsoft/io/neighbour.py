"""A raw deflate segment (RFC 1951) for flat pictures: every byte is a copy of the pixel to its
left, of the pixel above, or a literal, in one block of deflate's fixed Huffman codes.

A frame's image, its id maps and its PNG's rows are flat (98-99.9 % of the pixels of the
kitchen, ufo and ants frames equal the one to their left or above), and zlib's level 1 spends
~1.2 ms per MB looking for matches anywhere in its window. This encoder looks only at those two
distances (where each byte differs from them: NumPy) and runs at 2-4 GB/s on such a frame; its
output is a standard deflate stream that zlib, zipfile, NumPy and every PNG reader decode
(tests/frame/test_neighbour.py). zlib cannot be told to search only some distances, and
Python's ``zlib`` module is the only deflate encoder a refsoft install has, hence this one.

The segment refers to ``data`` before ``lo`` (up to 32 KiB back) as the bytes the decoder has
already produced, so it may follow any byte-aligned deflate output of ``data[:lo]`` that refers
to nothing after itself (zlib's output up to a full flush).
"""

from __future__ import annotations

import numpy as np

from .._numba import kernel
from ..errors import RefsoftError

#: The farthest a deflate match may refer back (RFC 1951: 32 KiB).
WINDOW = 32768

_LEN_BASE = (3, 4, 5, 6, 7, 8, 9, 10, 11, 13, 15, 17, 19, 23, 27, 31, 35, 43, 51, 59, 67, 83, 99, 115, 131,
             163, 195, 227, 258)
_LEN_EXTRA = (0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3, 4, 4, 4, 4, 5, 5, 5, 5, 0)
_DIST_BASE = (1, 2, 3, 4, 5, 7, 9, 13, 17, 25, 33, 49, 65, 97, 129, 193, 257, 385, 513, 769, 1025, 1537, 2049,
              3073, 4097, 6145, 8193, 12289, 16385, 24577)
_DIST_EXTRA = (0, 0, 0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5, 6, 6, 7, 7, 8, 8, 9, 9, 10, 10, 11, 11, 12, 12, 13, 13)


def _reversed(code: int, bits: int) -> int:
    """A Huffman code (written from its most significant bit) as the bits deflate's LSB-first
    stream holds."""
    return int(format(code, f"0{bits}b")[::-1], 2)


def _fixed_code(symbol: int):
    """(code, bits) of a literal/length symbol in deflate's fixed Huffman code (RFC 1951 3.2.6)."""
    if symbol < 144:
        return 0x30 + symbol, 8
    if symbol < 256:
        return 0x190 + symbol - 144, 9
    if symbol < 280:
        return symbol - 256, 7
    return 0xC0 + symbol - 280, 8


def _tables():
    """Per literal (256) and per match length (0..258: 3..258 used) the bits written and how many,
    a length's symbol and extra bits joined."""
    lit_val, lit_bits = np.zeros(256, np.int64), np.zeros(256, np.int64)
    for v in range(256):
        code, bits = _fixed_code(v)
        lit_val[v], lit_bits[v] = _reversed(code, bits), bits
    len_val, len_bits = np.zeros(259, np.int64), np.zeros(259, np.int64)
    for length in range(3, 259):
        i = max(j for j, b in enumerate(_LEN_BASE) if b <= length)
        if length == 258:
            i = 28  # 258 has its own symbol (285), not 284 with extra bits
        code, bits = _fixed_code(257 + i)
        len_val[length] = _reversed(code, bits) | ((length - _LEN_BASE[i]) << bits)
        len_bits[length] = bits + _LEN_EXTRA[i]
    return lit_val, lit_bits, len_val, len_bits


_LIT_VAL, _LIT_BITS, _LEN_VAL, _LEN_BITS = _tables()


def _distance(d: int):
    """(bits, how many) of distance ``d`` (1..32768): its fixed 5-bit code and extra bits."""
    i = max(j for j, b in enumerate(_DIST_BASE) if b <= d)
    return _reversed(i, 5) | ((d - _DIST_BASE[i]) << 5), 5 + _DIST_EXTRA[i]


def _differs(data, lo: int, hi: int, d: int) -> np.ndarray:
    """(hi - lo,) bool: whether ``data[j] != data[j - d]`` for ``j`` in ``[lo, hi)`` (True before
    ``d``: nothing to copy from; everywhere without ``d``)."""
    ne = np.ones(hi - lo, bool)
    s = max(lo, d)
    if d and s < hi:
        np.not_equal(data[s:hi], data[s - d:hi - d], out=ne[s - lo:])
    return ne


def _words(ne) -> np.ndarray:
    """(k,) int64: the bools ``ne`` as bits, little-endian (bit ``j`` of the whole is ``ne[j]``),
    and a word of clear bits after them."""
    bits = np.packbits(ne, bitorder="little")
    return np.concatenate((bits, np.zeros(-bits.size % 8 + 8, np.uint8))).view(np.int64)


def neighbour_deflate(data, lo: int, hi: int, pixel: int, row: int, final: bool = False, most_literals=None):
    """``data[lo:hi]`` as one fixed-Huffman deflate block, each byte a copy from ``pixel`` or
    ``row`` bytes back (greedy: the longer match, the pixel's on a tie; matches of 3 to 258 bytes)
    or a literal, ending byte-aligned: with ``final``, the stream's last block (padded to a
    byte); else followed by an empty stored block (what zlib's sync flush writes), after which
    another deflate segment may follow.

    Parameters
    ----------
    data : (n,) uint8 ndarray
        The bytes of the whole stream being written: ``data[:lo]`` is what the decoder has
        produced before this segment.
    lo, hi : int
        The segment, ``0 <= lo <= hi <= n``.
    pixel, row : int
        The two distances copied from (bytes, ``>= 1``); one beyond 32 KiB is not used.
    most_literals : int, optional
        None is returned once more literals than this are written (not a flat picture: zlib
        compresses it better and as fast).

    Returns
    -------
    bytes or None

    Raises
    ------
    RefsoftError
        ``data`` is not (n,) uint8, the segment is outside it, or a distance is below 1.
    """
    data = np.asarray(data)
    if data.dtype != np.uint8 or data.ndim != 1 or not 0 <= lo <= hi <= data.size or min(pixel, row) < 1:
        raise RefsoftError(f"neighbour_deflate needs (n,) uint8 bytes, 0 <= lo <= hi <= n and distances >= 1, got "
                           f"{data.dtype} {data.shape}, lo {lo}, hi {hi}, distances {pixel}, {row}")
    data = np.ascontiguousarray(data)
    pixel = pixel if 1 <= pixel <= WINDOW else 0
    row = row if 1 <= row <= WINDOW and row != pixel else 0
    np_, nr = _differs(data, lo, hi, pixel), _differs(data, lo, hi, row)
    # a byte that differs from both is a literal whatever the matches around it
    if most_literals is not None and np.count_nonzero(np_ & nr) > most_literals:
        return None
    mp, mr = _words(np_), _words(nr)
    pd, pb = _distance(pixel) if pixel else (0, 0)
    rd, rb = _distance(row) if row else (0, 0)
    out = np.empty((hi - lo) * 9 // 8 + 16, np.uint8)
    most = -1 if most_literals is None else int(most_literals)
    n = _encode(data, lo, hi, pixel, pd, pb, mp, row, rd, rb, mr, final, most, out, _LIT_VAL, _LIT_BITS, _LEN_VAL,
                _LEN_BITS)
    return None if n < 0 else out[:n].tobytes()


@kernel(llvm_inline=True)
def _run(differs, j, d, most):
    """The bytes from offset ``j`` of the segment (at most ``most``) equal to those ``d`` before
    them: the distance to the next set bit of ``differs`` (:func:`_words` of :func:`_differs`;
    0 without ``d``)."""
    if d == 0:  # no such distance
        return 0
    w = j >> 6
    x = differs[w] >> (j & 63)  # (an arithmetic shift: the copies of bit 63 come after it)
    n = 0
    if x == 0:
        n = 64 - (j & 63)
        w += 1
        while n < most:
            x = differs[w]
            if x != 0:
                break
            n += 64
            w += 1
        if n >= most:
            return most
    while (x & 0xFF) == 0:
        x >>= 8
        n += 8
    while (x & 1) == 0:
        x >>= 1
        n += 1
    return min(n, most)


@kernel
def _encode(data, lo, hi, pixel, pixel_val, pixel_bits, mp, row, row_val, row_bits, mr, final, most_literals, out,
            lit_val, lit_bits, len_val, len_bits):
    """The bytes written to ``out`` (-1 once more than ``most_literals`` literals, when that is
    ``>= 0``)."""
    acc = (1 if final else 0) | 2  # BFINAL, BTYPE = 01 (fixed codes); at most 39 bits held
    nbits = 3
    o = 0
    i = lo
    literals = 0
    while i < hi:
        most = min(258, hi - i)
        lp = _run(mp, i - lo, pixel, most)
        lr = _run(mr, i - lo, row, most)
        if lp >= lr:
            best, val, bits = lp, pixel_val, pixel_bits
        else:
            best, val, bits = lr, row_val, row_bits
        if best >= 3:
            acc |= len_val[best] << nbits
            nbits += len_bits[best]
            while nbits >= 8:
                out[o] = np.uint8(acc & 0xFF)
                acc >>= 8
                nbits -= 8
                o += 1
            acc |= val << nbits
            nbits += bits
            i += best
        else:
            literals += 1
            if most_literals >= 0 and literals > most_literals:
                return -1
            acc |= lit_val[data[i]] << nbits
            nbits += lit_bits[data[i]]
            i += 1
        while nbits >= 8:
            out[o] = np.uint8(acc & 0xFF)
            acc >>= 8
            nbits -= 8
            o += 1
    nbits += 7  # end of block: symbol 256, seven zero bits
    if not final:
        nbits += 3  # an empty stored block: BFINAL 0, BTYPE 00, then to the byte, LEN 0, NLEN 0xFFFF
    while nbits > 0:
        out[o] = np.uint8(acc & 0xFF)
        acc >>= 8
        nbits -= 8
        o += 1
    if not final:
        out[o] = 0
        out[o + 1] = 0
        out[o + 2] = 255
        out[o + 3] = 255
        o += 4
    return o
