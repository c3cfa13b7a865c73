"""Re-simulating one run of a sweep exactly, and finding where two traces part.

A sweep directory holds every planned run's spec (``plan.parquet``) and its
result row (``results.parquet`` with ``trace_sha256``); when traces were kept,
``traces/<run_id>.parquet`` holds the recorded steps, which locate a divergence
to its first step and field.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc

from analysis.measures.commands import kept_trace_path
from analysis.measures.row_columns import RowCol
from analysis.measures.sweep_manifest import PLAN_SPEC_COLUMN, SweepDir, SweepManifest
from analysis.measures.trace_columns import TraceCol
from analysis.measures.trace_file import FLOAT_COLUMNS, Trace
from scenarios.common.errors import FileError, SdcError, SpecError
from scenarios.common.file_read import read_parquet
from scenarios.spec.scenario_spec import ScenarioSpec
from sdc.batch.sweeps.manifest import controller_changes, package_versions, read_manifest

_PLAN_COLUMNS = (RowCol.run_id, PLAN_SPEC_COLUMN, RowCol.error)
_WORLD_COLUMNS = (RowCol.world_id, RowCol.world_slot)  # in the plans of sweeps with shared worlds
#: what a replay compares
_RESULT_COLUMNS = (RowCol.run_id, RowCol.status, RowCol.error, RowCol.trace_sha256)


@dataclasses.dataclass(frozen=True)
class Divergence:
    step: int
    field: str
    recorded: Any
    replayed: Any

    def describe(self) -> str:
        return (f"diverged at step {self.step}, field {self.field}: recorded {self.recorded!r}, "
                f"replayed {self.replayed!r}")


@dataclasses.dataclass(frozen=True)
class RecordedRun:
    run_id: str
    spec: ScenarioSpec
    row: dict | None  # its result row; None when the sweep has not run it yet
    trace_path: Path | None  # the recorded trace, when the sweep kept it
    manifest: SweepManifest
    #: the runs of its shared world in slot order (their IDs and specs), itself among
    #: them; None: it had a world of its own
    world: tuple[list[str], list[ScenarioSpec]] | None = None


def load_recorded_run(sweep_dir: Path, run_id: str) -> RecordedRun:
    """The spec, result row and trace of ``run_id`` in a sweep directory."""
    sweep_dir = Path(sweep_dir)
    manifest = read_manifest(sweep_dir) if sweep_dir.is_dir() else None
    plan_path = sweep_dir / SweepDir.plan
    # a search or estimate that is running (or was killed) holds its plan in parts
    plan_files = [plan_path] if plan_path.exists() else []
    plan_files += sorted((sweep_dir / SweepDir.plan_parts).glob("part-*.parquet"))
    if manifest is None or not plan_files:
        raise SdcError(f"DIR: {sweep_dir} is not a sweep directory (no {SweepDir.manifest})")
    tables = [read_parquet(f, "the plan file", required=_PLAN_COLUMNS) for f in plan_files]
    columns = list(_PLAN_COLUMNS) + [c for c in _WORLD_COLUMNS
                                     if all(c in t.column_names for t in tables)]
    plan = pa.concat_tables(t.select(columns) for t in tables).to_pandas()
    match = plan[plan[RowCol.run_id] == run_id]
    if match.empty:
        shown = ", ".join(map(str, plan[RowCol.run_id].head(4)))
        raise SdcError(f"--run: no run {run_id!r} in {sweep_dir} (runs: {shown}, ...)")
    planned = match.iloc[0]
    if planned[PLAN_SPEC_COLUMN] is None:
        raise SdcError(f"--run: {run_id} has no scenario to replay: {planned[RowCol.error]}")
    spec = _planned_spec(planned[PLAN_SPEC_COLUMN], plan_path, run_id)
    results = sweep_dir / SweepDir.results
    row = None
    if results.exists():
        table = read_parquet(results, "the results file", required=_RESULT_COLUMNS)
        rows = table.filter(pc.field(RowCol.run_id) == run_id).to_pylist()
        row = rows[0] if rows else None
    trace = kept_trace_path(sweep_dir, run_id)
    world = None
    if RowCol.world_id in plan.columns and isinstance(planned[RowCol.world_id], str):  # null: NaN
        runs = plan[plan[RowCol.world_id] == planned[RowCol.world_id]].sort_values(
            RowCol.world_slot)
        world = (list(runs[RowCol.run_id]),
                 [_planned_spec(j, plan_path, r) for r, j in
                  zip(runs[RowCol.run_id], runs[PLAN_SPEC_COLUMN], strict=True)])
    return RecordedRun(run_id, spec, row, trace if trace.exists() else None, manifest, world)


def _planned_spec(spec_json: str, plan_path: Path, run_id: str) -> ScenarioSpec:
    try:
        return ScenarioSpec.from_plain(json.loads(spec_json))
    except (TypeError, ValueError, RecursionError) as e:  # JSONDecodeError: a ValueError
        raise FileError(plan_path, f"the plan file holds no readable spec for {run_id} "
                                   f"({e})") from None
    except SpecError as e:
        raise FileError(plan_path, f"the plan file is from another sdc version (the spec "
                                   f"of {run_id}: {e})") from None


def version_warnings(manifest: SweepManifest) -> list[str]:
    """One line per package whose version differs from the sweep's, and per
    plug-in controller whose file changed since."""
    now = package_versions()
    recorded = manifest.versions or {}
    return ([f"warning: the sweep ran with {name} {recorded[name]}, this is {now.get(name)}"
             for name in recorded if name != "ray" and recorded[name] != now.get(name)]
            + [f"warning: {line}" for line in controller_changes(manifest)])


def _first_float_mismatch(a: np.ndarray, b: np.ndarray) -> int | None:
    differ = ~((a == b) | (np.isnan(a) & np.isnan(b)))
    return int(np.argmax(differ)) if differ.any() else None


def first_divergence(recorded: Trace, replayed: Trace) -> Divergence | None:
    """The earliest step (and, on a tie, the first field in file order) where the
    traces differ, or None when they are identical."""
    n = min(len(recorded), len(replayed))
    found: list[Divergence] = []
    for name in FLOAT_COLUMNS:
        a, b = recorded.floats[name][:n], replayed.floats[name][:n]
        k = _first_float_mismatch(a, b)
        if k is not None:
            found.append(Divergence(k, name, float(a[k]), float(b[k])))
    for name in (TraceCol.phase, TraceCol.traffic_class):
        rows_a, rows_b = getattr(recorded, name), getattr(replayed, name)
        k = next((k for k in range(n) if rows_a[k] != rows_b[k]), None)
        if k is not None:
            found.append(Divergence(k, name, str(rows_a[k]), str(rows_b[k])))
    k = next((k for k in range(n)
              if not np.array_equal(recorded.bodies(k), replayed.bodies(k))), None)
    if k is not None:
        found.append(Divergence(k, TraceCol.traffic_body, str(recorded.bodies(k)),
                                str(replayed.bodies(k))))
    for name in (TraceCol.lidar, TraceCol.traffic):
        rows_a, rows_b = getattr(recorded, name), getattr(replayed, name)
        for k in range(n):
            a, b = np.asarray(rows_a[k]), np.asarray(rows_b[k])
            if a.shape != b.shape:
                found.append(Divergence(k, f"{name} (length)", len(a), len(b)))
                break
            i = _first_float_mismatch(a, b)
            if i is not None:
                found.append(Divergence(k, f"{name}[{i}]", float(a[i]), float(b[i])))
                break
    if found:
        return min(found, key=lambda d: d.step)  # min keeps the first of equal steps
    if len(recorded) != len(replayed):
        return Divergence(n, "steps", len(recorded), len(replayed))
    return None


def replay_verdict(row: dict | None, recorded_trace: Trace | None, replayed: Trace,
                   sweep_dir: Path, run_id: str) -> tuple[bool, str]:
    """Whether a replay diverged from its recorded run, and the line that says so.

    ``row``: the recorded result row (None when the sweep has none yet);
    ``recorded_trace``: the recorded steps, when the sweep kept them. A replay is
    identical only when it can be compared and its steps and sha256 both agree;
    anything that cannot be compared counts as diverged.
    """
    replayed_sha = replayed.sha256()
    if row is None:
        return True, f"not comparable: {sweep_dir} has no result for {run_id} yet"
    if row[RowCol.status] != "ok":
        return True, (f"not comparable: the recorded run ended with status {row[RowCol.status]}: "
                      f"{row[RowCol.error]}")
    if recorded_trace is not None:  # the recorded steps: compare step by step
        divergence = first_divergence(recorded_trace, replayed)
        if divergence is not None:
            return True, f"DIVERGED: {divergence.describe()}"
        if row[RowCol.trace_sha256] != replayed_sha:
            return True, (f"DIVERGED: the replay equals the recorded trace file, but its "
                          f"sha256 {replayed_sha} is not the result row's "
                          f"{row[RowCol.trace_sha256]}")
    elif row[RowCol.trace_sha256] != replayed_sha:
        return True, (f"DIVERGED: trace sha256 {replayed_sha} != recorded "
                      f"{row[RowCol.trace_sha256]} (the sweep kept no trace of this run to find "
                      "the step; sweep with --traces all)")
    return False, f"identical: trace sha256 {replayed_sha}"
