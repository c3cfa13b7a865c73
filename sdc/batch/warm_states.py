"""The warm states of a batch of runs, each computed once before the runs.

Runs with a traffic warm-up start from a warm state (``scenarios/warm_state.py``).
Before a batch's runs, every distinct state they need that the driver's cache
lacks is computed by one ``warm_up`` task on the executor (a worker of any node),
whose file comes back like a trace and lands in the driver's cache; from there it
travels with each run by sha256 like the other job files
(:mod:`sdc.batch.job_files`). A state whose task failed is left to its runs: each
computes it itself (same trace) or fails the same way, as an error row.
"""

from __future__ import annotations

import contextlib
import json
from collections.abc import Callable, Iterable
from pathlib import Path

from scenarios.atomic_write import write_atomic
from scenarios.errors import SdcError
from scenarios.warm_state import (
    WarmState,
    cached_path,
    warm_state_dir,
    warm_state_id,
)
from sdc.batch.job_files import FileCatalog
from sdc.batch.run_task import RunTask

#: told the warm states done and in all, as they come
Progress = Callable[[int, int], None]
#: the most warm-ups whose settling a sweep directory keeps (warm-states.json)
SETTLING_SERIES = 20


def warm_keys(tasks: Iterable[RunTask], catalog: FileCatalog) -> dict[str, RunTask]:
    """Each distinct warm state the ``tasks`` start from, with the first task that
    needs it (a run whose files the driver cannot read is left to report it)."""
    needed: dict[str, RunTask] = {}
    for task in tasks:
        with contextlib.suppress(SdcError):
            key = catalog.warm_key(task.spec)
            if key is not None:
                needed.setdefault(key, task)
    return needed


def warm_up_tasks(tasks: Iterable[RunTask], catalog: FileCatalog) -> list[RunTask]:
    """A ``warm_up`` task for each warm state the tasks need and the driver lacks."""
    return [RunTask(f"warm-state-{key[:16]}", task.spec, trace_path=cached_path(key),
                    kind="warm_up")
            for key, task in warm_keys(tasks, catalog).items() if not cached_path(key).is_file()]


def prepare_warm_states(tasks: list[RunTask], executor,
                        progress: Progress) -> tuple[dict, list[str]]:
    """Compute on ``executor`` (inside its ``with`` block) the warm states ``tasks``
    need and the driver's cache lacks. Returns ``{"distinct": n, "computed": n,
    "failed": {task id: error}}`` and the keys of the states the tasks start from."""
    catalog = FileCatalog()
    needed = warm_keys(tasks, catalog)
    todo = warm_up_tasks(tasks, catalog)
    failed = {}
    if todo:
        warm_state_dir().mkdir(parents=True, exist_ok=True)
        progress(0, len(todo))
        for done, row in enumerate(executor.map(todo), start=1):
            if row["status"] != "ok":
                failed[row["run_id"]] = row.get("error")
            progress(done, len(todo))
    summary = {"distinct": len(needed), "computed": len(todo) - len(failed), "failed": failed}
    return summary, list(needed)


def write_settling(path: Path, keys: list[str]) -> None:
    """Write to ``path`` (JSON) how the traffic settled in the warm-ups of the first
    :data:`SETTLING_SERIES` of ``keys`` found in the driver's cache, by warm state
    (as results name it), with each warm-up's length: what the report draws. Nothing
    is written without one."""
    series = {}
    for key in keys:
        if len(series) == SETTLING_SERIES:
            break
        with contextlib.suppress(SdcError):
            series[warm_state_id(key)] = WarmState.read(cached_path(key)).settling
    if series:
        write_atomic(path, lambda tmp: tmp.write_text(json.dumps(series)))
