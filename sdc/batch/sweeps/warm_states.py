"""The warm states of a batch of runs, each computed once before the runs.

Runs with a traffic warm-up start from a warm state (``scenarios/sumo/warm_state.py``).
Before a batch's runs, every distinct state they need that the driver's cache
lacks is computed by one :class:`~sdc.batch.tasks.warm_up_task.WarmUpTask` on the
executor (a worker of any node), whose file comes back like a trace and lands in
the driver's cache; from there it travels with each run by sha256 like the other
job files (:mod:`sdc.batch.tasks.job_files`). A state whose task failed is left to
its runs: each computes it itself (same trace) or fails the same way, as an error
row.
"""

from __future__ import annotations

import contextlib
import json
import threading
from collections.abc import Callable, Iterable
from pathlib import Path

from analysis.measures.row_columns import RowCol
from scenarios.common.atomic_write import write_atomic
from scenarios.common.errors import SdcError
from scenarios.sumo.warm_state import (
    WarmState,
    cached_path,
    warm_state_dir,
    warm_state_id,
)
from scenarios.world_backends import warm_up_span_s
from sdc.batch.tasks.job_files import FileCatalog
from sdc.batch.tasks.task import Task
from sdc.batch.tasks.warm_up_clock import clock_path, read_clock
from sdc.batch.tasks.warm_up_task import WarmUpTask

#: told the warm states done and in all, and the seconds of SUMO simulated of all the
#: warm-ups' seconds, as they come
Progress = Callable[[int, int, float, float], None]
#: how often the driver reads the clocks of the warm-ups under way [s]
CLOCKS_READ_EVERY_S = 0.5
#: the most warm-ups whose settling a sweep directory keeps (warm-states.json)
SETTLING_SERIES = 20


def warm_keys(tasks: Iterable[Task], catalog: FileCatalog) -> dict[str, str]:
    """The key of the warm state each of ``tasks`` starts from, by run ID (a run
    without one, or whose files the driver cannot read, is left out: it reports them)."""
    keys: dict[str, str] = {}
    for task in tasks:
        with contextlib.suppress(SdcError):
            key = catalog.warm_key(task.spec)
            if key is not None:
                keys[task.run_id] = key
    return keys


def warm_up_tasks(tasks: Iterable[Task], keys: dict[str, str]) -> list[WarmUpTask]:
    """A :class:`WarmUpTask` for each warm state the ``tasks`` start from (``keys``: by run
    ID) that the driver's cache lacks, on the spec of the first run that needs it."""
    first = {}
    for task in tasks:
        if task.run_id in keys:
            first.setdefault(keys[task.run_id], task)
    return [WarmUpTask(f"warm-state-{key[:16]}", task.spec, state_path=cached_path(key),
                       clock_path=clock_path(cached_path(key)))
            for key, task in first.items() if not cached_path(key).is_file()]


def with_warm_state(row: dict, keys: dict[str, str]) -> dict:
    """``row`` naming its run's warm state (``keys``: by run ID) also when the run did
    not get to start from it (an error, a timeout): the report counts it with the runs
    that share its traffic."""
    key = keys.get(row[RowCol.run_id])
    if key is None or row.get(RowCol.warm_state) is not None:
        return row
    return {**row, RowCol.warm_state: warm_state_id(key)}


def prepare_warm_states(tasks: list[Task], executor,
                        progress: Progress) -> tuple[dict, dict[str, str]]:
    """Compute on ``executor`` (inside its ``with`` block) the warm states ``tasks``
    need and the driver's cache lacks. Returns ``{"distinct": n, "computed": n,
    "failed": {task id: error}}`` and the key of each task's warm state by run ID."""
    catalog = FileCatalog()
    keys = warm_keys(tasks, catalog)
    todo = warm_up_tasks(tasks, keys)
    failed = {}
    if todo:
        warm_state_dir().mkdir(parents=True, exist_ok=True)
        with _SumoClocks(todo, progress) as clocks:
            for row in executor.map(todo):
                if row[RowCol.status] != "ok":
                    failed[row[RowCol.run_id]] = row.get(RowCol.error)
                clocks.done(row[RowCol.run_id])
    summary = {"distinct": len(set(keys.values())), "computed": len(todo) - len(failed),
               "failed": failed}
    return summary, keys


class _SumoClocks:
    """The progress of ``tasks`` (warm-ups) in seconds of SUMO: those done in full, and
    of those under way what their workers' clocks say (:mod:`sdc.batch.tasks.warm_up_clock`),
    told to ``progress`` every :data:`CLOCKS_READ_EVERY_S` from a thread of its own."""

    def __init__(self, tasks: list[WarmUpTask], progress: Progress):
        self.progress, self.lock, self.stopped = progress, threading.Lock(), threading.Event()
        self.spans = {task.run_id: (task.clock_path, *warm_up_span_s(task.spec))
                      for task in tasks}
        self.total_s = sum(end - begin for _, begin, end in self.spans.values())
        self.finished: set[str] = set()
        self.thread = threading.Thread(target=self._watch, daemon=True)

    def __enter__(self) -> _SumoClocks:
        self._tell()
        self.thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stopped.set()
        self.thread.join()
        self._tell()

    def done(self, run_id: str) -> None:
        with self.lock:
            self.finished.add(run_id)
        self._tell()

    def _watch(self) -> None:
        while not self.stopped.wait(CLOCKS_READ_EVERY_S):
            self._tell()

    def _tell(self) -> None:
        with self.lock:
            simulated = 0.0
            for run_id, (path, begin, end) in self.spans.items():
                clock = end if run_id in self.finished else path and read_clock(path)
                simulated += 0.0 if clock is None else min(max(clock - begin, 0.0), end - begin)
            self.progress(len(self.finished), len(self.spans), simulated, self.total_s)


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
