"""Measurements of run time against error: ``refsoft bench accuracy``, ``refsoft bench sweep``,
``refsoft bench scaling`` and ``refsoft bench table1``. Each splits its work into independent tasks
(:mod:`refsoft.bench.tasks`: serially, or on a Dask cluster; stored and reused by a later run) and
writes CSV, a markdown table, ``report.html`` and (with matplotlib) plots; ``docs/benchmarks.md``
holds the figures of a run and how to rerun it.

Timed assertions do not belong in tests: the tests run these at tiny sizes and check the files,
never the times.
"""

from .accuracy import SETTINGS as ACCURACY_SETTINGS, accuracy, summarize as accuracy_summary
from .scaling import scaling
from .sweep import KNOBS, sweep
from .table1 import PAPER_TABLE1, table1
from .tasks import RunReport, Task, run_tasks

__all__ = ["accuracy", "accuracy_summary", "ACCURACY_SETTINGS", "sweep", "KNOBS", "scaling", "table1", "PAPER_TABLE1",
           "Task", "RunReport", "run_tasks"]
