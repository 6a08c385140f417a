"""Reads: a missing, unreadable or malformed file becomes one
:class:`~refsoft.errors.InputFileError` whose one-line message names the file and the problem
(the CLI prints it and exits with status 2), never a library's traceback."""

from __future__ import annotations

import json
import os
import tokenize
import zipfile
import zlib

import numpy as np

from ..errors import InputFileError

_ZIP_MAGIC = (b"PK\x03\x04", b"PK\x05\x06")  # a member first, or an empty archive
_NPY_MAGIC = b"\x93NUMPY"
#: What reading a damaged .npz can raise: the zip layer (a missing directory, bad CRC, bad
#: headers, unknown compression), zlib, and NumPy's .npy header parser (ast/tokenize) and reader.
_NPZ_ERRORS = (zipfile.BadZipFile, zlib.error, NotImplementedError, ValueError, EOFError, KeyError, SyntaxError,
               tokenize.TokenError, OverflowError, MemoryError)


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
