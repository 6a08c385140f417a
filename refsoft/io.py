"""Files in and out.

Writes are atomic: every output is written under a temporary name in the same folder, then
renamed, so an interrupted run never leaves a torn file and never damages an existing one.

Reads (:func:`read_npz`, :func:`read_json`) turn a missing, unreadable or malformed file into one
:class:`~refsoft.errors.InputFileError` whose one-line message names the file and the problem
(the CLI prints it and exits with status 2), never a library's traceback.
"""

from __future__ import annotations

import bisect
import io
import json
import mmap
import os
import tempfile
import tokenize
import zipfile
import zlib
from contextlib import contextmanager

import numpy as np

from .constants import NPZ_PIECE_BYTES, NPZ_SAMPLE_BYTES, NPZ_STORE_RATIO
from .errors import InputFileError

_ZIP_MAGIC = (b"PK\x03\x04", b"PK\x05\x06")  # a member first, or an empty archive
_NPY_MAGIC = b"\x93NUMPY"
#: What reading a damaged .npz can raise: the zip layer (a missing directory, bad CRC, bad
#: headers, unknown compression), zlib, and NumPy's .npy header parser (ast/tokenize) and reader.
_NPZ_ERRORS = (zipfile.BadZipFile, zlib.error, NotImplementedError, ValueError, EOFError, KeyError, SyntaxError,
               tokenize.TokenError, OverflowError, MemoryError)


#: Temporary files being written (removed by :func:`remove_temporaries` on a hard exit).
_ACTIVE = set()


@contextmanager
def atomic_path(path, suffix=""):
    """Yield a temporary path next to ``path``; rename it to ``path`` if the block succeeds."""
    path = os.fspath(path)
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(path) + ".", suffix=".tmp" + suffix, dir=folder)
    _ACTIVE.add(tmp)
    os.close(fd)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; outputs get the usual permissions
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
        _ACTIVE.discard(tmp)


def remove_temporaries() -> None:
    """Remove the temporary files of writes in progress (before leaving without finishing them)."""
    for tmp in list(_ACTIVE):
        try:
            os.unlink(tmp)
        except OSError:
            pass


def write_npz(path, **arrays):
    """``np.savez_compressed`` to ``path`` atomically (zlib's default level, 6)."""
    with atomic_path(path, ".npz") as tmp:
        np.savez_compressed(tmp, **arrays)


def write_npz_level(path, arrays, level: int):
    """Write ``arrays`` as an ``.npz`` to ``path`` atomically, deflated at zlib ``level`` (0-9).

    The archive is the one ``np.savez_compressed`` writes (one ``NAME.npy`` member per array, in
    order, zip64 members, the ``.npy`` header NumPy writes) but for how each member's bytes are
    compressed, so ``np.load`` reads the same arrays bit for bit:

    - a member is deflated in pieces of :data:`~refsoft.constants.NPZ_PIECE_BYTES`; a piece of
      zero bytes only (most of a G-buffer) is written as zlib's output for that many zeros after
      a full flush, computed once (:func:`_zero_piece`), instead of being compressed again;
    - a member whose samples deflate to more than :data:`~refsoft.constants.NPZ_STORE_RATIO` of
      their size (high-entropy floats) is stored uncompressed;
    - a zero piece's CRC-32 is combined by zlib (``crc32_combine64``) from that of zeros, and a
      piece whose pages were never touched (an anonymous mapping's, as
      :func:`refsoft.limits.zeros` makes them; :class:`_PageMap`) is not read at all.

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
    pages = _PageMap()
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
            deflate = fh._compressor = _PieceDeflate(level, zlib.Z_RLE if floats else zlib.Z_DEFAULT_STRATEGY)
        fh.write(header)
        # a zero piece bypasses the member writer (when it has the state this module knows):
        # its CRC-32 is combined from that of zeros, not computed over its bytes again
        direct = deflate is not None and all(hasattr(fh, a) for a in _WRITER_STATE)
        if direct:
            deflate.check = False
        for lo in range(0, data.size, NPZ_PIECE_BYTES):
            piece = data[lo:lo + NPZ_PIECE_BYTES]
            if direct and (_untouched_piece(unread, lo, piece.size) or _zero_bytes(piece)):
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
    fh._crc = _crc_after_zeros(fh._crc, piece)
    out = deflate.zeros(n)
    fh._compress_size += len(out)
    fh._fileobj.write(out)


def _zero_bytes(piece) -> bool:
    """Whether (n,) uint8 ``piece`` is zero bytes only (the bytes, not the values: -0.0 is not)."""
    words = piece.view(np.uint64) if piece.size % 8 == 0 else piece
    return piece.size > 0 and not words.max()


def _untouched_piece(unread, lo: int, n: int) -> bool:
    """Whether bytes ``lo:lo + n`` of an array lie in pages never touched (``unread``: what
    :meth:`_PageMap.untouched` said of the array, or None)."""
    if unread is None or n == 0:
        return False
    addr, flags = unread
    first = addr // _PAGE
    return bool(flags[(addr + lo) // _PAGE - first:(addr + lo + n - 1) // _PAGE - first + 1].all())


_PAGE = mmap.PAGESIZE


class _PageMap:
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
        first = addr // _PAGE
        n = (addr + data.size - 1) // _PAGE - first + 1
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


_ZERO_CRCS = {}
_COMBINE = []  # [zlib's crc32_combine64 or None], looked up at the first zero piece


def _crc_after_zeros(crc: int, piece) -> int:
    """``zlib.crc32(piece, crc)`` for a piece of zero bytes: zlib's ``crc32_combine64`` of ``crc``
    and the CRC-32 of that many zeros (computed once per size), without reading the piece; where
    the C library is not found, ``zlib.crc32`` itself."""
    if not _COMBINE:
        _COMBINE.append(_crc32_combine())
    combine, n = _COMBINE[0], piece.size
    if combine is None:
        return zlib.crc32(piece, crc)
    zeros = _ZERO_CRCS.get(n)
    if zeros is None:
        zeros = _ZERO_CRCS[n] = zlib.crc32(bytes(n))
    return combine(crc, zeros, n)


def _crc32_combine():
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


def _incompressible(data, level) -> bool:
    """Whether 4 evenly spaced samples of ``data`` (NPZ_SAMPLE_BYTES each, deflated as one
    stream) deflate to more than NPZ_STORE_RATIO of their size."""
    n = NPZ_SAMPLE_BYTES
    if data.size < 4 * n:
        return False
    z = zlib.compressobj(level, zlib.DEFLATED, -15)
    packed = sum(len(z.compress(data[s:s + n])) for s in np.linspace(0, data.size - n, 4).astype(np.int64))
    return packed + len(z.flush()) > NPZ_STORE_RATIO * 4 * n


_ZERO_PIECES = {}


def _zero_piece(n: int, level: int) -> bytes:
    """zlib's raw deflate output for ``n`` zero bytes followed by a full flush, from a fresh
    compressor: it refers to nothing before it and ends on a byte boundary, so it can follow any
    full flush of another stream (computed once per size and level)."""
    key = (n, level)
    piece = _ZERO_PIECES.get(key)
    if piece is None:
        z = zlib.compressobj(level, zlib.DEFLATED, -15)
        piece = _ZERO_PIECES[key] = z.compress(bytes(n)) + z.flush(zlib.Z_FULL_FLUSH)
    return piece


class _PieceDeflate:
    """A raw deflate stream (what zipfile's ZIP_DEFLATED compressor writes) fed in pieces: a piece
    of zero bytes only ends the stream's open block with a full flush (after which zlib refers
    to nothing earlier) and is written as :func:`_zero_piece` (:meth:`zeros`); any other piece
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
            if _zero_bytes(piece):
                return self.zeros(piece.size)
        self._open = True
        return self._z.compress(data)

    def zeros(self, n: int) -> bytes:
        """The deflate output of ``n`` zero bytes, after the stream's open block."""
        out = self._z.flush(zlib.Z_FULL_FLUSH) if self._open else b""
        self._open = False
        return out + _zero_piece(n, self._level)

    def flush(self) -> bytes:
        return self._z.flush()


def write_png(path, image, level=None):
    """Write an (H, W, 3) or (H, W) uint8 image as PNG atomically (Pillow's encoder, which
    imageio also writes through, without loading imageio's plugin machinery), at zlib ``level``
    (default: Pillow's, 6)."""
    from PIL import Image

    extra = {} if level is None else {"compress_level": int(level)}
    with atomic_path(path, ".png") as tmp:
        Image.fromarray(np.ascontiguousarray(image, dtype=np.uint8)).save(tmp, format="PNG", **extra)


def write_png_rows(path, image, level: int):
    """Write an (H, W, 3) or (H, W) uint8 image as PNG atomically, its rows unfiltered (PNG's filter
    type 0) and deflated by zlib at ``level``, in the three chunks a PNG needs (IHDR, IDAT, IEND,
    each with its zlib.crc32).

    A run's frames are written this way (:func:`refsoft.frame.outputs.write_frame`): Pillow chooses
    a filter for every row, most of its encoder's time, which it does not let a caller turn off;
    a rendered frame, flat-shaded, deflates about as well unfiltered, for less than half the CPU
    time (docs/benchmarks.md). Any PNG reader decodes it to the same pixels.

    Raises
    ------
    RefsoftError
        ``image`` is not uint8, (H, W) or (H, W, 3) with H, W >= 1.
    """
    import struct

    from .errors import RefsoftError

    img = np.asarray(image)
    if img.dtype != np.uint8 or not (img.ndim == 2 or (img.ndim == 3 and img.shape[2] == 3)) or 0 in img.shape[:2]:
        raise RefsoftError(f"a PNG needs an (H, W) or (H, W, 3) uint8 image with H, W >= 1, got {img.dtype} {img.shape}")
    h, w = img.shape[:2]
    rows = np.zeros((h, 1 + img[0].size), np.uint8)  # each row: its filter type (0), its bytes
    rows[:, 1:] = img.reshape(h, -1)
    data = zlib.compress(rows, level)

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


def write_json(path, data):
    """Write JSON (indented, keys in order) atomically."""
    with atomic_path(path) as tmp:
        with open(tmp, "w") as fh:
            json.dump(data, fh, indent=1)
            fh.write("\n")


def inside(path, folder) -> bool:
    """Whether ``path`` is ``folder`` or lies inside it (symbolic links resolved)."""
    p, f = os.path.realpath(path), os.path.realpath(folder)
    try:
        return os.path.commonpath([p, f]) == f
    except ValueError:  # different drives
        return False


def one_line(text, limit: int = 200) -> str:
    """``text`` as one printable line of at most ``limit`` characters (for messages quoting a
    damaged file: control characters escaped, whitespace runs collapsed)."""
    text = "".join(ch if ch.isprintable() else repr(ch)[1:-1] for ch in " ".join(str(text).split()))
    return text if len(text) <= limit else text[:limit - 3] + "..."


def _open_problem(path, exc: OSError) -> str:
    if isinstance(exc, FileNotFoundError):
        return "no such file"
    if isinstance(exc, IsADirectoryError) or os.path.isdir(path):
        return "is a folder, not a file"
    return f"cannot read: {one_line(exc.strerror or exc)}"


def _head(path, n: int = 8) -> bytes:
    try:
        with open(path, "rb") as fh:
            return fh.read(n)
    except OSError as exc:
        raise InputFileError(f"{path}: {_open_problem(path, exc)}") from None


def read_npz(path, required=()) -> dict:
    """Every array of an ``.npz`` file, read eagerly and without pickles.

    Parameters
    ----------
    path : str or PathLike
    required : iterable of str
        Keys the file must hold.

    Returns
    -------
    dict of str to ndarray

    Raises
    ------
    InputFileError
        The file is missing, is not an ``.npz`` archive (a single ``.npy`` array, random bytes),
        is truncated or damaged (no zip directory, a CRC or decompression error, a malformed
        ``.npy`` header), holds an object array or a member that is not an array, or lacks one
        of ``required``.
    """
    path = os.fspath(path)
    head = _head(path)
    if not head:
        raise InputFileError(f"{path}: empty file, not an .npz archive")
    if head.startswith(_NPY_MAGIC):
        raise InputFileError(f"{path}: a single .npy array, not an .npz archive of named arrays")
    if not head.startswith(_ZIP_MAGIC):
        raise InputFileError(f"{path}: not an .npz file (it does not begin as a zip archive)")
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
    except OSError as exc:
        raise InputFileError(f"{path}: {_open_problem(path, exc)}") from None
    except zipfile.BadZipFile as exc:
        what = "its zip directory is missing" if str(exc) == "File is not a zip file" else one_line(exc)
        raise InputFileError(f"{path}: truncated or damaged .npz archive ({what}; "
                             f"{os.path.getsize(path)} bytes)") from None
    except _NPZ_ERRORS as exc:
        if isinstance(exc, ValueError) and "allow_pickle" in str(exc):
            raise InputFileError(f"{path}: holds an object (pickled) array, which refsoft never loads") from None
        what = one_line(exc) or type(exc).__name__
        raise InputFileError(f"{path}: damaged .npz archive ({type(exc).__name__}: {what})") from None
    for k, v in arrays.items():
        if not isinstance(v, np.ndarray):
            raise InputFileError(f"{path}: member {one_line(k, 60)!r} is not a .npy array")
    missing = [k for k in required if k not in arrays]
    if missing:
        raise InputFileError(f"{path}: lacks {', '.join(missing)}")
    return arrays


def read_json(path, format=None, required=()):
    """The content of a JSON file.

    Parameters
    ----------
    path : str or PathLike
    format : str, optional
        The ``"format"`` the file must declare (e.g. ``"refsoft-golden-1"``).
    required : iterable of str
        Top-level keys the file must hold.

    Returns
    -------
    object
        A dict when ``format`` or ``required`` is given.

    Raises
    ------
    InputFileError
        The file is missing or unreadable, not UTF-8, not JSON (the message gives line and
        column), not an object when one is needed, of another format, or lacks a required key.
    """
    path = os.fspath(path)
    try:
        with open(path, encoding="utf-8") as fh:
            data = json.load(fh)
    except OSError as exc:
        raise InputFileError(f"{path}: {_open_problem(path, exc)}") from None
    except UnicodeDecodeError:
        raise InputFileError(f"{path}: not UTF-8 text, so not a JSON file") from None
    except json.JSONDecodeError as exc:
        raise InputFileError(f"{path}: not valid JSON ({exc.msg} at line {exc.lineno} column {exc.colno})") from None
    except ValueError as exc:  # e.g. an integer beyond Python's digit limit
        raise InputFileError(f"{path}: not valid JSON ({one_line(exc)})") from None
    except RecursionError:
        raise InputFileError(f"{path}: JSON nested too deeply to read") from None
    required = tuple(required)
    if format is None and not required:
        return data
    if not isinstance(data, dict):
        raise InputFileError(f"{path}: not a JSON object (a {type(data).__name__})")
    if format is not None and data.get("format") != format:
        raise InputFileError(f"{path}: not a {format} file (format {one_line(repr(data.get('format')), 60)})")
    missing = [k for k in required if k not in data]
    if missing:
        raise InputFileError(f"{path}: lacks the key{'s' if len(missing) > 1 else ''} "
                             f"{', '.join(repr(k) for k in missing)}")
    return data
