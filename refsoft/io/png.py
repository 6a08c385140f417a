"""PNG writing: Pillow's encoder (:func:`write_png`) and a frame's unfiltered rows deflated as a
flat picture, or by zlib (:func:`write_png_rows`)."""

from __future__ import annotations

import struct
import zlib

import numpy as np

from ..constants import NPZ_LITERAL_SHARE
from ..errors import RefsoftError
from .atomic import atomic_path


def write_png(path, image, level=None):
    """Write an (H, W, 3) or (H, W) uint8 image as PNG atomically (Pillow's encoder, which
    imageio also writes through, without loading imageio's plugin machinery), at zlib ``level``
    (default: Pillow's, 6)."""
    from PIL import Image

    extra = {} if level is None else {"compress_level": int(level)}
    with atomic_path(path, ".png") as tmp:
        Image.fromarray(np.ascontiguousarray(image, dtype=np.uint8)).save(tmp, format="PNG", **extra)


def _zlib_stream(rows, pixel: int, level: int) -> bytes:
    """The zlib stream (RFC 1950) of the (H, 1 + W * pixel) uint8 ``rows``: their deflate output
    by :func:`~refsoft.io.neighbour.neighbour_deflate` (each byte a copy of the pixel to its left
    or above, or a literal) after a 2-byte header saying "deflate, 32 KiB window, fastest", and
    their Adler-32 (``zlib.adler32``); zlib's own stream (``zlib.compress`` at ``level``) when the
    rows are not flat (more than :data:`~refsoft.constants.NPZ_LITERAL_SHARE` literals) or
    ``level`` is 0."""
    if level:
        from .neighbour import neighbour_deflate  # (Numba: loaded by the first PNG written)

        seg = neighbour_deflate(rows.reshape(-1), 0, rows.size, pixel, rows.shape[1], final=True,
                                most_literals=int(rows.size * NPZ_LITERAL_SHARE))
        if seg is not None:
            return b"\x78\x01" + seg + struct.pack(">I", zlib.adler32(rows))
    return zlib.compress(rows, level)


def write_png_rows(path, image, level: int):
    """Write an (H, W, 3) or (H, W) uint8 image as PNG atomically, its rows unfiltered (PNG's filter
    type 0) and deflated (each byte a copy of the pixel to its left or above, or a literal:
    :func:`_zlib_stream`; zlib at ``level`` for a picture that is not flat), in the three chunks a
    PNG needs (IHDR, IDAT, IEND, each with its zlib.crc32).

    A run's frames are written this way (:func:`refsoft.frame.outputs.write_frame`): Pillow chooses
    a filter for every row, most of its encoder's time, which it does not let a caller turn off;
    a rendered frame, flat-shaded, deflates about as well unfiltered, for less than half the CPU
    time, and the copies from the left or above take a third of zlib's (docs/benchmarks.md). Any
    PNG reader decodes it to the same pixels.

    Raises
    ------
    RefsoftError
        ``image`` is not uint8, (H, W) or (H, W, 3) with H, W >= 1.
    """
    img = np.asarray(image)
    if img.dtype != np.uint8 or not (img.ndim == 2 or (img.ndim == 3 and img.shape[2] == 3)) or 0 in img.shape[:2]:
        raise RefsoftError(f"a PNG needs an (H, W) or (H, W, 3) uint8 image with H, W >= 1, got {img.dtype} {img.shape}")
    h, w = img.shape[:2]
    rows = np.zeros((h, 1 + img[0].size), np.uint8)  # each row: its filter type (0), its bytes
    rows[:, 1:] = img.reshape(h, -1)
    data = _zlib_stream(rows, 3 if img.ndim == 3 else 1, level)

    def chunk(tag, body):
        return struct.pack(">I", len(body)) + tag + body + struct.pack(">I", zlib.crc32(body, zlib.crc32(tag)))

    ihdr = struct.pack(">IIBBBBB", w, h, 8, 2 if img.ndim == 3 else 0, 0, 0, 0)  # 8 bits, RGB or grey
    limit = 1 << 30  # a chunk holds less than 2**31 bytes
    with atomic_path(path, ".png") as tmp:
        with open(tmp, "wb") as fh:
            fh.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr))
            for lo in range(0, len(data), limit):
                fh.write(chunk(b"IDAT", data[lo:lo + limit]))
            fh.write(chunk(b"IEND", b""))
