"""One run as a unit of work: a task in, a result row out, in any process.

:meth:`RunTask.execute` is what every executor runs in its workers for a run. It
never raises for a failure of the run itself: that becomes a row with ``status``
error.
"""

from __future__ import annotations

import dataclasses
import traceback
from collections.abc import Sequence
from pathlib import Path
from typing import Literal

from analysis.measures.row_columns import RowCol
from analysis.measures.run_outcome import COMPLETED
from analysis.measures.trace_columns import TraceMeta
from scenarios.spec.scenario_spec import ScenarioSpec
from sdc.batch.tasks.job_files import JobFile
from sdc.batch.tasks.task import OneRowTask
from sdc.run.result_row import SweepColumns, sweep_row

TraceMode = Literal["none", "failures", "all"]


@dataclasses.dataclass(frozen=True)
class RunTask(OneRowTask):
    """What a worker needs for one run. ``sweep``: the run's sweep columns, for its row.

    An executor fills ``files`` on the driver (what the run reads besides its
    spec, :mod:`sdc.batch.tasks.job_files`); a worker runs a copy whose ``spec`` names
    its own copies of them, ``cache_dir`` holding the cached ones, and whose
    ``recorded_spec`` is the driver's spec, for the trace's metadata
    (:mod:`sdc.batch.executors.worker_files`) and whose ``warm_state`` is its copy of
    the warm state the run starts from, when one travels with the job.
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

    def execute(self) -> dict:
        """Run it and return its result row; write its trace when asked to."""
        from sdc.run.episode import run_episode  # keeps importers that never run fast

        try:
            episode = run_episode(self.spec, run_id=self.run_id, cache_dir=self.cache_dir,
                                  warm_state=self.warm_state)
        except Exception as e:  # the run's own failure is an outcome row, not a crash
            return self.error_row(f"{type(e).__name__}: {e}", traceback.format_exc())
        return self.delivered(episode)

    def delivered(self, episode) -> dict:
        """``episode``'s row as this run's, its trace written when asked to."""
        wanted = self.traces == "all" or (self.traces == "failures"
                                          and episode.row[RowCol.outcome] != COMPLETED)
        if self.trace_path is not None and wanted:
            if self.recorded_spec is not None:  # the driver's paths, not a worker's copies
                _record_driver_paths(episode.metadata, self.recorded_spec)
            episode.write_trace(self.trace_path)
        return self.row(episode.row)

    def row(self, row: dict) -> dict:
        """A run's row as this task's: with its sweep's columns when it has them."""
        return row if self.sweep is None else sweep_row(row, self.sweep)

    def on_worker(self, spec: ScenarioSpec, cache_dir: Path, warm_state: Path | None) -> RunTask:
        return dataclasses.replace(self, spec=spec, cache_dir=cache_dir, recorded_spec=self.spec,
                                   warm_state=self.warm_state if warm_state is None
                                   else warm_state)

    def outputs(self) -> tuple[Path | None]:
        return (self.trace_path,)

    def writing_to(self, paths: Sequence[Path | None]) -> RunTask:
        (path,) = paths
        return dataclasses.replace(self, trace_path=path)


def _record_driver_paths(metadata: dict, spec: ScenarioSpec) -> None:
    metadata[TraceMeta.spec] = spec.to_plain()
    if "net_file" in metadata[TraceMeta.road] and spec.road.net_file is not None:
        metadata[TraceMeta.road]["net_file"] = spec.road.net_file
