"""What every kind of task offers the executors that run it, and what the tasks of
one row share.

A task is a unit of work an executor ships to a worker (pickled: every kind is a
frozen dataclass) and gets a row back from. Three kinds, a class each:
:class:`~sdc.batch.tasks.run_task.RunTask` (one run),
:class:`~sdc.batch.tasks.warm_up_task.WarmUpTask` (a warm state computed before the
runs that start from it) and :class:`~sdc.batch.tasks.world_task.WorldTask` (the runs
of one shared world, together). An executor never asks which kind it holds: it
calls what :class:`Task` names.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Protocol, Self

from analysis.measures.row_columns import RowCol
from scenarios.spec.scenario_spec import ScenarioSpec
from sdc.batch.tasks.job_files import JobFile
from sdc.run.result_row import error_row, timeout_row

#: the key of the rows of a task's parts in its row, when they are not its own
#: (a world task's: its runs' rows)
WORLD_ROWS = "world_rows"


class Task(Protocol):
    """What an executor does with a task, whatever its kind.

    Its ``files`` are what it reads besides its spec (filled on the driver,
    :func:`~sdc.batch.tasks.job_files.with_files`); a worker runs :meth:`on_worker`'s
    copy, on its own copies of them. Its row holds one row per part (:meth:`parts`:
    a world's runs; any other task itself), and each part may write one file for the
    driver (:meth:`outputs`): a worker writes it to a scratch path of its own
    (:meth:`writing_to`), and the driver, given its bytes, writes it where the task
    asked.
    """

    @property
    def run_id(self) -> str: ...
    @property
    def spec(self) -> ScenarioSpec: ...  # whose files travel with it
    @property
    def files(self) -> tuple[JobFile, ...]: ...

    def execute(self) -> dict:
        """Do the work in this process and return the row; a failure of the work itself
        is an error row, never an exception."""

    def error_row(self, error: str, traceback_text: str | None = None) -> dict:
        """The row when it raised, its worker died or a file of it could not be had."""

    def timeout_row(self, error: str, wall_time_s: float) -> dict:
        """The row when it was stopped at its wall limit (:meth:`wall_limit_s`)."""

    def wall_limit_s(self, run_timeout_s: float) -> float:
        """Its wall limit under the run timeout of ``run_timeout_s`` a run."""

    def overrun_text(self, run_timeout_s: float) -> str:
        """What its timeout row says it exceeded."""

    def on_worker(self, spec: ScenarioSpec, cache_dir: Path, warm_state: Path | None) -> Self:
        """This task as a worker runs it: ``spec`` naming the worker's copies of its
        files, ``cache_dir`` holding the cached one, ``warm_state`` the copy of the warm
        state it starts from (None: none travelled)."""

    def parts(self) -> tuple[Task, ...]:
        """The tasks whose rows its row holds, in order."""

    def joined(self, rows: Sequence[dict]) -> dict:
        """Its row, made of its parts' rows."""

    def outputs(self) -> tuple[Path | None, ...]:
        """Where the driver wants the file each part writes (None: it writes none)."""

    def writing_to(self, paths: Sequence[Path | None]) -> Self:
        """This task writing its parts' files to ``paths`` instead (:meth:`outputs`)."""


def rows_of(row: dict) -> list[dict]:
    """The result rows in a task's row, in the order of its parts: a world task's runs'
    rows, else the row."""
    return row.get(WORLD_ROWS, [row])


def execute(task: Task) -> dict:
    """Do ``task`` in this process and return its row: what the executors' workers
    run unless they are given another function."""
    return task.execute()


def run_identity(run_id: str, spec: ScenarioSpec) -> dict:
    """The columns that name a run in its error and timeout rows."""
    return {RowCol.run_id: run_id, RowCol.seed: spec.scenario.seed,
            RowCol.controller: spec.controller.label, RowCol.backend: spec.scenario.backend}


class OneRowTask:
    """What the tasks whose row is their own (a run, a warm-up) share: their error and
    timeout rows name ``run_id`` and ``spec``'s seed, controller and backend, they are
    their own only part, and their wall limit is the run timeout."""

    run_id: str
    spec: ScenarioSpec

    def row(self, row: dict) -> dict:
        """A row as this task's (a run's: with its sweep's columns)."""
        return row

    def error_row(self, error: str, traceback_text: str | None = None) -> dict:
        return self.row(error_row(**run_identity(self.run_id, self.spec), error=error,
                                  traceback=traceback_text))

    def timeout_row(self, error: str, wall_time_s: float) -> dict:
        return self.row(timeout_row(**run_identity(self.run_id, self.spec), error=error,
                                    wall_time_s=wall_time_s))

    def wall_limit_s(self, run_timeout_s: float) -> float:
        return run_timeout_s

    def overrun_text(self, run_timeout_s: float) -> str:
        return f"run exceeded the run timeout of {run_timeout_s:g} s"

    def parts(self) -> tuple[Self]:
        return (self,)

    def joined(self, rows: Sequence[dict]) -> dict:
        (row,) = rows
        return row
