"""The run timeout, as both executors apply it."""

from __future__ import annotations

import time
from collections.abc import Iterable

from sdc.batch.run_task import RunTask, task_timeout_row


def task_limit_s(task: RunTask, limit_s: float | None) -> float | None:
    """A task's wall limit under the run timeout ``limit_s`` (None: none): a shared
    world's task holds its runs' time, the limit times its runs."""
    return None if limit_s is None else limit_s * max(1, len(task.members))


def timeout_row(task: RunTask, elapsed_s: float, limit_s: float) -> dict:
    what = (f"its world of {len(task.members)} runs exceeded {task_limit_s(task, limit_s):g} s "
            f"(the run timeout of {limit_s:g} s a run)" if task.members
            else f"run exceeded the run timeout of {limit_s:g} s")
    return task_timeout_row(task, f"{what}; its worker was stopped", elapsed_s)


def next_deadline_s(running: Iterable[tuple[float, float | None]]) -> float | None:
    """Seconds until the earliest running task times out, of ``running``'s (start,
    limit) pairs (None: no timeout)."""
    deadlines = [start + limit for start, limit in running if limit is not None]
    if not deadlines:
        return None
    return max(0.0, min(deadlines) - time.monotonic())
