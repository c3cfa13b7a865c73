"""One task in a worker process, and its outcome back on the driver.

A worker never opens a driver path: it runs on its own copies of the task's
files (:mod:`sdc.batch.executors.worker_files`) and writes the files the task
writes for the driver (a run's trace, a warm-up's state) into a scratch folder of
its own; their bytes travel back with the row, and the driver writes them where
the task asked (:func:`deliver`).
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable
from pathlib import Path

from scenarios.common.atomic_write import write_atomic
from sdc.batch.executors.worker_files import Fetch, FileLost, WorkerFiles
from sdc.batch.tasks.task import Task, rows_of

TaskFn = Callable[[Task], dict]
#: a task's row, and the bytes of the file each of its parts wrote for the driver
#: (None: none), in the order of its parts; None: it failed as a whole, its row says why
Outcome = tuple[dict, list[bytes | None] | None]
#: imported by each worker before it takes a task
WARM_MODULES = ("sdc.run.episode",)


def run_in_worker(task: Task, task_fn: TaskFn, files: WorkerFiles, fetch: Fetch) -> Outcome:
    """Run ``task`` with ``task_fn`` on this worker's copies of its files; every
    failure is its row (a file it cannot have: an error row naming the file)."""
    try:
        local = files.localise(task, fetch)
    except FileLost as e:
        return task.error_row(str(e)), None
    with tempfile.TemporaryDirectory(prefix="sdc-trace-") as scratch:
        paths = [None if wanted is None else Path(scratch) / f"trace-{k}.parquet"
                 for k, wanted in enumerate(task.outputs())]
        try:
            row = task_fn(local.writing_to(paths))
        except Exception as e:  # a bug outside the run itself; still its rows
            return task.error_row(f"{type(e).__name__}: {e}"), None
        return row, [path.read_bytes() if path is not None and path.is_file() else None
                     for path in paths]


def deliver(task: Task, outcome: Outcome) -> dict:
    """On the driver: write the files that came back where ``task`` wants them
    (:meth:`~sdc.batch.tasks.task.Task.outputs`) and return the row. A part whose
    file cannot be written gets an error row."""
    row, written = outcome
    if written is None:  # the task failed as a whole: its rows say why
        return row
    return task.joined([_written(part, part_row, path, data) for part, part_row, path, data
                        in zip(task.parts(), rows_of(row), task.outputs(), written,
                               strict=True)])


def _written(part: Task, row: dict, path: Path | None, data: bytes | None) -> dict:
    if data is not None and path is not None:
        try:
            write_atomic(path, lambda tmp: tmp.write_bytes(data))
        except OSError as e:
            return part.error_row(f"cannot write the trace {path} ({e.strerror or e})")
    return row
