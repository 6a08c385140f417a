"""``report.html``: one self-contained page per benchmark run (its tables, its plots as inline
base64 PNG, how the tasks ran), readable without a network; and ``tasks.csv``, the per-task run
times a scaling estimate starts from.

The run-time estimate for P workers, from the tasks' own times t_i (each on one worker): the run
takes at least ``max(max t_i, sum t_i / P)`` and, handing each free worker the next task, at most
``sum t_i / P + max t_i``, plus the cluster's start-up (docs/benchmarks.md, "Sweeps on a
cluster").
"""

from __future__ import annotations

import base64
import contextvars
import html
import os

import numpy as np

from ._common import _cell, write_csv, write_text

TASK_COLUMNS = ["task", "seconds", "host", "threads", "reused"]
#: The command line that is making the report (set by ``refsoft bench``; unset from Python).
COMMAND = contextvars.ContextVar("refsoft_bench_command", default=None)
#: Worker counts the estimate is tabulated for.
ESTIMATE_WORKERS = (1, 2, 4, 8, 16, 32, 64)

_STYLE = """body{font:14px/1.45 system-ui,sans-serif;margin:2em auto;max-width:80em;padding:0 1em;color:#222}
table{border-collapse:collapse;margin:0.6em 0 1.2em}th,td{border:1px solid #ccc;padding:2px 8px}
td.n{text-align:right;font-variant-numeric:tabular-nums}th{background:#f2f2f2}
img{max-width:100%;border:1px solid #ddd;margin:0.4em 0}.note{color:#a50}code{background:#f4f4f4}
.prov{color:#444;background:#f8f8f8;border-left:4px solid #bbb;padding:0.4em 0.8em}"""


def task_rows(run) -> list:
    """One row per task: its label, seconds, host, threads and whether it was reused."""
    return [{"task": label, "seconds": m.get("seconds"), "host": m.get("host"), "threads": m.get("threads"),
             "reused": bool(m.get("reused"))} for label, m in zip(run.labels, run.meta)]


def estimate(seconds, workers=ESTIMATE_WORKERS) -> list:
    """``[{"workers", "at_least", "at_most"}]``: bounds on the run time (s) of tasks taking
    ``seconds`` each, on each count of workers (start-up not included)."""
    t = np.asarray([s for s in seconds if s is not None], float)
    if not len(t):
        return []
    total, longest = float(t.sum()), float(t.max())
    return [{"workers": p, "at_least": max(longest, total / p), "at_most": min(total, total / p + longest)}
            for p in workers]


def write_tasks_csv(out, run) -> None:
    write_csv(os.path.join(out, "tasks.csv"), task_rows(run), TASK_COLUMNS)


def _table(rows, columns, headers=None) -> str:
    headers = headers or columns
    head = "".join(f"<th>{html.escape(h)}</th>" for h in headers)
    body = []
    for r in rows:
        cells = []
        for c in columns:
            v = r.get(c)
            num = isinstance(v, (int, float)) and not isinstance(v, bool)
            cells.append(f"<td{' class=n' if num else ''}>{html.escape(_cell(v))}</td>")
        body.append("<tr>" + "".join(cells) + "</tr>")
    return f"<table><tr>{head}</tr>\n" + "\n".join(body) + "</table>\n"


def _image(path, alt) -> str:
    with open(path, "rb") as fh:
        data = base64.b64encode(fh.read()).decode("ascii")
    return f'<img alt="{html.escape(alt)}" src="data:image/png;base64,{data}">\n'


def run_section(run) -> str:
    """How the tasks ran, their times and the estimate for more workers."""
    where = {"serial": "serially in one process", "local": f"on a local Dask cluster of {run.workers} workers"}.get(
        run.scheduler, f"on the Dask cluster at {html.escape(run.scheduler)} ({run.workers} workers)")
    threads = f", {run.threads} Numba thread{'s' if run.threads != 1 else ''} per task" if run.threads else ""
    secs = [m.get("seconds") for m in run.meta if m.get("seconds") is not None]
    parts = [f"<h2>Tasks</h2><p>{len(run.results)} tasks, {run.reused} reused from <code>tasks/</code>, "
             f"{run.computed} computed {where}{threads}, in {run.seconds:.1f} s.</p>"]
    if secs:
        parts.append(f"<p>Task times (s, each on one worker): sum {sum(secs):.1f}, median {np.median(secs):.2f}, "
                     f"longest {max(secs):.2f}. On P workers the tasks take at least max(longest, sum / P) and, each "
                     "free worker taking the next task, at most sum / P + longest, plus the cluster's start-up "
                     "(per-task times: <code>tasks.csv</code>):</p>")
        parts.append(_table(estimate(secs), ["workers", "at_least", "at_most"], ["workers P", "at least (s)",
                                                                                "at most (s)"]))
    return "".join(parts)


def _cpu_model() -> str:
    """The CPU's model name (Linux's /proc/cpuinfo), else what the platform module says."""
    import platform

    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as fh:
            for line in fh:
                if line.lower().startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def provenance(command=None) -> dict:
    """What made a report: ``refsoft`` (its version), ``date`` (UTC, ISO 8601), ``machine``
    (host, CPU model, cores, operating system), ``software`` (Python, NumPy, Numba) and the
    ``command`` (``command``, else :data:`COMMAND`, else a note that it ran from Python)."""
    import datetime
    import platform

    from .. import __version__
    from ._common import machine

    m = machine()
    cmd = command or COMMAND.get() or "(called from Python, not from the refsoft command)"
    return {"refsoft": __version__,
            "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
            "machine": f"{platform.node()}: {_cpu_model()}, {m['cores']} cores, {platform.platform()}",
            "software": f"Python {m['python']}, NumPy {m['numpy']}, Numba {m['numba']}, {m['threads']} Numba threads",
            "command": cmd}


def provenance_html(p) -> str:
    """:func:`provenance` as the report's opening lines."""
    lines = [f"<b>{html.escape(k)}</b>: "
             + (f"<code>{html.escape(v)}</code>" if k == "command" else html.escape(str(v))) for k, v in p.items()]
    return "<p class=prov>" + "<br>".join(lines) + "</p>\n"


def write_report(out, title, blocks, run=None, plots=True) -> str:
    """Write ``out/report.html``; returns its path.

    Parameters
    ----------
    out : str
    title : str
    blocks : list of tuple
        ``("h2", text)``, ``("p", text)``, ``("table", rows, columns, headers)`` or
        ``("image", path, alt)`` (a PNG file, inlined; skipped when missing).
    run : RunReport, optional
        Adds the tasks' section.

    The page opens with :func:`provenance`: refsoft's version, the date, the machine and the
    command.
    plots : bool
        False: a note that the plots need matplotlib.
    """
    parts = [f"<!DOCTYPE html>\n<html><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
             f"<style>{_STYLE}</style></head><body>\n<h1>{html.escape(title)}</h1>\n", provenance_html(provenance())]
    if not plots:
        parts.append("<p class=note>No plots: matplotlib is not installed (pip install 'refsoft[plot]'); the tables "
                     "are complete.</p>\n")
    for b in blocks:
        if b[0] == "h2":
            parts.append(f"<h2>{html.escape(b[1])}</h2>\n")
        elif b[0] == "p":
            parts.append(f"<p>{html.escape(b[1])}</p>\n")
        elif b[0] == "table":
            parts.append(_table(*b[1:]))
        elif b[0] == "image" and os.path.isfile(b[1]):
            parts.append(_image(b[1], b[2]))
    if run is not None:
        parts.append(run_section(run))
    parts.append("</body></html>\n")
    path = os.path.join(out, "report.html")
    write_text(path, "".join(parts))
    return path


def file_link(path) -> str:
    """A ``file://`` URI of ``path`` (terminals make it clickable)."""
    import pathlib

    return pathlib.Path(os.path.abspath(path)).as_uri()
