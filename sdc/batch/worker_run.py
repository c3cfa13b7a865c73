"""One task in a worker process, and its outcome back on the driver.

A worker never opens a driver path: it runs on its own copies of the task's
files (:mod:`sdc.batch.worker_files`) and writes the trace, when there is one,
into a scratch folder of its own; the trace's bytes travel back with the row,
and the driver writes them where the task asked (:func:`deliver`).
"""

from __future__ import annotations

import dataclasses
import tempfile
from collections.abc import Callable
from pathlib import Path

from scenarios.common.atomic_write import write_atomic
from sdc.batch.run_task import RunTask, task_error_row
from sdc.batch.worker_files import Fetch, FileLost, WorkerFiles

TaskFn = Callable[[RunTask], dict]
#: a task's row, and its trace file's bytes when it wrote one
Outcome = tuple[dict, bytes | None]


def run_in_worker(task: RunTask, task_fn: TaskFn, files: WorkerFiles, fetch: Fetch) -> Outcome:
    """Run ``task`` with ``task_fn`` on this worker's copies of its files; every
    failure is its row (a file it cannot have: an error row naming the file)."""
    try:
        local = files.localise(task, fetch)
    except FileLost as e:
        return task_error_row(task, str(e)), None
    with tempfile.TemporaryDirectory(prefix="sdc-trace-") as scratch:
        trace = Path(scratch) / "trace.parquet"
        if task.trace_path is not None:
            local = dataclasses.replace(local, trace_path=trace)
        try:
            row = task_fn(local)
        except Exception as e:  # a bug outside the run itself; still one row
            return task_error_row(task, f"{type(e).__name__}: {e}"), None
        return row, (trace.read_bytes() if trace.is_file() else None)


def deliver(task: RunTask, outcome: Outcome) -> dict:
    """On the driver: write the trace that came back to ``task.trace_path`` and
    return the row. A trace that cannot be written makes the row an error."""
    row, trace = outcome
    if trace is not None and task.trace_path is not None:
        try:
            write_atomic(task.trace_path, lambda tmp: tmp.write_bytes(trace))
        except OSError as e:
            return task_error_row(task, f"cannot write the trace {task.trace_path} "
                                  f"({e.strerror or e})")
    return row
