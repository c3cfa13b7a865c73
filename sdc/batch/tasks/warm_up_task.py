"""A warm state computed as a unit of work, before the runs that start from it
(:mod:`sdc.batch.sweeps.warm_states` makes these tasks and runs them)."""

from __future__ import annotations

import dataclasses
import traceback
from collections.abc import Sequence
from pathlib import Path

from analysis.measures.row_columns import RowCol
from scenarios.common.atomic_write import write_atomic
from scenarios.spec.scenario_spec import ScenarioSpec
from sdc.batch.tasks.job_files import JobFile
from sdc.batch.tasks.task import OneRowTask
from sdc.batch.tasks.warm_up_clock import ClockWriter


@dataclasses.dataclass(frozen=True)
class WarmUpTask(OneRowTask):
    """Compute the warm state of ``spec`` and write its file to ``state_path``
    (``scenarios/sumo/warm_state.py``), and SUMO's clock on the way to ``clock_path``,
    the driver's path, which a worker on another machine may not reach
    (:mod:`sdc.batch.tasks.warm_up_clock`). On a worker, ``spec`` names its copies of
    the road's files and ``cache_dir`` holds the cached one, as a run's."""

    run_id: str
    spec: ScenarioSpec
    state_path: Path
    clock_path: Path | None = None  # where its SUMO clock goes, for progress
    files: tuple[JobFile, ...] = ()
    cache_dir: Path | None = None  # where it finds built networks and road edges

    def execute(self) -> dict:
        """Compute (or find in this machine's cache) the warm state and write its file
        to ``state_path``; the row says ok or why not."""
        from scenarios.world_backends import warm_state_file

        clock = ClockWriter(self.clock_path) if self.clock_path else None
        try:
            data = warm_state_file(self.spec, self.cache_dir, on_sample=clock)
            write_atomic(self.state_path, lambda tmp: tmp.write_bytes(data))
        except Exception as e:  # noqa: BLE001 - its runs compute it themselves, or fail alike
            return self.error_row(f"{type(e).__name__}: {e}", traceback.format_exc())
        finally:
            if clock is not None:
                clock.remove()
        return {RowCol.run_id: self.run_id, RowCol.status: "ok"}

    def on_worker(self, spec: ScenarioSpec, cache_dir: Path,
                  warm_state: Path | None) -> WarmUpTask:
        return dataclasses.replace(self, spec=spec, cache_dir=cache_dir)  # it makes its state

    def outputs(self) -> tuple[Path]:
        return (self.state_path,)

    def writing_to(self, paths: Sequence[Path | None]) -> WarmUpTask:
        (path,) = paths
        return dataclasses.replace(self, state_path=path)
