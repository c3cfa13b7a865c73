"""Executors run tasks in worker processes and yield one result row per task.

``with executor:`` starts the workers; ``executor.map(tasks)`` (any number of
times inside) yields exactly one row per task, in completion order: the row the
task returned, or one with ``status`` timeout when it ran past
``run_timeout_s`` (its worker is stopped), or ``status`` error when its worker
died under it or one of its files could not be had. A worker runs one task at a
time, so each process holds at most one libsumo simulation, and it never opens a
driver path: a run's files travel with the job (:mod:`sdc.batch.job_files`).

:class:`LocalExecutor`: spawned processes on this machine
(:mod:`sdc.batch.local_executor`); :class:`RayExecutor`: Ray tasks carrying
batches of runs (:mod:`sdc.batch.ray_executor`).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from typing import Protocol, Self

from sdc.batch.local_executor import LocalExecutor
from sdc.batch.ray_executor import RayExecutor
from sdc.batch.run_task import RunTask
from sdc.batch.worker_run import TaskFn

__all__ = ["Executor", "LocalExecutor", "RayExecutor", "TaskFn"]


class Executor(Protocol):
    """The executors' contract (above); :class:`LocalExecutor` and :class:`RayExecutor`
    keep it."""

    name: str
    workers: int

    def __enter__(self) -> Self: ...
    def __exit__(self, *exc: object) -> None: ...
    def map(self, tasks: Iterable[RunTask]) -> Iterator[dict]: ...
