"""The ``refsoft`` command's entry point: imports the command line inside the interrupt guard, so
Ctrl-C at any moment, even while Python loads NumPy and Numba, ends with one line and status 130.

The command also pauses Python's cyclic garbage collector for its first seconds (:func:`pause_gc`),
spares its process SciPy (:class:`SkipScipyProbes`), which no refsoft kernel uses, and Numba's
implementation registries while it only loads cached kernels
(:func:`refsoft._numba.load_cached_without_registries`).
"""

import gc
import sys
import threading

#: True in the ``refsoft`` command's own process, from the start of :func:`main`.
COMMAND = False
#: Seconds from the command's start without Python's cyclic garbage collector (:func:`pause_gc`).
GC_PAUSE_SECONDS = 2.0


def pause_gc(seconds: float) -> None:
    """Turn Python's cyclic garbage collector off for ``seconds``, then back on.

    Loading NumPy, Numba and the cached kernels makes hundreds of thousands of long-lived objects:
    the collections they trigger (about 170 in a one-frame render's process) cost 60-80 ms, and
    collect next to nothing. The pause covers the command's start-up and a small render's frame;
    the garbage of a longer pause is bounded by what the process allocates meanwhile. Reference
    counting frees memory as usual throughout; the outputs do not depend on it."""
    if not gc.isenabled():
        return
    gc.disable()
    timer = threading.Timer(seconds, gc.enable)
    timer.daemon = True  # never keeps the process alive
    timer.start()


class SkipScipyProbes:
    """An import finder that refuses SciPy to Numba's two probes of it, and only to them.

    When Numba loads its implementations (with the first kernel a process compiles or loads from
    the cache), ``numba.np.arraymath`` probes for a BLAS by importing ``scipy.linalg.cython_blas``
    when SciPy is installed: 0.15-0.3 s of a one-frame render's process. The probe's answer only
    chooses how ``np.correlate`` and ``np.convolve`` take inner products inside compiled code
    (BLAS or a loop); no refsoft kernel calls either, so their machine code, and every output, is
    the same without it. Numba's import checks, by importing SciPy, that it is at least 1.0, as
    every SciPy for Python 3.10 (refsoft's oldest) is. Any other import of SciPy (``np.dot`` or
    ``np.linalg`` being compiled, the caller's own code) goes through as usual. The command
    installs this finder in its own process only (:func:`main`); ``import refsoft`` leaves Numba
    as it is. Should Numba rename a probe, the finder refuses nothing to it.
    """

    #: (module, function) of each probe whose imports of SciPy are refused; the last runs last.
    PROBES = (("numba", "_ensure_critical_deps"), ("numba.np.arraymath", "_check_blas"))

    @classmethod
    def find_spec(cls, name, path=None, target=None):
        if name != "scipy" and not name.startswith("scipy."):
            return None
        frame = sys._getframe(1)
        while frame is not None:
            probe = (frame.f_globals.get("__name__"), frame.f_code.co_name)
            if probe in cls.PROBES:
                if probe == cls.PROBES[-1]:  # the BLAS probe runs once per process, after the other
                    sys.meta_path.remove(cls)
                raise ModuleNotFoundError(f"No module named {name!r} (refused to Numba's probe)", name=name)
            frame = frame.f_back
        return None

    @classmethod
    def install(cls) -> None:
        """Put the finder first on ``sys.meta_path`` (once), unless Numba has already probed."""
        if cls not in sys.meta_path and "numba.np.arraymath" not in sys.modules:
            sys.meta_path.insert(0, cls)


def main(argv=None) -> int:
    global COMMAND
    from . import interrupt

    COMMAND = True
    pause_gc(GC_PAUSE_SECONDS)
    if not interrupt.installed():
        interrupt.install()
    SkipScipyProbes.install()
    try:
        interrupt.release()
        from .cli import main as cli_main
    except (KeyboardInterrupt, Exception) as exc:
        # an Exception counts when a library turned the interrupt into another error while it imported
        if not isinstance(exc, KeyboardInterrupt) and not interrupt.seen():
            raise
        print(interrupt.MESSAGE, file=sys.stderr)
        return 130
    return cli_main(argv, installed=True)


def run() -> None:
    """``sys.exit(main())``, for ``python -m refsoft`` and the console script."""
    import signal

    try:
        code = main()
    except KeyboardInterrupt:  # between the guard's own steps
        from .interrupt import MESSAGE

        code = 130
        print(MESSAGE, file=sys.stderr)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the work is done: an interrupt now changes nothing
    if code == 130:
        # interrupted: leave at once with that status. An interrupt raised inside some library's
        # C-level call of Python code during its import can leave Python's "unhandled Ctrl-C"
        # mark set, which would turn a normal exit into death by SIGINT (status -2)
        import os

        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    sys.exit(code)
