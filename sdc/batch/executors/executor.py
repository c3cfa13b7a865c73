"""Executors run tasks in worker processes and yield one result row per task.

``with executor:`` starts the workers; ``executor.map(tasks)`` (any number of
times inside) yields exactly one row per task, in completion order: the row the
task returned, or one with ``status`` timeout when it ran past
``run_timeout_s`` (its worker is stopped), or ``status`` error when its worker
died under it or one of its files could not be had. A worker runs one task at a
time, so each process holds at most one libsumo simulation, and it never opens a
driver path: a run's files travel with the job (:mod:`sdc.batch.tasks.job_files`).

``LocalExecutor``: spawned processes on this machine
(:mod:`sdc.batch.executors.local_executor`); ``RayExecutor``: Ray tasks carrying
batches of runs (:mod:`sdc.batch.executors.ray_executor`). This module holds their
contract alone, so what only needs the contract (a sweep) imports neither.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from typing import Protocol, Self

from sdc.batch.tasks.task import Task


class Executor(Protocol):
    """The executors' contract (above);
    :class:`~sdc.batch.executors.local_executor.LocalExecutor` and
    :class:`~sdc.batch.executors.ray_executor.RayExecutor` keep it. A worker runs a
    task with the executor's ``task_fn`` (default
    :func:`~sdc.batch.tasks.task.execute`), a
    :data:`~sdc.batch.executors.worker_run.TaskFn`."""

    name: str
    workers: int

    def __enter__(self) -> Self: ...
    def __exit__(self, *exc: object) -> None: ...
    def map(self, tasks: Iterable[Task]) -> Iterator[dict]: ...
