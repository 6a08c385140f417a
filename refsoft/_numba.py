"""Shared Numba settings: every kernel is compiled with these flags (spec section 2)."""

import os
import sys
from contextlib import contextmanager

import numba
import numba.core.cpu as numba_cpu  # (loaded by numba itself)
import numpy as np
from numba import types
from numba.extending import overload

#: fastmath=False: no reassociation, no FMA contraction. error_model="numpy": inf/NaN like a GPU.
KERNEL_OPTIONS = dict(cache=True, fastmath=False, error_model="numpy", nogil=True)
if hasattr(numba_cpu.CPUTargetOptions, "no_cfunc_wrapper"):
    # kernels are called from Python (through their CPython wrapper) and from each other, never as
    # C function pointers: the C wrapper Numba compiles beside each one by default is left out
    # (3 % of a first run's compile time)
    KERNEL_OPTIONS["no_cfunc_wrapper"] = True

#: Every dispatcher made by :func:`kernel`, in definition order (see :func:`specialisations`).
KERNELS = []


def kernel(fn=None, *, inline=False, llvm_inline=False):
    """``numba.njit`` with refsoft's fixed options (``inline=True`` inlines a small helper into its
    callers at Numba's level; ``llvm_inline=True`` compiles it on its own and has LLVM inline its
    machine code into every caller).

    Kernels have no parallel loops: a loop run on several threads is a kernel over a range of
    iterations, called by :func:`refsoft._parallel.parallel_range` (Numba's parallel lowering
    would compile the loop's body a second time)."""

    def wrap(f):
        extra = {"inline": "always"} if inline else {}
        if llvm_inline:
            extra["forceinline"] = True
        dispatcher = numba.njit(**KERNEL_OPTIONS, **extra)(f)
        dispatcher.compile = _compile_once(dispatcher, dispatcher.compile)
        KERNELS.append(dispatcher)
        return dispatcher

    return wrap(fn) if fn is not None else wrap


def _compile_once(dispatcher, compile_):
    """``dispatcher.compile`` behind a lock file that every process on the machine shares: while
    one process compiles a kernel, another that needs it waits, then loads it from Numba's cache
    (``compile`` looks there first) instead of compiling it again. The first run's second process
    (:mod:`refsoft._warmup`) and the command compile different kernels at the same time so; two
    test processes never compile one kernel twice. Numba's own compiler lock is taken first, so
    the threads of one process wait for each other there and never hold a lock file while another
    thread of theirs waits for it."""
    from numba.core import sigutils
    from numba.core.compiler_lock import global_compiler_lock

    def compile(sig):
        args, _ = sigutils.normalize_signature(sig)
        if tuple(args) in dispatcher.overloads:  # compiled or loaded in this process already
            return compile_(sig)
        with global_compiler_lock, _lock_file(dispatcher):
            return compile_(sig)

    return compile


@contextmanager
def _lock_file(dispatcher):
    """An exclusive ``flock`` on the kernel's lock file beside its cache files (none when the
    cache folder cannot be written: the kernel is then compiled without waiting for anyone).
    The operating system releases it when the process ends, whatever the way."""
    import fcntl

    f = dispatcher.py_func
    folder = getattr(getattr(dispatcher, "_cache", None), "_cache_path", None)
    try:
        os.makedirs(folder, exist_ok=True)
        fd = os.open(os.path.join(folder, f"{f.__qualname__}-{f.__code__.co_firstlineno}.lock"),
                     os.O_RDWR | os.O_CREAT, 0o666)
    except (OSError, TypeError):
        yield
        return
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)  # releases the lock


def readonly(a: np.ndarray) -> np.ndarray:
    """``a`` as a read-only array (a view when it is writable; no copy). Numba compiles a kernel
    once for writable and once for read-only arrays of the same type: a kernel whose callers pass
    both (a mesh's frozen arrays, arrays just computed) is given read-only views by its wrapper,
    one specialisation instead of two."""
    if a.flags.writeable:
        a = a.view()
        a.flags.writeable = False
    return a


def like(value, prototype):
    """``value`` converted to the float type of ``prototype`` (a float32 or float64 scalar).

    Kernels take ``fp``, a scalar of the working precision (``np.float32(0)`` or
    ``np.float64(0)``), and write their float constants as ``like(2.0, fp)``; the conversion is
    resolved when the kernel is compiled (no call at run time), unlike a function passed as an
    argument."""
    return type(prototype)(value)


@overload(like, inline="always")
def _like_impl(value, prototype):
    if prototype == types.float32:
        return lambda value, prototype: np.float32(value)
    if prototype == types.float64:
        return lambda value, prototype: np.float64(value)
    return None


def kernels_cached(minimum: int = 20) -> bool:
    """Whether Numba's cache already holds compiled kernels of refsoft (at least ``minimum``
    index files under the package's ``__pycache__`` folders, or under ``$NUMBA_CACHE_DIR``):
    False on a first run, which compiles them (tens of seconds)."""
    import glob

    root = os.environ.get("NUMBA_CACHE_DIR") or os.path.dirname(os.path.abspath(__file__))
    return len(glob.glob(os.path.join(root, "**", "*.nbi"), recursive=True)) >= minimum


def specialisations() -> dict:
    """The specialisations of refsoft's kernels in this process: kernel name (``module.function``)
    -> {signature (tuple of Numba types): ``"loaded"`` from Numba's cache or ``"compiled"``}, for
    the kernels called at least once. A kernel loaded from the cache carries the helpers it calls
    in its own machine code: they appear only where they were compiled; a helper inlined at
    Numba's level never has a specialisation of its own."""
    out = {}
    for d in KERNELS:
        hits = d.stats.cache_hits
        for sig in d.signatures:
            name = f"{d.py_func.__module__}.{d.py_func.__name__}"
            out.setdefault(name, {})[sig] = "loaded" if hits.get(sig) else "compiled"
    return out


def _report_compiles():
    """``REFSOFT_COMPILE_REPORT=1``: at exit, the seconds each kernel took to compile in this
    process (its own time: the helpers it compiled on the way are counted apart; wall and CPU
    time of the compiling thread) and how many specialisations were loaded from the cache, on
    stderr, slowest first."""
    import atexit
    import sys
    import time

    from numba.core import event

    spent, stack = {}, []

    class _Listener(event.Listener):
        def on_start(self, ev):
            f = ev.data["dispatcher"].py_func
            stack.append([f"{f.__module__}.{f.__qualname__}", time.perf_counter(), time.thread_time(), 0.0, 0.0])

        def on_end(self, ev):
            name, t0, c0, child_t, child_c = stack.pop()
            dt, dc = time.perf_counter() - t0, time.thread_time() - c0
            row = spent.setdefault(name, [0, 0.0, 0.0])
            row[0] += 1
            row[1] += dt - child_t
            row[2] += dc - child_c
            if stack:
                stack[-1][3] += dt
                stack[-1][4] += dc

    def report():
        loaded = sum(v == "loaded" for sigs in specialisations().values() for v in sigs.values())
        rows = sorted(spent.items(), key=lambda kv: -kv[1][2])
        print(f"refsoft: compiled {sum(r[0] for _, r in rows)} specialisations in "
              f"{sum(r[1] for _, r in rows):.1f} s ({sum(r[2] for _, r in rows):.1f} s CPU); "
              f"loaded {loaded} from the cache", file=sys.stderr)
        for name, (n, wall, cpu) in rows:
            print(f"  {name:64s} {n:3d} {wall:7.2f} s {cpu:7.2f} s CPU", file=sys.stderr)

    event.register("numba:compile", _Listener())
    atexit.register(report)


def load_cached_without_registries() -> bool:
    """Load kernels from Numba's cache without first loading Numba's implementation registries.

    Before it loads a cached kernel, Numba "refreshes" its target: it imports and registers the
    implementations of every Python and NumPy feature it can compile (``numba.cpython``,
    ``numba.np`` and more: 0.3-0.5 s of a one-frame render's process). Loading machine code
    needs none of them, only Numba's runtime (the arrays' memory management), which is
    initialised here as the refresh would. A process that later compiles a kernel refreshes then
    (Numba's compiler does so before it compiles anything), so nothing is missing when it is
    needed; the machine code, the same bytes from the same cache, and every output are unchanged.
    The command turns this on in its own process only (:mod:`refsoft._start`); ``import
    refsoft`` leaves Numba as it is. Returns whether it is on (False when this Numba's cache no
    longer has the methods it relies on: Numba then works as usual)."""
    from numba.core import caching

    cache = caching.Cache
    if getattr(cache.load_overload, "_refsoft", False):
        return True
    try:
        from numba.core.runtime import rtsys
    except ImportError:
        return False
    if not (hasattr(cache, "_guard_against_spurious_io_errors") and hasattr(cache, "_load_overload")
            and hasattr(rtsys, "initialize")):
        return False

    def load_overload(self, sig, target_context):
        rtsys.initialize(target_context)
        with self._guard_against_spurious_io_errors():
            return self._load_overload(sig, target_context)

    load_overload._refsoft = True
    cache.load_overload = load_overload
    return True


if getattr(sys.modules.get("refsoft._start"), "COMMAND", False):
    load_cached_without_registries()

if os.environ.get("REFSOFT_COMPILE_REPORT"):
    _report_compiles()
