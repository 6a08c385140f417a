"""A frame's ``.npz``: the archive ``np.savez_compressed`` writes, at a chosen zlib level, with
its repeating runs (zeros, an id, a colour: :mod:`refsoft.io.runs`) deflated once
(:mod:`refsoft.io.deflate`), their CRC-32 combined (:mod:`refsoft.io.crc`) and their untouched
pages not read (:mod:`refsoft.io.pages`)."""

from __future__ import annotations

import functools
import io
import math
import zipfile
import zlib

import numpy as np

from ..constants import (NPZ_PERIOD_BYTES, NPZ_PIECE_BYTES, NPZ_REPEAT_BYTES, NPZ_SAMPLE_BYTES, NPZ_SHORTEST_RUN,
                         NPZ_STORE_RATIO, NPZ_UNIT_BYTES)
from .atomic import atomic_path
from .crc import combine
from .deflate import PieceDeflate
from .pages import PageMap
from .runs import repeating_runs, untouched_units


def write_npz_level(path, arrays, level: int, float_level=None):
    """Write ``arrays`` as an ``.npz`` to ``path`` atomically, deflated at zlib ``level`` (0-9).

    The archive is the one ``np.savez_compressed`` writes (one ``NAME.npy`` member per array, in
    order, zip64 members, the ``.npy`` header NumPy writes) but for how each member's bytes are
    compressed, so ``np.load`` reads the same arrays bit for bit:

    - a member is cut into runs (:func:`~refsoft.io.runs.repeating_runs`): runs of
      :data:`~refsoft.constants.NPZ_UNIT_BYTES` units that repeat
      :data:`~refsoft.constants.NPZ_PERIOD_BYTES` (zeros: most of a G-buffer; one id or colour:
      the background of the id maps and the image) and other bytes. A repeating run is written
      as zlib's output for such bytes after a full flush, computed once per pattern and size
      (:func:`~refsoft.io.deflate.repeat_piece`), instead of being compressed again; its CRC-32
      is combined by zlib (``crc32_combine64``) from the piece's, and a unit whose pages were
      never touched (an anonymous mapping's, as :func:`refsoft.limits.zeros` makes them;
      :class:`~refsoft.io.pages.PageMap`) is not read at all;
    - a member whose samples deflate to more than :data:`~refsoft.constants.NPZ_STORE_RATIO` of
      their size (high-entropy floats) is stored uncompressed; with ``float_level=0`` the other
      bytes of a float member (a G-buffer's reflector pixels) are stored inside its deflate
      stream, its repeating runs still deflated.

    zipfile writes the headers and, where its member writer's state is not the one this module
    knows, each byte's CRC-32 (``zlib.crc32``); zlib does all the compression. The file's bytes
    depend on the arrays' bytes only (not on which pages were read, on what the cache of pieces
    holds or on how a CRC was computed), so a rerun writes the same bytes. A ``kitchen`` frame
    at 1024x768: about 25 ms of CPU (docs/benchmarks.md).

    Parameters
    ----------
    path : str or PathLike
    arrays : dict of str to ndarray
        Written in the dict's order; object arrays are refused (``ValueError``, no pickles).
    level : int
        zlib's compression level (0 stores every member uncompressed).
    float_level : int, optional
        zlib's level for the bytes of float members outside their repeating runs (default
        ``level``; 0: stored, the runs still deflated at ``level``).
    """
    pages = PageMap()
    try:
        with atomic_path(path, ".npz") as tmp:
            with zipfile.ZipFile(tmp, mode="w", compression=zipfile.ZIP_DEFLATED, compresslevel=level,
                                 allowZip64=True) as zf:
                for name, value in arrays.items():
                    _write_member(zf, name + ".npy", np.asanyarray(value), level, pages, float_level)
    finally:
        pages.close()


#: The date of every member of a frame's npz.
ZIP_DATE = (1980, 1, 1, 0, 0, 0)


def _npy_parts(array):
    """The ``.npy`` header NumPy writes for ``array`` (bytes) and its data as (n,) uint8, in the
    order NumPy writes it (Fortran order for a Fortran-contiguous array, as its header says)."""
    if array.dtype.hasobject:
        raise ValueError("Object arrays cannot be saved when allow_pickle=False")
    fmt = np.lib.format
    header = fmt.header_data_from_array_1_0(array)
    buf = io.BytesIO()
    try:  # the version np.save picks: 1.0 unless the header needs more than 64 KiB
        fmt.write_array_header_1_0(buf, header)
    except ValueError:
        buf = io.BytesIO()
        fmt.write_array_header_2_0(buf, header)
    data = np.asarray(array)
    data = np.ascontiguousarray(data.T if header["fortran_order"] else data).reshape(-1)
    return buf.getvalue(), data.view(np.uint8)


def _repeat_sizes(n: int) -> tuple:
    """The pieces a repeating run of ``n`` bytes (whole units) is written as: multiples of
    ``lcm(NPZ_UNIT_BYTES, NPZ_PERIOD_BYTES)`` (so that each starts the run's pattern over) in
    powers of two, largest first, at most :data:`~refsoft.constants.NPZ_REPEAT_BYTES` each, then
    the rest. A run of any length is a few pieces of a few sizes, all cached after the first frames
    (a cut into equal pieces left a new size at each run's end, compressed again every frame)."""
    return _cut(n, NPZ_UNIT_BYTES, NPZ_PERIOD_BYTES, NPZ_REPEAT_BYTES)


@functools.lru_cache(maxsize=4096)
def _cut(n: int, unit: int, period: int, most: int) -> tuple:
    """:func:`_repeat_sizes` (a frame's runs recur: their cuts are kept)."""
    base = math.lcm(unit, period)
    top = base << max(0, (most // base).bit_length() - 1)  # the largest base * 2**k allowed
    whole, rest = divmod(n, base)
    tops, whole = divmod(whole * base, top)
    sizes = [top] * tops
    for bit in range((whole // base).bit_length() - 1, -1, -1):
        if (whole // base) >> bit & 1:
            sizes.append(base << bit)
    if rest:
        sizes.append(rest)
    return tuple(sizes)


def _write_member(zf, name, array, level, pages=None, float_level=None):
    header, data = _npy_parts(array)
    # a fixed date (the zip format's first): a rerun writes the same bytes (the file's own
    # modification time says when it was written)
    info = zipfile.ZipInfo(name, date_time=ZIP_DATE)
    # asked before the samples below read (and so touch) a few pages
    unread = pages.untouched(data) if pages is not None and level else None
    store = level == 0 or _incompressible(data, level)
    info.compress_type = zipfile.ZIP_STORED if store else zipfile.ZIP_DEFLATED
    with zf.open(info, "w", force_zip64=True) as fh:
        if store:
            fh.write(header)
            fh.write(data)
            return
        # zipfile's member writer crc32s each write, hands it to its compressor's compress()
        # and, at close, writes its flush(): that compressor is replaced by one that reuses the
        # deflate output of repeating pieces
        # (floats: zlib's run-length strategy, as small for half the time of its default
        # on a G-buffer, whose float bytes seldom repeat beyond the runs of zeros; or stored)
        floats = array.dtype.kind in "fc"
        other = float_level if floats and float_level is not None else level
        picture = _picture(array)
        deflate = fh._compressor = PieceDeflate(level, zlib.Z_RLE if floats else zlib.Z_DEFAULT_STRATEGY, other,
                                                picture)
        fh.write(header)
        # a repeating piece bypasses the member writer (when it has the state this module
        # knows): its CRC-32 is combined from the piece's, not computed over its bytes again
        direct = combine() is not None and all(hasattr(fh, a) for a in _WRITER_STATE)
        n_units = data.size // NPZ_UNIT_BYTES
        skip = untouched_units(unread, n_units, NPZ_UNIT_BYTES) if direct else None
        shortest = 1 if other == 0 else NPZ_SHORTEST_RUN
        runs = repeating_runs(data, NPZ_UNIT_BYTES, NPZ_PERIOD_BYTES, skip, shortest)
        if direct:
            _write_runs(fh, deflate, data, runs, picture is not None)
            return
        for lo, hi, pattern in runs:  # through the member writer, which reads every byte
            if pattern is None and picture is not None:  # a picture's other bytes: one segment
                deflate.span = (data, lo, hi)
                fh.write(data[lo:hi])
                continue
            if pattern is None:
                for a in range(lo, hi, NPZ_PIECE_BYTES):
                    fh.write(data[a:min(hi, a + NPZ_PIECE_BYTES)])
                continue
            a = lo
            for n in _repeat_sizes(hi - lo):
                deflate.pattern = pattern
                fh.write(data[a:a + n])
                a += n


#: Pixels of the narrowest array written as a picture (:func:`_picture`): an (N, 2) or (N, 3)
#: array holds one vertex per row, whose values seldom repeat the row above.
PICTURE_MIN_WIDTH = 8

#: What zipfile's member writer (``_ZipWriteFile``, Python 3.10-3.13) keeps of a member being
#: written: its size, CRC-32 and compressed size, and the archive's file.
_WRITER_STATE = ("_file_size", "_crc", "_compress_size", "_fileobj")


def _write_runs(fh, deflate, data, runs, picture=False):
    """What ``fh.write`` of each run does (the member writer's size, CRC-32, compressed size and
    output), in one pass: a repeating piece's CRC-32 is combined from the piece's (zlib's
    ``crc32_combine64``), not computed over its bytes, which are not read; a picture's other
    bytes are one segment (:meth:`~refsoft.io.deflate.PieceDeflate.segment`)."""
    join = combine()
    crc, out, held = fh._crc, [], 0
    for lo, hi, pattern in runs:
        if pattern is None and picture:
            crc = zlib.crc32(data[lo:hi], crc)
            out.append(deflate.segment(data, lo, hi))
            held += len(out[-1])
        elif pattern is None:
            for a in range(lo, hi, NPZ_PIECE_BYTES):  # CRC-32 and deflate a piece while it is in cache
                piece = data[a:min(hi, a + NPZ_PIECE_BYTES)]
                crc = zlib.crc32(piece, crc)
                out.append(deflate.compress(piece))
                held += len(out[-1])
        else:
            for n in _repeat_sizes(hi - lo):
                piece, piece_crc = deflate.repeat(pattern, n)
                crc = join(crc, piece_crc, n)
                out.append(piece)
                held += len(piece)
        if held >= NPZ_PIECE_BYTES:  # the output held in memory stays small
            fh._compress_size += _write_out(fh, out)
            held = 0
    fh._compress_size += _write_out(fh, out)
    fh._file_size += data.size
    fh._crc = crc


def _write_out(fh, out) -> int:
    blob = b"".join(out)
    out.clear()
    fh._fileobj.write(blob)
    return len(blob)


def _picture(array):
    """(pixel, row) bytes of an array whose bytes are a picture's pixels, row after row: (H, W)
    of integers or bools (a frame's id maps, a G-buffer's mask) or (H, W, 3 or 4) of uint8 (its
    image), written in C order; else None."""
    if array.dtype.kind not in "iub" or array.ndim not in (2, 3) or array.size == 0 or (
            array.flags.f_contiguous and not array.flags.c_contiguous):
        return None  # (a Fortran-ordered array's bytes are written column by column)
    if array.shape[1] < PICTURE_MIN_WIDTH:  # a list of vertices' pixels or ids, not a picture
        return None
    if array.ndim == 2:
        return array.itemsize, array.shape[1] * array.itemsize
    if array.ndim == 3 and array.dtype == np.uint8 and array.shape[2] in (3, 4):
        return array.shape[2], array.shape[1] * array.shape[2]
    return None


def _incompressible(data, level) -> bool:
    """Whether 4 evenly spaced samples of ``data`` (NPZ_SAMPLE_BYTES each, deflated as one
    stream) deflate to more than NPZ_STORE_RATIO of their size."""
    n = NPZ_SAMPLE_BYTES
    if data.size < 4 * n:
        return False
    z = zlib.compressobj(level, zlib.DEFLATED, -15)
    packed = sum(len(z.compress(data[i * (data.size - n) // 3:][:n])) for i in range(4))
    return packed + len(z.flush()) > NPZ_STORE_RATIO * 4 * n
