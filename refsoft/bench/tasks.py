"""A small runner of independent tasks, serially in this process or on a Dask cluster, with
every result stored as soon as it is done.

A :class:`Task` is a module-level function with its arguments and a *key*: a JSON-able dict of
everything that determines the result (scene, frames, options, size, ...). The runner adds
:func:`identity` (the refsoft version, a digest of refsoft's own source files, the NumPy and
Numba versions) to the key, hashes it, and stores the
result under ``STORE/<hash>.npz`` (written under a temporary name, then renamed: an interrupted
run leaves whole files only). A later run with the same store computes only the tasks whose
result is missing (or, with ``fresh``, every task) and reports how many it reused.

Schedulers:

- ``"serial"``: one task after another in this process (no Dask import);
- ``"local"``: a ``dask.distributed.LocalCluster`` on this machine, ``workers`` processes of one
  thread each;
- ``"tcp://HOST:PORT"``: an existing Dask scheduler and its workers (their refsoft, NumPy and
  Numba must be the client's: the runner compares versions and source digests before it
  submits anything).

Timings stay honest on a shared machine: a worker runs one task at a time, and each task sets
Numba's thread count to its worker's share of the cores it may run on (the cores divided by the
workers sharing them), so tasks running at once never ask for more threads than there are cores.
Tasks that time something (``Task.timing``) need one thread per worker and at most one worker per
core: a local cluster is capped at the cores, a remote one is refused otherwise.
"""

from __future__ import annotations

import hashlib
import json
import os
import socket
import sys
import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..errors import RefsoftError

#: Seconds to wait for a remote scheduler (and its first worker) before giving up.
CONNECT_TIMEOUT = 10.0
#: How often (s) the client looks at its tasks and at the interrupt flag.
POLL_SECONDS = 0.05
#: How long closing the client or a local cluster may take before it is left to end with this process.
CLOSE_SECONDS = 15.0
#: Layout of a stored result.
STORE_FORMAT = "refsoft-task-1"

#: This worker process's Numba thread count (set by the client through ``Client.run``).
_SHARE = None


@dataclass(frozen=True)
class Task:
    """One independent piece of work.

    Parameters
    ----------
    key : dict
        JSON-able: everything that determines the result (the runner adds the refsoft version
        and source digest).
    fn : callable
        A module-level function (a Dask worker imports it by name), returning a dict whose
        values are JSON-able or NumPy arrays (not of objects).
    args : tuple
    kwargs : dict
    timing : bool
        The task times something: it needs a whole worker of one thread.
    label : str
        What the progress lines and errors call it.
    """

    key: dict
    fn: Callable
    args: tuple = ()
    kwargs: dict = field(default_factory=dict)
    timing: bool = False
    label: str = ""


@dataclass
class RunReport:
    """What :func:`run_tasks` did.

    ``results`` (in task order), ``reused`` (from the store) and ``computed`` counts, and per
    task ``meta``: ``{"seconds", "host", "threads", "reused"}`` (seconds: the task's own run time
    where it was computed, the stored one for a reused task)."""

    scheduler: str
    workers: int
    threads: int | None
    results: list
    meta: list
    reused: int = 0
    computed: int = 0
    dashboard: str | None = None
    seconds: float = 0.0
    labels: list = field(default_factory=list)

    def line(self) -> str:
        """One line: how many tasks, reused, computed, and where."""
        where = {"serial": "in this process", "local": f"on {self.workers} local Dask workers"}.get(
            self.scheduler, f"on {self.workers} Dask workers at {self.scheduler}")
        if self.threads and self.scheduler != "serial":
            where += f" ({self.threads} thread{'s' if self.threads > 1 else ''} each)"
        return (f"{len(self.results)} tasks: {self.reused} reused, {self.computed} computed"
                + (f" {where}" if self.computed else ""))


def check_scheduler(text) -> str:
    """``text`` if it names a scheduler (``serial``, ``local``, ``tcp://HOST:PORT``)."""
    if text in ("serial", "local"):
        return text
    if isinstance(text, str) and text.startswith("tcp://"):
        host, _, port = text[len("tcp://"):].rpartition(":")
        if host and port.isdigit() and 0 < int(port) < 65536:
            return text
    raise RefsoftError(f"--scheduler takes serial, local or tcp://HOST:PORT, got {text!r}")


def dask_available() -> bool:
    """Whether ``dask.distributed`` can be imported (without importing it)."""
    import importlib.util

    return importlib.util.find_spec("distributed") is not None


def cores() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


_CODE = None


def code_digest() -> str:
    """SHA-256 of refsoft's Python sources (their paths and contents): results computed by other
    code are not reused."""
    global _CODE
    if _CODE is None:
        root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
        h = hashlib.sha256()
        for folder, dirs, files in sorted(os.walk(root)):
            dirs[:] = sorted(d for d in dirs if d != "__pycache__")
            for name in sorted(f for f in files if f.endswith(".py")):
                p = os.path.join(folder, name)
                h.update(os.path.relpath(p, root).replace(os.sep, "/").encode() + b"\0")
                with open(p, "rb") as fh:
                    h.update(fh.read() + b"\0")
        _CODE = h.hexdigest()
    return _CODE


def identity() -> dict:
    """What computes: refsoft's version and source digest, and the NumPy and Numba versions
    (other versions may round differently)."""
    import numba

    from .. import __version__

    return {"refsoft": __version__, "code": code_digest(), "numpy": np.__version__, "numba": numba.__version__}


def _plain(value):
    """``value`` as JSON types (tuples as lists, NumPy scalars as Python numbers)."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    raise TypeError(f"not JSON-able: {type(value).__name__}")


def task_digest(task: Task, ident: dict) -> str:
    """The hex SHA-256 of a task's key with the computing refsoft's identity."""
    text = json.dumps({"key": _plain(task.key), **ident}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()


def _split(result) -> tuple[dict, dict]:
    """A task's result as (JSON part, arrays), the JSON part round-tripped so that a computed
    result equals a stored one exactly."""
    if not isinstance(result, dict):
        raise TypeError(f"a task must return a dict, got {type(result).__name__}")
    arrays = {k: v for k, v in result.items() if isinstance(v, np.ndarray)}
    for k, v in arrays.items():
        if v.dtype == object:
            raise TypeError(f"task result {k!r}: object arrays are not stored")
    plain = json.loads(json.dumps(_plain({k: v for k, v in result.items() if k not in arrays})))
    return plain, arrays


class Store:
    """Results of tasks in a folder, one ``<digest>.npz`` each (JSON in member ``_doc``, arrays
    as ``a0``, ``a1``, ...)."""

    def __init__(self, folder):
        self.folder = os.fspath(folder)

    def remove_temporaries(self) -> None:
        """Remove what a killed run was writing (``.NAME.tmp*`` files: never read as results)."""
        if not os.path.isdir(self.folder):
            return
        for name in os.listdir(self.folder):
            if name.startswith(".") and ".tmp" in name:
                try:
                    os.unlink(os.path.join(self.folder, name))
                except OSError:
                    pass

    def path(self, digest: str) -> str:
        return os.path.join(self.folder, digest[:40] + ".npz")

    def get(self, digest: str):
        """``(result, meta)`` stored for ``digest``, or None (missing, damaged, or another key)."""
        from ..io import read_npz

        p = self.path(digest)
        if not os.path.isfile(p):
            return None
        try:
            z = read_npz(p, required=("_doc",))
            doc = json.loads(z["_doc"].tobytes().decode())
            if doc.get("format") != STORE_FORMAT or doc.get("digest") != digest:
                return None
            result = dict(doc["result"])
            result.update({name: z[f"a{i}"] for i, name in enumerate(doc["arrays"])})
            return result, doc["meta"]
        except (RefsoftError, ValueError, KeyError, TypeError, UnicodeDecodeError):
            return None  # damaged: computed again and overwritten

    def put(self, digest: str, key: dict, plain: dict, arrays: dict, meta: dict) -> None:
        from ..io import write_npz

        doc = {"format": STORE_FORMAT, "digest": digest, "key": _plain(key), "meta": meta, "result": plain,
               "arrays": list(arrays)}
        members = {f"a{i}": v for i, v in enumerate(arrays.values())}
        members["_doc"] = np.frombuffer(json.dumps(doc).encode(), dtype=np.uint8)
        write_npz(self.path(digest), **members)


def _threads():
    nb = sys.modules.get("numba")
    return int(nb.get_num_threads()) if nb is not None else None


def _execute(fn, args, kwargs):
    """Run one task where it was sent (a Dask worker, or this process): ``(plain, arrays, meta)``."""
    if _SHARE is not None:
        import numba

        numba.set_num_threads(max(1, min(_SHARE, numba.config.NUMBA_NUM_THREADS)))
    t0 = time.perf_counter()
    result = fn(*args, **kwargs)
    seconds = time.perf_counter() - t0
    plain, arrays = _split(result)
    return plain, arrays, {"seconds": seconds, "host": socket.gethostname(), "threads": _threads()}


def _set_share(threads):
    """On a worker: the Numba threads its tasks use."""
    global _SHARE
    _SHARE = threads


def _worker_facts():
    """On a worker: who computes, and on which cores."""
    try:
        affinity = sorted(os.sched_getaffinity(0))
    except AttributeError:
        affinity = list(range(os.cpu_count() or 1))
    return {**identity(), "host": socket.gethostname(), "affinity": affinity,
            "malloc_trim": os.environ.get("MALLOC_TRIM_THRESHOLD_")}


class _Progress:
    """A tqdm bar over tasks on a terminal, else (a log) a line every tenth of the run."""

    def __init__(self, total, desc, enabled):
        self.total, self.desc, self.n, self.bar, self.every = total, desc, 0, None, 0
        self.t0 = time.perf_counter()
        if not enabled or total < 1:
            return
        if sys.stderr.isatty():
            from tqdm import tqdm

            self.bar = tqdm(total=total, desc=desc, unit="task")
        else:
            self.every = max(1, -(-total // 10))

    def update(self):
        self.n += 1
        if self.bar is not None:
            self.bar.update(1)
        elif self.every and (self.n % self.every == 0 or self.n == self.total):
            print(f"{self.desc}: {self.n}/{self.total} tasks ({100 * self.n // self.total}%), "
                  f"{time.perf_counter() - self.t0:.1f} s", file=sys.stderr, flush=True)

    def close(self):
        if self.bar is not None:
            self.bar.close()


def run_tasks(tasks, scheduler="serial", workers=None, store=None, progress=False, desc="tasks", fresh=False,
              connect_timeout=CONNECT_TIMEOUT, on_result=None) -> RunReport:
    """Run ``tasks``, reusing the stored results of earlier runs; returns a :class:`RunReport`.

    Parameters
    ----------
    tasks : list of Task
    scheduler : {"serial", "local"} or str
        Or ``"tcp://HOST:PORT"`` (module docstring).
    workers : int, optional
        Local cluster only: worker processes (default: the cores; with timing tasks at most the
        cores).
    store : str or PathLike, optional
        Folder of stored results (default: none, nothing reused).
    progress : bool
        A start line on stderr (tasks, reused, where, the dashboard) and a progress bar.
    desc : str
        The progress lines' name.
    fresh : bool
        Compute every task again (their stored results are overwritten).
    connect_timeout : float
        Seconds to wait for a remote scheduler and its first worker.
    on_result : callable, optional
        ``on_result(index, result)`` as each result arrives (reused ones first).

    Raises
    ------
    RefsoftError
        A bad scheduler or worker count, Dask missing, an unreachable scheduler, workers with
        another refsoft, or (timing tasks) workers of several threads or more workers than cores;
        all before any task runs.
    """
    scheduler = check_scheduler(scheduler)
    if workers is not None:
        if scheduler != "local":
            raise RefsoftError("--workers is for --scheduler local")
        if not isinstance(workers, int) or isinstance(workers, bool) or workers < 1:
            raise RefsoftError(f"--workers must be at least 1, got {workers!r}")
    if not connect_timeout > 0:
        raise RefsoftError(f"--connect-timeout must be positive, got {connect_timeout!r}")
    if scheduler != "serial" and not dask_available():
        raise RefsoftError(f"--scheduler {scheduler} needs Dask: pip install 'refsoft[dask]' (or give --scheduler "
                           "serial)")
    tasks = list(tasks)
    ident = identity()
    digests = [task_digest(t, ident) for t in tasks]
    st = Store(store) if store is not None else None
    if st is not None:
        st.remove_temporaries()  # the store belongs to this run (as the output folder does)
    results, meta = [None] * len(tasks), [None] * len(tasks)
    todo = []
    for i, d in enumerate(digests):
        got = None if (st is None or fresh) else st.get(d)
        if got is None:
            todo.append(i)
        else:
            results[i], meta[i] = got[0], dict(got[1], reused=True)
            if on_result is not None:
                on_result(i, results[i])
    timing = any(tasks[i].timing for i in todo)
    report = RunReport(scheduler, 1, None, results, meta, reused=len(tasks) - len(todo),
                       labels=[t.label or json.dumps(_plain(t.key), sort_keys=True) for t in tasks])
    t0 = time.perf_counter()

    def finish(i, plain, arrays, m):
        if st is not None:
            st.put(digests[i], tasks[i].key, plain, arrays, m)
        results[i], meta[i] = dict(plain, **arrays), dict(m, reused=False)
        report.computed += 1
        if on_result is not None:
            on_result(i, results[i])

    if not todo:
        if progress:
            print(f"{desc}: {report.line()}", file=sys.stderr, flush=True)
    elif scheduler == "serial":
        report.threads = _threads()
        _run_serial(tasks, todo, finish, progress, desc, report)
    else:
        _run_dask(tasks, todo, digests, finish, scheduler, workers, timing, connect_timeout, progress, desc, report)
    report.seconds = time.perf_counter() - t0
    return report


def _run_serial(tasks, todo, finish, progress, desc, report):
    from .. import interrupt

    if progress:
        print(f"{desc}: {len(tasks)} tasks: {report.reused} reused, {len(todo)} to compute in this process",
              file=sys.stderr, flush=True)
    bar = _Progress(len(todo), desc, progress)
    try:
        for i in todo:
            interrupt.check()
            t = tasks[i]
            finish(i, *_execute(t.fn, t.args, t.kwargs))
            bar.update()
    finally:
        bar.close()
    report.computed = len(todo)


def _run_dask(tasks, todo, digests, finish, scheduler, workers, timing, connect_timeout, progress, desc, report):
    from .. import interrupt

    cluster = client = None
    pending = []
    with _QuietDask():
        try:
            if scheduler == "local":
                cluster, client, n, share = _local_cluster(workers, timing, progress)
            else:
                client, n, share = _remote(scheduler, timing, connect_timeout)
            report.workers, report.threads = n, share
            report.dashboard = _dashboard(client, scheduler == "local")
            if progress:
                where = f"{n} {'local ' if scheduler == 'local' else ''}Dask worker{'s' if n > 1 else ''}"
                print(f"{desc}: {len(tasks)} tasks: {report.reused} reused, {len(todo)} to compute on {where} "
                      f"({share} thread{'s' if share > 1 else ''} each)"
                      + (f"; dashboard {report.dashboard}" if report.dashboard else ""), file=sys.stderr, flush=True)
            from distributed import as_completed

            index = {}
            for i in todo:
                t = tasks[i]
                # priorities fall in the order given, so that results arrive roughly in that order
                f = client.submit(_execute, t.fn, t.args, t.kwargs, key=f"refsoft-{digests[i][:32]}", pure=False,
                                  priority=-len(index))
                index[f.key] = i
                pending.append(f)
            bar = _Progress(len(todo), desc, progress)
            try:
                ac = as_completed(pending)
                while not ac.is_empty():
                    interrupt.check()
                    if not ac.has_ready():
                        time.sleep(POLL_SECONDS)
                        continue
                    for f in ac.next_batch(block=False):
                        i = index[f.key]
                        finish(i, *_result(f, tasks[i]))
                        pending.remove(f)
                        f.release()
                        bar.update()
            finally:
                bar.close()
        finally:
            _close(client, cluster, pending)


def _close(client, cluster, pending):
    """Cancel what is left, disconnect, and close a local cluster (its workers also leave on
    their own when this process ends)."""
    if client is not None:
        if pending:
            _quietly(client.cancel, pending)
        _quietly(client.close, timeout=CLOSE_SECONDS)
    if cluster is not None:
        _quietly(cluster.close, timeout=CLOSE_SECONDS)


def _quietly(fn, *args, **kwargs):
    try:
        fn(*args, **kwargs)
    except (OSError, TimeoutError, RuntimeError):  # a worker slow to leave: it ends with this process
        pass


def _result(future, task):
    from distributed import KilledWorker

    try:
        return future.result()
    except KilledWorker as exc:
        raise RefsoftError(f"task {task.label or task.key}: the Dask workers running it died ({exc})") from None


def _dashboard(client, local):
    """The cluster's dashboard address, or None."""
    import importlib.util

    try:
        if "dashboard" not in client.scheduler_info().get("services", {}):
            return None
        link = client.dashboard_link
    except Exception:  # noqa: BLE001 - the dashboard is a convenience, never a reason to stop
        return None
    if local and importlib.util.find_spec("bokeh") is None:
        link += " (its pages need bokeh: pip install bokeh)"
    return link


def _local_cluster(workers, timing, progress):
    import logging

    from distributed import Client, LocalCluster

    ncores = cores()
    n = ncores if workers is None else workers
    if timing and n > ncores:
        if progress:
            print(f"refsoft: note: timing tasks: {n} workers capped at the {ncores} cores (--no-timing runs more)",
                  file=sys.stderr, flush=True)
        n = ncores
    share = max(1, ncores // n)
    package_root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    path = os.pathsep.join(p for p in (package_root, os.environ.get("PYTHONPATH")) if p)
    with _sigint_blocked(), _worker_environ():  # Ctrl-C reaches this process only (_sigint_blocked)
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0",
                               silence_logs=logging.ERROR, env={"PYTHONPATH": path})
    client = Client(cluster)
    client.run(_set_share, share)
    return cluster, client, n, share


class _worker_environ:
    """While a local cluster starts: its workers without Dask's ``MALLOC_TRIM_THRESHOLD_``
    (with it glibc returns freed memory at once, and every frame's fresh arrays fault their
    pages in again: slower tasks, docs/benchmarks.md), and this process's environment as it was
    afterwards (Dask's nannies, running in this process, write their workers' variables into
    it, whence every later child would inherit them)."""

    def __enter__(self):
        import dask

        self.saved = dict(os.environ)
        self.config = dask.config.set({"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None})
        self.config.__enter__()
        return self

    def __exit__(self, *exc):
        self.config.__exit__(*exc)
        for k in set(os.environ) - set(self.saved):
            del os.environ[k]
        os.environ.update(self.saved)
        return False


def _remote(address, timing, connect_timeout):
    from distributed import Client

    try:
        client = Client(address, timeout=connect_timeout)
    except (OSError, TimeoutError) as exc:
        raise RefsoftError(f"cannot reach the Dask scheduler at {address} within {connect_timeout:g} s "
                           f"({type(exc).__name__})") from None
    try:
        try:
            client.wait_for_workers(1, timeout=connect_timeout)
        except (OSError, TimeoutError):
            raise RefsoftError(f"the Dask scheduler at {address} has no workers (none joined within "
                               f"{connect_timeout:g} s)") from None
        facts = client.run(_worker_facts)
        nthreads = client.nthreads()
        here = identity()
        groups, trimmed = {}, set()
        for addr, f in facts.items():
            if (f["refsoft"], f["code"]) != (here["refsoft"], here["code"]):
                raise RefsoftError(f"the Dask worker {addr} runs refsoft {f['refsoft']} (sources {f['code'][:12]}), "
                                   f"this is {here['refsoft']} ({here['code'][:12]}): install the same refsoft on "
                                   "every worker")
            if (f["numpy"], f["numba"]) != (here["numpy"], here["numba"]):
                raise RefsoftError(f"the Dask worker {addr} runs NumPy {f['numpy']} and Numba {f['numba']}, this is "
                                   f"NumPy {here['numpy']} and Numba {here['numba']}: install the same on every worker")
            if timing and nthreads.get(addr, 1) > 1:
                raise RefsoftError(f"timing tasks need one thread per Dask worker; {addr} has {nthreads[addr]} (start "
                                   "workers with --nthreads 1, or give --no-timing)")
            groups.setdefault((f["host"], tuple(f["affinity"])), []).append(addr)
            if f.get("malloc_trim") is not None:
                trimmed.add(f["host"])
        shares = {}
        for (host, affinity), addrs in groups.items():
            if timing and len(addrs) > len(affinity):
                raise RefsoftError(f"timing tasks need at most one Dask worker per core; {host} runs {len(addrs)} on "
                                   f"{len(affinity)} cores (start fewer, or give --no-timing)")
            for a in addrs:
                shares[a] = max(1, len(affinity) // len(addrs))
        for a, s in shares.items():
            client.run(_set_share, s, workers=[a])
        if timing and trimmed:
            print(f"refsoft: note: the Dask workers on {', '.join(sorted(trimmed))} run with MALLOC_TRIM_THRESHOLD_ set "
                  "(Dask's default), which slows every frame; docs/benchmarks.md, 'Sweeps on a cluster', says how to "
                  "start them without it", file=sys.stderr, flush=True)
    except BaseException:
        client.close()
        raise
    share = min(shares.values()) if shares else 1
    return client, len(facts), share


class _QuietDask:
    """Dask's own log lines (start-up, shutdown) at ERROR only, while the runner talks to it."""

    def __enter__(self):
        import logging

        self.loggers = [logging.getLogger(n) for n in ("distributed", "tornado", "asyncio")]
        self.levels = [lg.level for lg in self.loggers]
        for lg in self.loggers:
            lg.setLevel(logging.CRITICAL)
        return self

    def __exit__(self, *exc):
        for lg, level in zip(self.loggers, self.levels):
            lg.setLevel(level)
        return False


class _sigint_blocked:
    """While the local workers start: SIGINT ignored, so that the processes started meanwhile
    ignore it for good (a terminal's Ctrl-C, sent to every process of the group, then reaches
    only this one, which closes the cluster), and blocked in this thread, so that a Ctrl-C
    meanwhile is kept pending (Linux does not discard a blocked signal) and delivered to the
    handler put back at the end."""

    def __enter__(self):
        import signal
        import threading

        self.ok = hasattr(signal, "pthread_sigmask") and threading.current_thread() is threading.main_thread()
        if self.ok:
            signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
            self.previous = signal.signal(signal.SIGINT, signal.SIG_IGN) or signal.default_int_handler
        return self

    def __exit__(self, *exc):
        import signal

        if self.ok:
            signal.signal(signal.SIGINT, self.previous)
            signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
        return False


def resolve(scheduler=None, workers=None, fresh=False, connect_timeout=None) -> dict:
    """The command line's ``--scheduler``, ``--workers``, ``--fresh`` and ``--connect-timeout``
    checked before any work, as keyword arguments of the bench functions. No ``--scheduler``:
    ``local`` when Dask is installed (or ``--workers`` is given), else ``serial`` with a note."""
    if scheduler is None:
        scheduler = "local" if dask_available() or workers is not None else "serial"
        if scheduler == "serial":
            print("refsoft: note: Dask is not installed: the tasks run one after another in this process "
                  "(pip install 'refsoft[dask]' for a local cluster)", file=sys.stderr)
    scheduler = check_scheduler(scheduler)
    if workers is not None and scheduler != "local":
        raise RefsoftError(f"--workers is for --scheduler local, not {scheduler}")
    if workers is not None and workers < 1:
        raise RefsoftError(f"--workers must be at least 1, got {workers}")
    if connect_timeout is not None:
        if not scheduler.startswith("tcp://"):
            raise RefsoftError("--connect-timeout is for --scheduler tcp://HOST:PORT")
        if not connect_timeout > 0:
            raise RefsoftError(f"--connect-timeout must be positive, got {connect_timeout:g}")
    if scheduler != "serial" and not dask_available():
        raise RefsoftError(f"--scheduler {scheduler} needs Dask: pip install 'refsoft[dask]' (or give --scheduler "
                           "serial)")
    return {"scheduler": scheduler, "workers": workers, "fresh": bool(fresh), "connect_timeout": connect_timeout}
