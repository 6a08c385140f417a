"""Ctrl-C that ends cleanly at any moment.

The command line installs :func:`install`'s handler when the package is imported, and holds a
first interrupt (records it only) until its entry point runs and acts on it. Before compiled code
is loaded (NumPy,
trimesh and the like are importing) an interrupt raises ``KeyboardInterrupt`` at once, as Python's
own handler does, and is recorded too, so one that a library swallows (some catch every exception
while they import) is still seen at the next :func:`check`. Once Numba's compiler is loaded, raising
inside it can leave LLVM half-torn down (an error printed from a finalizer, at worst a crash), so
the interrupt is only recorded: the program stops at its next :func:`check` (between frames, cases,
settings), and if it reaches none within :data:`GRACE_SECONDS` (a long compile), it removes the
files it was writing (:func:`refsoft.io.remove_temporaries`) and leaves with status 130. A second
Ctrl-C raises at once.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
import time

#: How long an interrupt waits for a safe point before the program leaves without one.
GRACE_SECONDS = 2.0
#: The message every interrupted command ends with.
MESSAGE = "refsoft: interrupted"

_seen = False
_previous = None
_held = False


def _handler(signum, frame):
    global _seen
    first = not _seen
    _seen = True
    if not first or ("llvmlite" not in sys.modules and not _held):
        raise KeyboardInterrupt
    threading.Thread(target=_leave_if_stuck, daemon=True).start()


def _leave_if_stuck():
    time.sleep(GRACE_SECONDS)
    from .io import remove_temporaries

    remove_temporaries()
    sys.stderr.write(MESSAGE + "\n")
    sys.stderr.flush()
    os._exit(130)


def install(hold: bool = False) -> None:
    """Install the handler (main thread only; a no-op elsewhere). ``hold``: only record a first
    interrupt until :func:`release` (the command's package import holds it, so that one landing
    while Python still finds and compiles the entry module, outside any code of refsoft's that
    could catch it, is acted on by the entry point instead)."""
    global _previous, _seen, _held
    _seen, _held = False, hold
    try:
        _previous = signal.signal(signal.SIGINT, _handler)
    except ValueError:  # not the main thread
        _previous = None


def release() -> None:
    """End :func:`install`'s hold: an interrupt raises at once again (until compiled code
    loads), and one that arrived during the hold raises ``KeyboardInterrupt`` now."""
    global _held
    _held = False
    check()


def installed() -> bool:
    """Whether the handler is in place."""
    return _previous is not None


def restore() -> None:
    """Put back the handler :func:`install` replaced."""
    global _previous
    if _previous is not None:
        signal.signal(signal.SIGINT, _previous)
        _previous = None


def seen() -> bool:
    """Whether an interrupt arrived since :func:`install`."""
    return _seen


def check() -> None:
    """Raise ``KeyboardInterrupt`` if an interrupt arrived (a safe point)."""
    if _seen:
        raise KeyboardInterrupt
