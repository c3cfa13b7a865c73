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
from sdc.batch.run_task import WORLD_ROWS, RunTask, rows_of, task_error_row
from sdc.batch.worker_files import Fetch, FileLost, WorkerFiles

TaskFn = Callable[[RunTask], dict]
#: a task's row, and its trace file's bytes when it wrote one (a world task: each of
#: its runs', in slot order)
Outcome = tuple[dict, bytes | None | list[bytes | None]]


def run_in_worker(task: RunTask, task_fn: TaskFn, files: WorkerFiles, fetch: Fetch) -> Outcome:
    """Run ``task`` with ``task_fn`` on this worker's copies of its files; every
    failure is its row (a file it cannot have: an error row naming the file)."""
    try:
        local = files.localise(task, fetch)
    except FileLost as e:
        return task_error_row(task, str(e)), None
    with tempfile.TemporaryDirectory(prefix="sdc-trace-") as scratch:
        traces = [Path(scratch) / f"trace-{k}.parquet" for k in range(len(task.members))]
        if task.members:
            local = dataclasses.replace(local, members=tuple(
                m if m.trace_path is None else dataclasses.replace(m, trace_path=trace)
                for m, trace in zip(task.members, traces, strict=True)))
        elif task.trace_path is not None:
            traces = [Path(scratch) / "trace.parquet"]
            local = dataclasses.replace(local, trace_path=traces[0])
        try:
            row = task_fn(local)
        except Exception as e:  # a bug outside the run itself; still its rows
            return task_error_row(task, f"{type(e).__name__}: {e}"), None
        written = [trace.read_bytes() if trace.is_file() else None for trace in traces]
        return row, (written if task.members else written[0] if written else None)


def deliver(task: RunTask, outcome: Outcome) -> dict:
    """On the driver: write the trace that came back to ``task.trace_path`` and
    return the row. A trace that cannot be written makes the row an error."""
    row, trace = outcome
    if task.members:
        rows = rows_of(row)
        if trace is None:  # the world task failed as a whole: its rows say why
            return row
        return {WORLD_ROWS: [deliver(member, (member_row, member_trace)) for member, member_row,
                             member_trace in zip(task.members, rows, trace, strict=True)]}
    if trace is not None and task.trace_path is not None:
        try:
            write_atomic(task.trace_path, lambda tmp: tmp.write_bytes(trace))
        except OSError as e:
            return task_error_row(task, f"cannot write the trace {task.trace_path} "
                                  f"({e.strerror or e})")
    return row
