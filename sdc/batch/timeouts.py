"""The run timeout, as both executors apply it."""

from __future__ import annotations

import time
from collections.abc import Iterable

from sdc.batch.run_task import RunTask, task_timeout_row


def timeout_row(task: RunTask, elapsed_s: float, limit_s: float) -> dict:
    return task_timeout_row(task, f"run exceeded the run timeout of {limit_s:g} s; "
                            "its worker was stopped", elapsed_s)


def next_deadline_s(starts: Iterable[float], limit_s: float | None) -> float | None:
    """Seconds until the earliest running run times out (None: no timeout)."""
    starts = list(starts)
    if limit_s is None or not starts:
        return None
    return max(0.0, min(starts) + limit_s - time.monotonic())
