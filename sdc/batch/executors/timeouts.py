"""The run timeout, as both executors apply it."""

from __future__ import annotations

import time
from collections.abc import Iterable

from sdc.batch.tasks.task import Task


def task_limit_s(task: Task, limit_s: float | None) -> float | None:
    """A task's wall limit under the run timeout ``limit_s`` (None: none): a shared
    world's task holds its runs' time, the limit times its runs."""
    return None if limit_s is None else task.wall_limit_s(limit_s)


def timeout_row(task: Task, elapsed_s: float, limit_s: float) -> dict:
    """The row of ``task``, stopped after ``elapsed_s`` under the run timeout ``limit_s``."""
    return task.timeout_row(f"{task.overrun_text(limit_s)}; its worker was stopped", elapsed_s)


def next_deadline_s(running: Iterable[tuple[float, float | None]]) -> float | None:
    """Seconds until the earliest running task times out, of ``running``'s (start,
    limit) pairs (None: no timeout)."""
    deadlines = [start + limit for start, limit in running if limit is not None]
    if not deadlines:
        return None
    return max(0.0, min(deadlines) - time.monotonic())
