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
#: a task runs the scenario, or only computes its warm state (into ``trace_path``), or
#: runs the runs of a shared world (its ``members``)
TaskKind = Literal["run", "warm_up", "world"]
#: a world task's row: the key of its runs' rows (:func:`rows_of`)
WORLD_ROWS = "world_rows"


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

    A ``world`` task (:func:`world_task`) runs its ``members``, the runs of one shared
    world (:mod:`sdc.run.shared_world`), together: its ``run_id`` is the world's, its
    spec the first run's (the files they share travel once) and its row holds one row
    per run (:func:`rows_of`).
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
    members: tuple[RunTask, ...] = ()  # world: its runs, in slot order


def world_task(world_id: str, members: list[RunTask]) -> RunTask:
    """The task of the runs of one shared world (their specs share its world fields)."""
    return RunTask(world_id, members[0].spec, kind="world", members=tuple(members))


def rows_of(row: dict) -> list[dict]:
    """The result rows in a task's row: a world task's runs' rows, else the row."""
    return row.get(WORLD_ROWS, [row])


def _identity(task: RunTask) -> dict:
    spec = task.spec
    return {"run_id": task.run_id, "seed": spec.scenario.seed,
            "controller": spec.controller.label, "backend": spec.scenario.backend}


def task_row(task: RunTask, row: dict) -> dict:
    """A run's row as ``task``'s: with its sweep's columns when it has them."""
    return row if task.sweep is None else sweep_row(row, task.sweep)


def task_error_row(task: RunTask, error: str, traceback_text: str | None = None) -> dict:
    """The row of ``task`` when it raised or its worker died (of a world: each run's)."""
    if task.kind == "world":
        return {WORLD_ROWS: [task_error_row(m, error, traceback_text) for m in task.members]}
    return task_row(task, error_row(**_identity(task), error=error, traceback=traceback_text))


def task_timeout_row(task: RunTask, error: str, wall_time_s: float) -> dict:
    """The row of ``task`` when it was stopped at the run timeout (of a world: each
    run's)."""
    if task.kind == "world":
        return {WORLD_ROWS: [task_timeout_row(m, error, wall_time_s) for m in task.members]}
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
    if task.kind == "world":
        return _run_world(task)
    try:
        episode = run_episode(task.spec, run_id=task.run_id, cache_dir=task.cache_dir,
                              warm_state=task.warm_state)
    except Exception as e:  # the run's own failure is an outcome row, not a crash
        return task_error_row(task, f"{type(e).__name__}: {e}", traceback.format_exc())
    return _delivered(task, episode)


def _delivered(task: RunTask, episode) -> dict:
    """``episode``'s row as ``task``'s, its trace written when asked to."""
    wanted = task.traces == "all" or (task.traces == "failures"
                                      and episode.row["outcome"] != COMPLETED)
    if task.trace_path is not None and wanted:
        if task.recorded_spec is not None:  # the driver's paths, not a worker's copies
            _record_driver_paths(episode.metadata, task.recorded_spec)
        episode.write_trace(task.trace_path)
    return task_row(task, episode.row)


def _run_world(task: RunTask) -> dict:
    """Run a world task's runs together (:func:`sdc.run.shared_world.run_group`), on
    the files its worker holds for the world (``task.spec``'s)."""
    from sdc.run.shared_world import Failed, run_group

    local = task.spec
    specs = [dataclasses.replace(m.spec, road=local.road, controller=dataclasses.replace(
        m.spec.controller, name=local.controller.name)) for m in task.members]
    outcomes = run_group(specs, [m.run_id for m in task.members], cache_dir=task.cache_dir,
                         warm_state=task.warm_state)
    rows = []
    for member, outcome in zip(task.members, outcomes, strict=True):
        if isinstance(outcome, Failed):
            rows.append(task_error_row(member, outcome.error, outcome.traceback))
        else:
            recorded = member.spec if task.recorded_spec is not None else None
            rows.append(_delivered(dataclasses.replace(member, recorded_spec=recorded),
                                   outcome))
    return {WORLD_ROWS: rows}
