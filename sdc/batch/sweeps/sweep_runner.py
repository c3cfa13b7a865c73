"""Running a sweep into a directory that survives any interruption.

``DIR/manifest.json`` says what the sweep is and how far it got, ``DIR/plan.parquet``
holds every planned run (its spec as JSON), rows stream into ``DIR/parts/`` as
runs finish and end in ``DIR/results.parquet``. A resumed sweep runs only the
runs that have no row yet, so the finished directory is the same whether or not
it was interrupted.
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import dataclasses
import json
import shlex
import time
from collections import Counter
from pathlib import Path
from typing import Protocol

import pyarrow as pa
import pyarrow.parquet as pq

from analysis.measures.row_columns import RowCol
from analysis.measures.run_outcome import COLLIDED, OUTCOMES, STATUSES
from analysis.measures.sweep_manifest import PLAN_SPEC_COLUMN, Session, SweepDir, SweepManifest
from analysis.measures.world_sharing import world_sharing
from scenarios.common.atomic_write import write_atomic
from scenarios.common.errors import SdcError
from scenarios.scene import traffic_model
from scenarios.spec.sweep_plan import PlannedRun, expand, plan_sha256
from scenarios.spec.sweep_spec import PARAM_PREFIX, SweepSpec
from scenarios.sumo.warm_state import SETTLING_FILE
from scenarios.sumo_net.road_source import road_source
from scenarios.world_backends import prepare_network
from sdc.batch.executors.executor import Executor
from sdc.batch.sweeps.manifest import (
    controller_changes,
    controller_sources,
    git_state,
    network_file_changes,
    now_iso,
    package_versions,
    read_manifest,
    write_manifest,
)
from sdc.batch.sweeps.result_store import ResultStore
from sdc.batch.sweeps.warm_states import prepare_warm_states, with_warm_state, write_settling
from sdc.batch.tasks.job_files import FileCatalog
from sdc.batch.tasks.run_task import RunTask, TraceMode
from sdc.batch.tasks.task import Task, rows_of
from sdc.batch.tasks.world_task import WorldTask
from sdc.run.result_row import SweepColumns, invalid_sample_row, result_schema


class Reporter(Protocol):
    """What a sweep tells about its progress (see :mod:`sdc.batch.sweeps.progress`)."""

    def planning(self, done: int, total: int) -> None: ...  # runs planned so far
    def start(self, total: int, done: int, outcomes: Counter, failed: int) -> None: ...
    def advance(self, row: dict) -> None: ...
    def set_total(self, total: int) -> None: ...  # the runs now planned (an estimate's change)
    def warm_states(self, done: int, total: int, sumo_s: float,
                    sumo_total_s: float) -> None: ...  # warm states done, SUMO's seconds
    def stop(self) -> None: ...


@dataclasses.dataclass(frozen=True)
class SweepOutcome:
    out_dir: Path
    runs: int  # in the plan
    counts: dict[str, int]  # rows by status; "missing" for runs without a row
    outcomes: dict[str, int]  # ok rows by outcome (analysis.measures.run_outcome.OUTCOMES)
    interrupted: bool
    wall_time_s: float


def sweep_columns(run: PlannedRun) -> SweepColumns:
    seat = run.world
    return SweepColumns(run_index=run.index, sample=run.sample, params=run.params,
                        world_id=seat and seat.world_id, world_slot=seat and seat.slot)


def invalid_row(run: PlannedRun) -> dict:
    return invalid_sample_row(sweep_columns(run), run_id=run.run_id, seed=run.seed,
                              controller=run.controller, backend=run.backend, error=run.error)


def plan_table_of(plan: list[PlannedRun], sweep: SweepSpec) -> pa.Table:
    params = result_schema(sweep.param_types)
    rows = [{RowCol.run_id: r.run_id, RowCol.controller: r.controller, RowCol.seed: r.seed,
             RowCol.error: r.error,
             PLAN_SPEC_COLUMN: json.dumps(r.spec.to_plain()) if r.spec else None,
             **sweep_columns(r).values()} for r in plan]
    fields = [params.field(n) for n in (RowCol.run_id, RowCol.run_index, RowCol.sample,
                                        RowCol.world_id, RowCol.world_slot, RowCol.controller,
                                        RowCol.seed, RowCol.error)]
    fields += [pa.field(PLAN_SPEC_COLUMN, pa.string())]
    fields += [f for f in params if f.name.startswith(PARAM_PREFIX)]
    return pa.Table.from_pylist(rows, schema=pa.schema(fields))


def plan_tasks(plan: list[PlannedRun], done: set[str], trace_dir: Path | None,
               traces: TraceMode) -> list[Task]:
    """The tasks of the runs of ``plan`` without a row (``done``: those with one). The
    runs of a shared world go as one task, all of them (it re-simulates the world), a
    run that has its row without a trace path (its row is not taken again)."""
    def task(run: PlannedRun) -> RunTask:
        path = (None if trace_dir is None or run.run_id in done
                else trace_dir / f"{run.run_id}.parquet")
        return RunTask(run.run_id, run.spec, sweep_columns(run), trace_path=path,
                       traces=traces)

    worlds: dict[str, list[PlannedRun]] = {}
    tasks = []
    for run in plan:
        if run.spec is None:
            continue
        if run.world is None:
            if run.run_id not in done:
                tasks.append(task(run))
        else:
            worlds.setdefault(run.world.world_id, []).append(run)
    for world_id, runs in worlds.items():
        if any(run.run_id not in done for run in runs):
            tasks.append(WorldTask.of(world_id, [task(run) for run in runs],
                                      runs[0].world.seats))
    return tasks


def members_keys(tasks: list[Task], keys: dict[str, str]) -> dict[str, str]:
    """``keys`` (warm-state keys by task ID) also by the run IDs of world tasks' runs
    (a task's parts: a world's runs, any other task itself)."""
    return {**keys, **{part.run_id: keys[t.run_id] for t in tasks if t.run_id in keys
                       for part in t.parts()}}


def open_dir(out_dir: Path, digest: str, resume: bool) -> SweepManifest | None:
    """The manifest of the sweep ``out_dir`` holds, checked to be ``digest``'s and resumable;
    None when ``out_dir`` is free for a new sweep (missing or empty)."""
    out_dir = Path(out_dir)
    manifest = read_manifest(out_dir) if out_dir.is_dir() else None
    if manifest is not None:
        if not resume:
            raise SdcError(f"--out: {out_dir} already holds a sweep; pass --resume to "
                           "continue it, or choose another directory")
        if manifest.plan_sha256 != digest:
            made_with = shlex.join(word for text in manifest.overrides or ()
                                   for word in ("--set", text))
            raise SdcError(f"--resume: {out_dir} holds a different sweep "
                           f"({manifest.sweep_name!r}, another plan); "
                           "resume it with the sweep file and options that started it"
                           + (f" (it was made with {made_with})" if made_with else ""))
        changes = controller_changes(manifest) + network_file_changes(manifest)
        if changes:
            raise SdcError(f"--resume: {changes[0]}; the sweep would mix two versions of "
                           "it (restore it, or start a new sweep)")
        return manifest
    if out_dir.exists() and (not out_dir.is_dir() or not _unstarted(out_dir)):
        raise SdcError(f"--out: {out_dir} exists and is not a sweep directory")
    return None


def _unstarted(out_dir: Path) -> bool:
    """Is ``out_dir`` empty, or left by a sweep killed before its manifest (holding only
    its plan, whole or as a temporary file), so a new sweep may take it?"""
    return all(p.name == SweepDir.plan or p.name.startswith(f".{SweepDir.plan}.")
               for p in out_dir.iterdir())


def make_dir(out_dir: Path) -> None:
    try:
        Path(out_dir).mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise SdcError(f"--out: cannot create {out_dir}: {e.strerror or e}") from None


def new_manifest(sweep: SweepSpec, digest: str, runs: int, samples: int,
                 specs: tuple = ()) -> SweepManifest:
    """The manifest of a sweep that has not run yet (``specs``: its runs' scenario
    specs, for what it records of their SUMO configurations; default the base)."""
    return SweepManifest.new(
        sweep=sweep.to_plain(),
        base_scenario=sweep.base.to_plain(),
        **({"overrides": list(sweep.overrides)} if sweep.overrides else {}),
        plan_sha256=digest,
        runs=runs,
        samples=samples,
        versions=package_versions(),
        traffic_model=traffic_model.description(),
        # sumo_config roads: the options of each configuration applied, overridden, not
        sumo_config=[entry for road, step_s in dict.fromkeys(
                         (spec.road, spec.scenario.step_s) for spec in specs or (sweep.base,))
                     if (entry := road_source(road).manifest_entry(step_s)) is not None],
        controllers=controller_sources(sweep.controllers),
        files={},  # what travels with the job: driver path -> field, sha256
        git=git_state(),
        started_at=now_iso(),
        ended_at=None,
        status="running",
        counts={},
        collisions=0,
        sessions=(),
    )


def prepare_dir(out_dir: Path, sweep: SweepSpec, plan: list[PlannedRun],
                resume: bool) -> SweepManifest:
    """Check ``out_dir`` and return its manifest (a new one for a fresh sweep)."""
    digest = plan_sha256(plan)
    manifest = open_dir(out_dir, digest, resume)
    if manifest is not None:
        return manifest
    plan_table = plan_table_of(plan, sweep)  # before the directory: nothing half-made
    make_dir(out_dir)
    write_atomic(Path(out_dir) / SweepDir.plan, lambda tmp: pq.write_table(plan_table, tmp))
    return new_manifest(sweep, digest, len(plan), len({r.sample for r in plan}),
                        tuple(r.spec for r in plan if r.spec is not None))


def build_networks(tasks: list[Task], workers: int) -> None:
    """Build each distinct SUMO road network once, before any worker needs it."""
    roads = list({task.spec.road: None for task in tasks
                  if task.spec.scenario.world_backend.loads_networks})
    with concurrent.futures.ThreadPoolExecutor(max(1, workers)) as pool:
        list(pool.map(prepare_network, roads))


def record_job_files(out_dir: Path, manifest: SweepManifest,
                     tasks: list[Task]) -> SweepManifest:
    """Record in the manifest (and its session) the files the runs read besides
    their specs, by the driver's path, with their sha256: what travels with the
    job. One the driver cannot read is left out here and makes its runs error rows.
    Returns the manifest written."""
    catalog = FileCatalog()
    for task in tasks:
        with contextlib.suppress(SdcError):
            catalog.files(task.spec)
    entries = catalog.manifest_entries()
    manifest = manifest.with_session(files={**(manifest.session.files or {}), **entries})
    manifest = manifest.updated(files={**(manifest.files or {}), **entries})
    write_manifest(out_dir, manifest)
    return manifest


def record_warm_states(out_dir: Path, manifest: SweepManifest, warm: dict,
                       keys: dict[str, str]) -> SweepManifest:
    """Record how many distinct warm states the session's runs start from (and
    which failed to compute; the manifest keeps the largest count of a session), and
    how their traffic settled (:data:`~scenarios.sumo.warm_state.SETTLING_FILE`). Returns
    the manifest (written with the job files, :func:`record_job_files`)."""
    manifest = manifest.with_session(warm_states=warm)
    manifest = manifest.updated(warm_states=max(manifest.warm_states or 0, warm["distinct"]))
    if keys:
        write_settling(out_dir / SETTLING_FILE, list(dict.fromkeys(keys.values())))
    return manifest


def _tally(table: pa.Table) -> tuple[Counter, Counter]:
    """Rows by status, and the ok rows by outcome (completed, collided, ...)."""
    return (Counter(table.column(RowCol.status).to_pylist()),
            Counter(o for o in table.column(RowCol.outcome).to_pylist() if o is not None))


def run_sweep(sweep: SweepSpec, out_dir: Path, executor: Executor, reporter: Reporter, *,
              traces: TraceMode = "failures", resume: bool = False) -> SweepOutcome:
    """Run every planned run of ``sweep`` that has no row in ``out_dir`` yet.

    ``KeyboardInterrupt`` stops the sweep: what finished is kept, and the
    outcome says ``interrupted``.
    """
    wall_start = time.perf_counter()
    out_dir = Path(out_dir)
    plan = expand(sweep, reporter.planning)
    manifest = prepare_dir(out_dir, sweep, plan, resume)
    store = ResultStore(out_dir, result_schema(sweep.param_types))
    stored = store.read()
    done = set(stored.column(RowCol.run_id).to_pylist())
    trace_dir = out_dir / SweepDir.traces
    if traces != "none":
        trace_dir.mkdir(exist_ok=True)
    todo = [run for run in plan if run.run_id not in done]
    tasks = plan_tasks(plan, done, trace_dir if traces != "none" else None, traces)

    manifest = start_session(out_dir, manifest, executor, traces, len(todo))

    statuses, outcomes = _tally(stored)
    reporter.start(total=len(plan), done=len(done), outcomes=outcomes,
                   failed=statuses["error"] + statuses["timeout"])
    interrupted = False
    try:
        for run in todo:
            if run.spec is None:
                row = invalid_row(run)
                store.add(row)
                reporter.advance(row)
        if tasks:
            build_networks(tasks, executor.workers)
            with executor:
                warm, keys = prepare_warm_states(tasks, executor, reporter.warm_states)
                manifest = record_warm_states(out_dir, manifest, warm, keys)
                manifest = record_job_files(out_dir, manifest, tasks)
                keys = members_keys(tasks, keys)
                for task_row in executor.map(tasks):
                    for row in rows_of(task_row):
                        if row[RowCol.run_id] in done:  # a world's run that had its row
                            continue
                        row = with_warm_state(row, keys)
                        store.add(row)
                        reporter.advance(row)
    except KeyboardInterrupt:
        interrupted = True
    finally:
        reporter.stop()
        summary, outcomes = end_session(out_dir, manifest, store.consolidate(), len(plan))
    return SweepOutcome(out_dir, len(plan), summary, outcomes, interrupted,
                        time.perf_counter() - wall_start)


def start_session(out_dir: Path, manifest: SweepManifest, executor: Executor,
                  traces: TraceMode, runs_to_do: int) -> SweepManifest:
    """Record in the manifest that a session (this command) starts running ``out_dir``;
    the manifest written, its last session this one."""
    session = Session.new(started_at=now_iso(), ended_at=None, executor=executor.name,
                          workers=executor.workers, traces=traces, runs_to_do=runs_to_do)
    manifest = manifest.updated(sessions=(*manifest.sessions, session), status="running")
    write_manifest(out_dir, manifest)
    return manifest


def end_session(out_dir: Path, manifest: SweepManifest, table: pa.Table,
                planned: int, finished: bool | None = None
                ) -> tuple[dict[str, int], dict[str, int]]:
    """Record the session's end and the rows' counts (``missing``: planned runs without
    a row); the sweep is complete when ``finished`` (default: nothing missing).
    Returns the counts by status and the ok rows' by outcome."""
    counts, by_outcome = _tally(table)
    summary = {s: counts.get(s, 0) for s in STATUSES}
    summary["missing"] = planned - table.num_rows
    outcomes = {o: by_outcome.get(o, 0) for o in OUTCOMES}
    finished = not summary["missing"] if finished is None else finished
    ended_at = now_iso()
    asked = manifest.egos_per_world
    sharing = world_sharing(table.to_pandas(), asked) if asked > 1 else None
    manifest = manifest.with_session(ended_at=ended_at).updated(
        ended_at=ended_at, counts=summary, collisions=outcomes[COLLIDED], outcomes=outcomes,
        status="complete" if finished else "interrupted",
        **({"shared_worlds": sharing} if sharing else {}))
    write_manifest(out_dir, manifest)
    return summary, outcomes
