"""A raw deflate stream (a zip member's) fed in pieces, whose pieces that repeat a short pattern
(zeros, one id, one colour) are written as zlib's output for such bytes, computed once, instead of
being compressed again."""

from __future__ import annotations

import zlib

import numpy as np

from ..constants import NPZ_LITERAL_SHARE, NPZ_PICTURE_BYTES

#: (pattern, n, level, strategy) -> (deflate output, CRC-32) of a repeating piece.
_PIECES = {}
#: Entries kept at most: a run's patterns are few (zeros, the background's ids and colours), but a
#: long run of varied scenes should not grow the cache without bound.
_MAX_PIECES = 4096


def repeat_bytes(pattern: bytes, n: int) -> np.ndarray:
    """(n,) uint8: ``pattern`` repeated from its first byte, cut to ``n`` bytes."""
    p = np.frombuffer(pattern, np.uint8)
    return np.tile(p, -(-n // p.size))[:n]


def repeat_piece(pattern: bytes, n: int, level: int, strategy: int = zlib.Z_DEFAULT_STRATEGY):
    """zlib's raw deflate output for ``n`` bytes repeating ``pattern``, followed by a full flush,
    from a fresh compressor (it refers to nothing before it and ends on a byte boundary, so it can
    follow any full flush of another stream), and the CRC-32 of those bytes; computed once per
    pattern, size, level and strategy."""
    key = (pattern, n, level, strategy)
    piece = _PIECES.get(key)
    if piece is None:
        data = repeat_bytes(pattern, n)
        z = zlib.compressobj(level, zlib.DEFLATED, -15, 8, strategy)
        if len(_PIECES) >= _MAX_PIECES:
            _PIECES.clear()
        piece = _PIECES[key] = (z.compress(data) + z.flush(zlib.Z_FULL_FLUSH), zlib.crc32(data))
    return piece


class PieceDeflate:
    """A raw deflate stream (what zipfile's ZIP_DEFLATED compressor writes) fed in pieces: a piece
    that repeats a pattern ends the stream's open block with a full flush (after which zlib refers
    to nothing earlier) and is written as :func:`repeat_piece` (:meth:`repeat`); any other piece
    goes to zlib at ``other_level`` (default ``level``; 0: stored blocks), or, for a picture, to
    :meth:`segment`. ``pattern`` and ``span``: set by a caller that hands the next piece through
    zipfile's member writer (which calls :meth:`compress`), to say that it repeats this pattern,
    or that it is ``data[lo:hi]`` of the member's bytes ``data`` (``span = (data, lo, hi)``)."""

    def __init__(self, level: int, strategy: int = zlib.Z_DEFAULT_STRATEGY, other_level=None, picture=None):
        self._level = level
        self._strategy = strategy
        self._z = zlib.compressobj(level if other_level is None else other_level, zlib.DEFLATED, -15, 8, strategy)
        self._open = False  # input given to self._z since its last full flush
        self._picture = picture
        self.pattern = None
        self.span = None

    def compress(self, data) -> bytes:
        if self.pattern is not None:
            pattern, self.pattern = self.pattern, None
            return self.repeat(pattern, memoryview(data).nbytes)[0]
        if self.span is not None:
            (whole, lo, hi), self.span = self.span, None
            return self.segment(whole, lo, hi)
        self._open = True
        return self._z.compress(data)

    def segment(self, data, lo: int, hi: int) -> bytes:
        """The deflate output of ``data[lo:hi]`` (``data``: the member's whole (n,) uint8 bytes, of
        which ``data[:lo]`` went before), each byte copied from the pixel to its left or above
        where the stream is a picture (``picture``: (pixel, row) bytes), the segment at least
        :data:`~refsoft.constants.NPZ_PICTURE_BYTES` long and with few literals
        (:func:`~refsoft.io.neighbour.neighbour_deflate`, after the open block), else zlib's."""
        if self._picture is not None and hi - lo >= NPZ_PICTURE_BYTES:
            from .neighbour import neighbour_deflate  # (Numba: loaded by the first picture written)

            pixel, row = self._picture
            seg = neighbour_deflate(data, lo, hi, pixel, row, most_literals=int((hi - lo) * NPZ_LITERAL_SHARE))
            if seg is not None:
                out = self._z.flush(zlib.Z_FULL_FLUSH) if self._open else b""
                self._open = False
                return out + seg
        self._open = True
        return self._z.compress(data[lo:hi])

    def repeat(self, pattern: bytes, n: int):
        """The deflate output of ``n`` bytes repeating ``pattern``, after the stream's open block,
        and the CRC-32 of those bytes."""
        out = self._z.flush(zlib.Z_FULL_FLUSH) if self._open else b""
        self._open = False
        piece, crc = repeat_piece(pattern, n, self._level, self._strategy)
        return out + piece, crc

    def flush(self) -> bytes:
        return self._z.flush()
