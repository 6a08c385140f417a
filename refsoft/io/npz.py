"""A frame's ``.npz``: the archive ``np.savez_compressed`` writes, at a chosen zlib level, with its
G-buffers' zero pieces deflated once (:mod:`refsoft.io.deflate`), their CRC-32 combined
(:mod:`refsoft.io.crc`) and their untouched pages not read (:mod:`refsoft.io.pages`)."""

from __future__ import annotations

import io
import zipfile
import zlib

import numpy as np

from ..constants import NPZ_PIECE_BYTES, NPZ_SAMPLE_BYTES, NPZ_STORE_RATIO
from .atomic import atomic_path
from .crc import crc_after_zeros
from .deflate import PieceDeflate, zero_bytes
from .pages import PageMap, untouched_piece


def write_npz_level(path, arrays, level: int):
    """Write ``arrays`` as an ``.npz`` to ``path`` atomically, deflated at zlib ``level`` (0-9).

    The archive is the one ``np.savez_compressed`` writes (one ``NAME.npy`` member per array, in
    order, zip64 members, the ``.npy`` header NumPy writes) but for how each member's bytes are
    compressed, so ``np.load`` reads the same arrays bit for bit:

    - a member is deflated in pieces of :data:`~refsoft.constants.NPZ_PIECE_BYTES`; a piece of
      zero bytes only (most of a G-buffer) is written as zlib's output for that many zeros after
      a full flush, computed once (:func:`~refsoft.io.deflate.zero_piece`), instead of being compressed again;
    - a member whose samples deflate to more than :data:`~refsoft.constants.NPZ_STORE_RATIO` of
      their size (high-entropy floats) is stored uncompressed;
    - a zero piece's CRC-32 is combined by zlib (``crc32_combine64``) from that of zeros, and a
      piece whose pages were never touched (an anonymous mapping's, as
      :func:`refsoft.limits.zeros` makes them; :class:`~refsoft.io.pages.PageMap`) is not read at all.

    zipfile writes the headers and the other pieces' CRC-32 (``zlib.crc32``); zlib does all the
    compression. The file's bytes do not depend on how a zero piece was found or its CRC computed,
    so a rerun writes the same bytes. An ``ants`` frame (8 reflectors) at 1024x768: about 60 ms of
    CPU (docs/benchmarks.md).

    Parameters
    ----------
    path : str or PathLike
    arrays : dict of str to ndarray
        Written in the dict's order; object arrays are refused (``ValueError``, no pickles).
    level : int
        zlib's compression level (0 stores every member uncompressed).
    """
    pages = PageMap()
    try:
        with atomic_path(path, ".npz") as tmp:
            with zipfile.ZipFile(tmp, mode="w", compression=zipfile.ZIP_DEFLATED, compresslevel=level,
                                 allowZip64=True) as zf:
                for name, value in arrays.items():
                    _write_member(zf, name + ".npy", np.asanyarray(value), level, pages)
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


def _write_member(zf, name, array, level, pages=None):
    header, data = _npy_parts(array)
    # a fixed date (the zip format's first): a rerun writes the same bytes (the file's own
    # modification time says when it was written)
    info = zipfile.ZipInfo(name, date_time=ZIP_DATE)
    # asked before the samples below read (and so touch) a few pages
    unread = pages.untouched(data) if pages is not None and level else None
    store = level == 0 or _incompressible(data, level)
    info.compress_type = zipfile.ZIP_STORED if store else zipfile.ZIP_DEFLATED
    with zf.open(info, "w", force_zip64=True) as fh:
        deflate = None
        if not store:
            # zipfile's member writer crc32s each write, hands it to its compressor's
            # compress() and, at close, writes its flush(): that compressor is replaced by one
            # that reuses the deflate output of zero pieces
            # (floats: zlib's run-length strategy, as small for half the time of its default
            # on a G-buffer, whose float bytes seldom repeat beyond the runs of zeros)
            floats = array.dtype.kind in "fc"
            deflate = fh._compressor = PieceDeflate(level, zlib.Z_RLE if floats else zlib.Z_DEFAULT_STRATEGY)
        fh.write(header)
        # a zero piece bypasses the member writer (when it has the state this module knows):
        # its CRC-32 is combined from that of zeros, not computed over its bytes again
        direct = deflate is not None and all(hasattr(fh, a) for a in _WRITER_STATE)
        if direct:
            deflate.check = False
        for lo in range(0, data.size, NPZ_PIECE_BYTES):
            piece = data[lo:lo + NPZ_PIECE_BYTES]
            if direct and (untouched_piece(unread, lo, piece.size) or zero_bytes(piece)):
                _write_zeros(fh, deflate, piece)
            else:
                fh.write(piece)


#: What zipfile's member writer (``_ZipWriteFile``, Python 3.10-3.13) keeps of a member being
#: written: its size, CRC-32 and compressed size, and the archive's file.
_WRITER_STATE = ("_file_size", "_crc", "_compress_size", "_fileobj")


def _write_zeros(fh, deflate, piece):
    """What ``fh.write(piece)`` does for a piece of zero bytes, without reading it again."""
    n = piece.size
    fh._file_size += n
    fh._crc = crc_after_zeros(fh._crc, piece)
    out = deflate.zeros(n)
    fh._compress_size += len(out)
    fh._fileobj.write(out)


def _incompressible(data, level) -> bool:
    """Whether 4 evenly spaced samples of ``data`` (NPZ_SAMPLE_BYTES each, deflated as one
    stream) deflate to more than NPZ_STORE_RATIO of their size."""
    n = NPZ_SAMPLE_BYTES
    if data.size < 4 * n:
        return False
    z = zlib.compressobj(level, zlib.DEFLATED, -15)
    packed = sum(len(z.compress(data[s:s + n])) for s in np.linspace(0, data.size - n, 4).astype(np.int64))
    return packed + len(z.flush()) > NPZ_STORE_RATIO * 4 * n
