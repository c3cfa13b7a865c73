"""The runs of one shared world (:mod:`sdc.run.shared_world`) as one unit of work:
they re-simulate their world together, in one worker, and its row holds theirs."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from pathlib import Path

from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.spec.world_seating import on_world_road
from sdc.batch.tasks.job_files import JobFile
from sdc.batch.tasks.run_task import RunTask
from sdc.batch.tasks.task import WORLD_ROWS


@dataclasses.dataclass(frozen=True)
class WorldTask:
    """The runs of one shared world, its ``members`` in slot order (their specs share
    its world fields): ``run_id`` is the world's, ``spec`` the first run's (the files
    they share travel once, and on a worker ``spec`` names its copies of them, as a
    run's does; ``recorded_spec`` is then the driver's, and each run's trace records
    its own driver spec), its row holds one row per run
    (:func:`~sdc.batch.tasks.task.rows_of`)."""

    run_id: str
    spec: ScenarioSpec
    members: tuple[RunTask, ...]
    seats: int  # the egos its world holds at a time
    files: tuple[JobFile, ...] = ()
    cache_dir: Path | None = None  # where its runs find built networks and road edges
    recorded_spec: ScenarioSpec | None = None  # the driver's spec, when on a worker's copies
    warm_state: Path | None = None  # the worker's copy of the world's warm state

    @classmethod
    def of(cls, world_id: str, members: Sequence[RunTask], seats: int) -> WorldTask:
        """The task of ``members``, the runs of the world ``world_id``, ``seats`` of them
        at a time."""
        return cls(world_id, members[0].spec, tuple(members), seats)

    def execute(self) -> dict:
        """Run its runs together (:func:`sdc.run.shared_world.run_group`), on the files
        its worker holds for the world (``spec``'s): one row each, a trace each when
        asked to."""
        from sdc.run.shared_world import Failed, run_group

        local = self.spec
        specs = [dataclasses.replace(on_world_road(m.spec, local), controller=dataclasses.replace(
            m.spec.controller, name=local.controller.name)) for m in self.members]
        outcomes = run_group(specs, [m.run_id for m in self.members], self.seats,
                             cache_dir=self.cache_dir, warm_state=self.warm_state)
        rows = []
        for member, outcome in zip(self.members, outcomes, strict=True):
            if isinstance(outcome, Failed):
                rows.append(member.error_row(outcome.error, outcome.traceback))
            else:
                recorded = member.spec if self.recorded_spec is not None else None
                rows.append(dataclasses.replace(member, recorded_spec=recorded)
                            .delivered(outcome))
        return self.joined(rows)

    def error_row(self, error: str, traceback_text: str | None = None) -> dict:
        """Each run's error row."""
        return self.joined([m.error_row(error, traceback_text) for m in self.members])

    def timeout_row(self, error: str, wall_time_s: float) -> dict:
        """Each run's timeout row."""
        return self.joined([m.timeout_row(error, wall_time_s) for m in self.members])

    def wall_limit_s(self, run_timeout_s: float) -> float:
        """The world's task holds its runs' time: the run timeout times its runs."""
        return run_timeout_s * max(1, len(self.members))

    def overrun_text(self, run_timeout_s: float) -> str:
        return (f"its world of {len(self.members)} runs exceeded "
                f"{self.wall_limit_s(run_timeout_s):g} s (the run timeout of "
                f"{run_timeout_s:g} s a run)")

    def on_worker(self, spec: ScenarioSpec, cache_dir: Path,
                  warm_state: Path | None) -> WorldTask:
        return dataclasses.replace(self, spec=spec, cache_dir=cache_dir, recorded_spec=self.spec,
                                   warm_state=self.warm_state if warm_state is None
                                   else warm_state)

    def parts(self) -> tuple[RunTask, ...]:
        return self.members

    def joined(self, rows: Sequence[dict]) -> dict:
        return {WORLD_ROWS: list(rows)}

    def outputs(self) -> tuple[Path | None, ...]:
        return tuple(m.trace_path for m in self.members)

    def writing_to(self, paths: Sequence[Path | None]) -> WorldTask:
        return dataclasses.replace(self, members=tuple(
            m.writing_to((path,)) for m, path in zip(self.members, paths, strict=True)))
