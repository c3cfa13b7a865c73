"""One run as a unit of work: a task in, a result row out, in any process.

:func:`execute` is what every executor runs in its workers. It never raises for
a failure of the run itself: that becomes a row with ``status`` error.
"""

from __future__ import annotations

import dataclasses
import traceback
from pathlib import Path
from typing import Literal

from analysis.measures.run_outcome import COMPLETED
from scenarios.common.atomic_write import write_atomic
from scenarios.spec.scenario_spec import ScenarioSpec
from sdc.batch.job_files import JobFile
from sdc.batch.warm_up_clock import ClockWriter
from sdc.run.result_row import SweepColumns, error_row, sweep_row, timeout_row

TraceMode = Literal["none", "failures", "all"]
#: a task runs the scenario, or only computes its warm state (into ``trace_path``)
TaskKind = Literal["run", "warm_up"]


@dataclasses.dataclass(frozen=True)
class RunTask:
    """What a worker needs for one run. ``sweep``: the run's sweep columns, for its row.

    An executor fills ``files`` on the driver (what the run reads besides its
    spec, :mod:`sdc.batch.job_files`); a worker runs a copy whose ``spec`` names
    its own copies of them, ``cache_dir`` holding the cached ones, and whose
    ``recorded_spec`` is the driver's spec, for the trace's metadata
    (:mod:`sdc.batch.worker_files`) and whose ``warm_state`` is its copy of the
    warm state the run starts from, when one travels with the job.

    A ``warm_up`` task computes the spec's warm state instead of running it, and
    writes its file to ``trace_path`` (:mod:`sdc.batch.warm_states`), and SUMO's
    clock on the way to ``clock_path``, the driver's path, which a worker on another
    machine may not reach (:mod:`sdc.batch.warm_up_clock`).
    """

    run_id: str
    spec: ScenarioSpec
    sweep: SweepColumns | None = None
    trace_path: Path | None = None
    traces: TraceMode = "all"  # with a trace_path: write it always, or on a collision only
    files: tuple[JobFile, ...] = ()
    cache_dir: Path | None = None  # where the run finds built networks and road edges
    recorded_spec: ScenarioSpec | None = None  # the spec a trace records (default: spec)
    warm_state: Path | None = None  # the worker's copy of the run's warm state
    kind: TaskKind = "run"
    clock_path: Path | None = None  # warm_up: where its SUMO clock goes, for progress


def _identity(task: RunTask) -> dict:
    spec = task.spec
    return {"run_id": task.run_id, "seed": spec.scenario.seed,
            "controller": spec.controller.label, "backend": spec.scenario.backend}


def task_row(task: RunTask, row: dict) -> dict:
    """A run's row as ``task``'s: with its sweep's columns when it has them."""
    return row if task.sweep is None else sweep_row(row, task.sweep)


def task_error_row(task: RunTask, error: str, traceback_text: str | None = None) -> dict:
    """The row of ``task`` when it raised or its worker died."""
    return task_row(task, error_row(**_identity(task), error=error, traceback=traceback_text))


def task_timeout_row(task: RunTask, error: str, wall_time_s: float) -> dict:
    """The row of ``task`` when it was stopped at the run timeout."""
    return task_row(task, timeout_row(**_identity(task), error=error, wall_time_s=wall_time_s))


def _record_driver_paths(metadata: dict, spec: ScenarioSpec) -> None:
    metadata["spec"] = spec.to_plain()
    if "net_file" in metadata["road"] and spec.road.net_file is not None:
        metadata["road"]["net_file"] = spec.road.net_file


def _warm_up(task: RunTask) -> dict:
    """Compute (or find in this machine's cache) the warm state of ``task.spec`` and
    write its file to ``task.trace_path``; the row says ok or why not."""
    from scenarios.world_backends import warm_state_file

    clock = ClockWriter(task.clock_path) if task.clock_path else None
    try:
        data = warm_state_file(task.spec, task.cache_dir, on_sample=clock)
        write_atomic(task.trace_path, lambda tmp: tmp.write_bytes(data))
    except Exception as e:  # noqa: BLE001 - its runs compute it themselves, or fail alike
        return task_error_row(task, f"{type(e).__name__}: {e}", traceback.format_exc())
    finally:
        if clock is not None:
            clock.remove()
    return {"run_id": task.run_id, "status": "ok"}


def execute(task: RunTask) -> dict:
    """Run ``task`` and return its result row; write its trace when asked to."""
    from sdc.run.episode import run_episode  # keeps importers that never run fast

    if task.kind == "warm_up":
        return _warm_up(task)
    try:
        episode = run_episode(task.spec, run_id=task.run_id, cache_dir=task.cache_dir,
                              warm_state=task.warm_state)
    except Exception as e:  # the run's own failure is an outcome row, not a crash
        return task_error_row(task, f"{type(e).__name__}: {e}", traceback.format_exc())
    wanted = task.traces == "all" or (task.traces == "failures"
                                      and episode.row["outcome"] != COMPLETED)
    if task.trace_path is not None and wanted:
        if task.recorded_spec is not None:  # the driver's paths, not a worker's copies
            _record_driver_paths(episode.metadata, task.recorded_spec)
        episode.write_trace(task.trace_path)
    return task_row(task, episode.row)
