"""Files in and out.

Writes are atomic (:mod:`refsoft.io.atomic`): every output is written under a temporary name in
the same folder, then renamed, so an interrupted run never leaves a torn file and never damages
an existing one. A frame's ``.npz`` is written by :mod:`refsoft.io.npz` (with
:mod:`~refsoft.io.runs`, :mod:`~refsoft.io.deflate`, :mod:`~refsoft.io.crc` and
:mod:`~refsoft.io.pages`), its PNG by :mod:`refsoft.io.png`; the flat pictures of both (the
image, the id maps) by :mod:`refsoft.io.neighbour`.

Reads (:func:`read_npz`, :func:`read_json`, :mod:`refsoft.io.read`) turn a missing, unreadable or
malformed file into one :class:`~refsoft.errors.InputFileError` whose one-line message names the
file and the problem (the CLI prints it and exits with status 2), never a library's traceback.
"""

from .atomic import atomic_path, remove_temporaries, write_json, write_npz
from .npz import ZIP_DATE, write_npz_level
from .png import write_png, write_png_rows
from .read import inside, one_line, read_json, read_npz

__all__ = ["ZIP_DATE", "atomic_path", "inside", "one_line", "read_json", "read_npz", "remove_temporaries",
           "write_json", "write_npz", "write_npz_level", "write_png", "write_png_rows"]
