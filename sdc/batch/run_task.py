"""One run as a unit of work: a task in, a result row out, in any process.

:func:`execute` is what every executor runs in its workers. It never raises for
a failure of the run itself: that becomes a row with ``status`` error.
"""

from __future__ import annotations

import dataclasses
import math
import traceback
from pathlib import Path
from typing import Any, Literal

from scenarios.scenario_spec import ScenarioSpec

TraceMode = Literal["none", "failures", "all"]


@dataclasses.dataclass(frozen=True)
class RunTask:
    """What a worker needs for one run. ``columns`` are copied into the row as they are."""

    run_id: str
    spec: ScenarioSpec
    columns: dict[str, Any] = dataclasses.field(default_factory=dict)
    trace_path: Path | None = None
    traces: TraceMode = "all"  # with a trace_path: write it always, or on a collision only


def _plain(value: Any) -> Any:
    if hasattr(value, "item"):  # numpy scalar
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def failed_row(task: RunTask, status: str, error: str, **extra: Any) -> dict:
    """The row of a run that produced no outcome (``status`` error or timeout)."""
    return {"run_id": task.run_id, **task.columns, "seed": task.spec.scenario.seed,
            "controller": task.spec.controller.name, "backend": task.spec.scenario.backend,
            "status": status,
            "error": error, **extra}


def execute(task: RunTask) -> dict:
    """Run ``task`` and return its result row; write its trace when asked to."""
    from sdc.run.episode import run_episode  # keeps importers that never run fast

    try:
        episode = run_episode(task.spec)
    except Exception as e:  # the run's own failure is an outcome row, not a crash
        return failed_row(task, "error", f"{type(e).__name__}: {e}",
                          traceback=traceback.format_exc())
    wanted = task.traces == "all" or (task.traces == "failures" and episode.row["collision"])
    if task.trace_path is not None and wanted:
        episode.write_trace(task.trace_path)
    return {"run_id": task.run_id, **task.columns,
            **{k: _plain(v) for k, v in episode.row.items()}}
