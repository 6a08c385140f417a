"""A raw deflate stream (a zip member's) fed in pieces, whose pieces of zero bytes are written as
zlib's output for that many zeros, computed once, instead of being compressed again."""

from __future__ import annotations

import zlib

import numpy as np


def zero_bytes(piece) -> bool:
    """Whether (n,) uint8 ``piece`` is zero bytes only (the bytes, not the values: -0.0 is not)."""
    words = piece.view(np.uint64) if piece.size % 8 == 0 else piece
    return piece.size > 0 and not words.max()


_ZERO_PIECES = {}


def zero_piece(n: int, level: int) -> bytes:
    """zlib's raw deflate output for ``n`` zero bytes followed by a full flush, from a fresh
    compressor: it refers to nothing before it and ends on a byte boundary, so it can follow any
    full flush of another stream (computed once per size and level)."""
    key = (n, level)
    piece = _ZERO_PIECES.get(key)
    if piece is None:
        z = zlib.compressobj(level, zlib.DEFLATED, -15)
        piece = _ZERO_PIECES[key] = z.compress(bytes(n)) + z.flush(zlib.Z_FULL_FLUSH)
    return piece


class PieceDeflate:
    """A raw deflate stream (what zipfile's ZIP_DEFLATED compressor writes) fed in pieces: a piece
    of zero bytes only ends the stream's open block with a full flush (after which zlib refers
    to nothing earlier) and is written as :func:`zero_piece` (:meth:`zeros`); any other piece
    goes to zlib. ``check``: whether :meth:`compress` looks for zero pieces itself (off when the
    caller hands those to :meth:`zeros`)."""

    def __init__(self, level: int, strategy: int = zlib.Z_DEFAULT_STRATEGY):
        self._level = level
        self._z = zlib.compressobj(level, zlib.DEFLATED, -15, 8, strategy)
        self._open = False  # input given to self._z since its last full flush
        self.check = True

    def compress(self, data) -> bytes:
        if self.check:
            piece = np.frombuffer(data, np.uint8)
            if zero_bytes(piece):
                return self.zeros(piece.size)
        self._open = True
        return self._z.compress(data)

    def zeros(self, n: int) -> bytes:
        """The deflate output of ``n`` zero bytes, after the stream's open block."""
        out = self._z.flush(zlib.Z_FULL_FLUSH) if self._open else b""
        self._open = False
        return out + zero_piece(n, self._level)

    def flush(self) -> bytes:
        return self._z.flush()
