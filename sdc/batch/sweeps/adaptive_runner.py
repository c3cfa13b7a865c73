"""Search and estimate: sweeps whose samples are drawn batch by batch, toward failure.

``sdc search`` and ``sdc estimate`` read a sweep's ``[sweep.params]`` as the
nominal distribution and let a sampler draw each batch from what the previous
ones scored (:mod:`analysis.measures.run_score`): the mode-finding search of
:mod:`analysis.rare.mode_search`, the multilevel importance sampler of
:mod:`analysis.rare.rare_events`.
The batches run on the sweep executors.

The directory is a sweep directory whose plan grows: each batch's runs are
written to ``DIR/plan-parts/`` before they run, rows stream to ``DIR/parts/``,
and both end in ``plan.parquet`` and ``results.parquet``, so ``sdc replay``
and ``sdc report`` read it like any sweep. Each row carries its batch, phase,
importance weight and score (``ADAPTIVE_COLUMNS``); ``DIR/estimate.json`` or
``DIR/search.json`` says where it stands after every batch.

Resuming replays the stored scores through the sampler: its batches depend only
on the sweep's seed and the scores told, so it draws the same batches again
(checked against the stored plan), runs only the runs without a row and goes on.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import time
from collections import Counter
from pathlib import Path
from typing import Literal

import numpy as np
import pandas as pd

from analysis.measures.failure_event import FailureEvent
from analysis.measures.row_columns import RowCol
from analysis.measures.run_score import ScoreKind
from analysis.measures.sweep_manifest import (
    PLAN_SPEC_COLUMN,
    AdaptiveRecord,
    SweepDir,
    SweepManifest,
)
from analysis.rare.adaptive_summary import described_modes, stuck_modes, summary_path
from analysis.rare.failure_modes import OTHER
from analysis.rare.mode_search import ModeSearch
from analysis.rare.proposals import unit_points
from analysis.rare.rare_events import EstimationLoop
from scenarios.common.atomic_write import write_atomic
from scenarios.common.errors import SdcError, SpecError
from scenarios.common.plain_json import json_plain
from scenarios.common.seeding import RUN_SEEDS_STREAM, SAMPLER_STREAM, draw_seeds, stream_rng
from scenarios.spec.controller_ref import controller_label
from scenarios.spec.sweep_plan import PlannedRun, plan_samples
from scenarios.spec.sweep_spec import SweepSpec
from sdc.batch.executors.executor import Executor
from sdc.batch.sweeps.result_store import ResultStore
from sdc.batch.sweeps.sweep_runner import (
    Reporter,
    build_networks,
    end_session,
    invalid_row,
    make_dir,
    members_keys,
    new_manifest,
    open_dir,
    plan_table_of,
    plan_tasks,
    record_job_files,
    record_warm_states,
    start_session,
)
from sdc.batch.sweeps.warm_states import prepare_warm_states, with_warm_state
from sdc.batch.tasks.run_task import TraceMode
from sdc.batch.tasks.task import rows_of
from sdc.run.result_row import adaptive_row, result_schema

Mode = Literal["search", "estimate"]


@dataclasses.dataclass(frozen=True)
class AdaptiveSettings:
    """What a search or an estimate does beyond its sweep file (the CLI's options)."""

    mode: Mode
    controller: str  # one of the sweep's controllers, the one judged
    max_runs: int  # search: --budget; estimate: --max-runs
    batch_size: int
    target_rhw: float | None = None  # estimate only
    score: ScoreKind = "gap"
    elite_fraction: float = 0.1
    stop_after: int | None = None  # search only: failures after which it ends

    def to_plain(self) -> dict:
        return dataclasses.asdict(self)


@dataclasses.dataclass(frozen=True)
class AdaptiveOutcome:
    out_dir: Path
    runs: int  # runs drawn (rows)
    counts: dict[str, int]
    outcomes: dict[str, int]  # ok rows by outcome (analysis.measures.run_outcome.OUTCOMES)
    interrupted: bool
    wall_time_s: float
    summary: dict  # what estimate.json or search.json holds


def check_adaptive(sweep: SweepSpec, settings: AdaptiveSettings) -> None:
    """Wrong use, as :class:`SpecError` naming the field or option."""
    if sweep.sampler == "grid":
        raise SpecError("sweep.sampler", f"{settings.mode} draws its own samples from the "
                        "parameters' distributions; a grid has no distribution to adapt "
                        "(use random, sobol or lhs; the sampler itself is not used)")
    if not any(p.continuous for p in sweep.params):
        raise SpecError("sweep.params", f"{settings.mode} adapts the sampling of continuous "
                        "parameters (uniform, loguniform, normal); this sweep has none")
    if settings.controller not in sweep.controllers:
        raise SpecError("--controller", f"{settings.controller!r} is not one of the sweep's "
                        f"controllers ({', '.join(sweep.controllers)})")
    option = "--budget" if settings.mode == "search" else "--max-runs"
    if settings.max_runs < 2 * settings.batch_size:
        raise SpecError(option, f"{settings.max_runs} runs are too few to adapt: at least two "
                        f"batches of --batch-size {settings.batch_size} "
                        f"({2 * settings.batch_size} runs)")
    if settings.mode == "estimate" and not (settings.target_rhw or 0) > 0:
        raise SpecError("--target-rhw", f"must be > 0, got {settings.target_rhw!r}")


def settings_sha256(sweep: SweepSpec, settings: AdaptiveSettings) -> str:
    """A digest of everything that decides the runs: resuming needs the same."""
    body = [sweep.to_plain(), sweep.base.to_plain(), settings.to_plain()]
    return hashlib.sha256(json.dumps(body, sort_keys=True).encode()).hexdigest()


def _loop(sweep: SweepSpec, settings: AdaptiveSettings) -> EstimationLoop | ModeSearch:
    rng = stream_rng(sweep.seed, SAMPLER_STREAM)
    dims = len(sweep.params)
    if settings.mode == "search":
        return ModeSearch(dims, settings.max_runs, rng, settings.batch_size,
                          stop_after=settings.stop_after, elite_fraction=settings.elite_fraction)
    return EstimationLoop(dims, settings.target_rhw, settings.max_runs, rng,
                          settings.batch_size, elite_fraction=settings.elite_fraction)


def _batch_plan(sweep: SweepSpec, z: np.ndarray, seeds: list[int], first_sample: int,
                width: int) -> list[PlannedRun]:
    u = unit_points(z)
    values = [{p.path: p.at(float(x)) for p, x in zip(sweep.params, row, strict=True)}
              for row in u]
    return plan_samples(sweep, values, seeds, first_sample=first_sample,
                        index_width=width)


class _Runs:
    """The directory's rows and plan, and running a batch's missing runs (a session of
    the manifest starts with it)."""

    def __init__(self, out_dir: Path, sweep: SweepSpec, executor: Executor, reporter: Reporter,
                 traces: TraceMode, settings: AdaptiveSettings, manifest: SweepManifest):
        self.out_dir, self.sweep, self.executor, self.reporter = out_dir, sweep, executor, reporter
        self.traces, self.settings = traces, settings
        self.event = FailureEvent(settings.score)
        self.store = ResultStore(out_dir, result_schema(sweep.param_types, adaptive=True))
        self.plans = ResultStore(out_dir, plan_table_of([], sweep).schema, table=SweepDir.plan,
                                 parts=SweepDir.plan_parts)
        self.rows = {r[RowCol.run_id]: r for r in self.store.read().to_pylist()}
        self.planned = {r[RowCol.run_id]: r[PLAN_SPEC_COLUMN] for r in self.plans.read().select(
            [RowCol.run_id, PLAN_SPEC_COLUMN]).to_pylist()}
        self.trace_dir = out_dir / SweepDir.traces
        self._entered = False
        self.manifest = start_session(out_dir, manifest, executor, traces,
                                      max(0, settings.max_runs - len(self.rows)))

    def close(self) -> None:
        if self._entered:
            self.executor.__exit__(None, None, None)
            self._entered = False

    def _check_plan(self, batch: int, plan: list[PlannedRun]) -> None:
        """Write the batch's plan, or check it against the one stored (a resume)."""
        table = plan_table_of(plan, self.sweep)
        stored = [self.planned.get(r.run_id) for r in plan]
        if all(s is None for s in stored):
            for row in table.to_pylist():
                self.plans.add(row)
            self.plans.flush()  # before any of its runs: replay finds every run's spec
            return
        if stored != table.column(PLAN_SPEC_COLUMN).to_pylist():
            raise SdcError(f"--resume: batch {batch} drawn again differs from the one in "
                           f"{self.out_dir} (another sdc version or sampler); start a new "
                           "directory")

    def run(self, batch: int, phase: str, plan: list[PlannedRun],
            weights: np.ndarray) -> list[dict]:
        """Every run of the batch's row, in plan order (stored ones are not run again)."""
        self._check_plan(batch, plan)
        adaptive = {r.run_id: {"batch": batch, "phase": phase, "weight": float(w)}
                    for r, w in zip(plan, weights, strict=True)}
        todo = [r for r in plan if r.run_id not in self.rows]
        for run in todo:
            if run.spec is None:
                self._add(adaptive_row(invalid_row(run), **adaptive[run.run_id], score=None))
        if self.traces != "none":
            self.trace_dir.mkdir(exist_ok=True)
        tasks = plan_tasks(plan, set(self.rows),
                           None if self.traces == "none" else self.trace_dir, self.traces)
        if tasks:
            build_networks(tasks, self.executor.workers)
            if not self._entered:
                self.executor.__enter__()
                self._entered = True
            warm, keys = prepare_warm_states(tasks, self.executor, self.reporter.warm_states)
            self.manifest = record_warm_states(self.out_dir, self.manifest, warm, keys)
            self.manifest = record_job_files(self.out_dir, self.manifest, tasks)
            keys = members_keys(tasks, keys)
            for task_row in self.executor.map(tasks):
                for row in rows_of(task_row):
                    if row[RowCol.run_id] in self.rows:  # a world's run that had its row
                        continue
                    row = with_warm_state(row, keys)
                    score = self.event.run_score(row)
                    self._add(adaptive_row(row, **adaptive[row[RowCol.run_id]], score=score))
        return [self.rows[r.run_id] for r in plan]

    def _add(self, row: dict) -> None:
        self.store.add(row)
        self.rows[row[RowCol.run_id]] = row
        self.reporter.advance(row)


def _scores(rows: list[dict]) -> np.ndarray:
    """What the sampler is told of the rows' scores (a sample with no run: +inf)."""
    return np.array([FailureEvent.told(r[RowCol.score]) for r in rows])


def run_adaptive(sweep: SweepSpec, out_dir: Path, executor: Executor, reporter: Reporter,
                 settings: AdaptiveSettings, *, traces: TraceMode = "failures",
                 resume: bool = False) -> AdaptiveOutcome:
    """Search or estimate into ``out_dir`` until the loop stops or ``KeyboardInterrupt``."""
    wall_start = time.perf_counter()
    check_adaptive(sweep, settings)
    sweep = dataclasses.replace(sweep, controllers=(settings.controller,))
    out_dir = Path(out_dir)
    digest = settings_sha256(sweep, settings)
    manifest = open_dir(out_dir, digest, resume)
    if manifest is None:
        make_dir(out_dir)
        manifest = new_manifest(sweep, digest, 0, 0).updated(
            adaptive=AdaptiveRecord.from_dict(settings.to_plain()))
    runs = _Runs(out_dir, sweep, executor, reporter, traces, settings, manifest)
    loop = _loop(sweep, settings)
    seed_rng = stream_rng(sweep.seed, RUN_SEEDS_STREAM)
    width = max(5, len(str(settings.max_runs - 1)))
    reporter.start(total=settings.max_runs, done=len(runs.rows),
                   outcomes=Counter(r[RowCol.outcome] for r in runs.rows.values()
                                    if r[RowCol.outcome]),
                   failed=sum(r[RowCol.status] != "ok" for r in runs.rows.values()))
    state, drawn, batch = "running", 0, 0
    try:
        while (z := loop.ask()) is not None:
            phase = "adapt" if loop.adapting else settings.mode
            weights = np.exp(loop.log_weights(z))
            seeds = draw_seeds(seed_rng, len(z))
            rows = runs.run(batch, phase, _batch_plan(sweep, z, seeds, drawn, width), weights)
            loop.tell(z, _scores(rows))
            reporter.set_total(loop.planned_runs)  # the ETA from the runs still planned
            drawn, batch = drawn + len(z), batch + 1
            _write_summary(out_dir, sweep, settings, loop, runs.rows, state)
        state = "finished"
    except KeyboardInterrupt:
        state = "interrupted"
    finally:
        runs.close()
        reporter.stop()
        planned = runs.plans.consolidate().num_rows
        table = runs.store.consolidate()
        manifest = runs.manifest.updated(runs=planned, samples=planned)
        counts, outcomes = end_session(out_dir, manifest, table, planned, state == "finished")
        summary = _write_summary(out_dir, sweep, settings, loop, runs.rows, state)
    return AdaptiveOutcome(out_dir, table.num_rows, counts, outcomes, state == "interrupted",
                           time.perf_counter() - wall_start, summary)


def _write_summary(out_dir: Path, sweep: SweepSpec, settings: AdaptiveSettings,
                   loop: EstimationLoop | ModeSearch, rows: dict[str, dict], state: str) -> dict:
    """Write ``estimate.json`` or ``search.json``; ``state``: running, finished, interrupted
    (``failure_modes`` is None while running)."""
    ordered = sorted(rows.values(), key=lambda r: r[RowCol.run_index])
    modes = stuck = None  # grouping every failure is for the end, not for each batch
    if state != "running":  # a search has no estimation rows, hence no max_weight
        max_weight = loop.max_weight if isinstance(loop, EstimationLoop) else math.inf
        table = pd.DataFrame(ordered)
        modes = described_modes(table, sweep.params, out_dir, max_weight)
        stuck = stuck_modes(table, sweep.params, out_dir)
    summary = {
        "mode": settings.mode, "state": state,
        "controller": controller_label(settings.controller), "score": settings.score,
        "batch_size": settings.batch_size, "max_runs": settings.max_runs,
        "runs": len(rows),
        "adaptation_runs": loop.adaptation_runs,
        "adaptation_levels": [float(g) for g in loop.levels],
        "no_outcome_runs": sum(r[RowCol.status] != "ok" and r[RowCol.score] is not None
                               for r in rows.values()),
        "invalid_samples": sum(r[RowCol.score] is None for r in rows.values()),
        "failure_modes": modes,
        "modes_found": None if modes is None else sum(m["outcome"] != OTHER for m in modes),
        "stuck_modes": stuck,
    }
    if isinstance(loop, ModeSearch):
        event = FailureEvent(settings.score)
        failed = [r[RowCol.run_id] for r in ordered if event.failed(r[RowCol.score])]
        stopped = "failures found" if loop.found_enough else "budget"
        summary.update(stopped=stopped if state == "finished" else None,
                       failures=len(failed), first_failure_run=loop.first_failure_run,
                       first_failure_run_id=failed[0] if failed else None,
                       failure_run_ids=failed)
    else:
        summary.update(_estimate_fields(loop, state))
    path = summary_path(out_dir, settings.mode)
    text = json.dumps(json_plain(summary), indent=2) + "\n"
    write_atomic(path, lambda tmp: Path(tmp).write_text(text))
    return summary


def _estimate_fields(loop: EstimationLoop, state: str) -> dict:
    sampler = loop.sampler
    fields = {"target_rhw": loop.target_rhw, "judged_from": loop.judged_from,
              "level_ess": [float(e) for e in sampler.level_ess],
              "level_uncovered": list(sampler.level_uncovered),
              "max_weight": loop.max_weight,
              "history": [dataclasses.asdict(h) for h in loop.history],
              "stopped": loop.stopped if state == "finished" else None}
    if sampler.estimation_log_weights.size == 0:
        return fields
    return {**fields, **loop.result().to_plain()}
