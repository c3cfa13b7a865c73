"""A sweep's report as numbers: :class:`SweepSummary` (its ``summary.json``), built
from the result rows and the manifest; the columns it groups by."""

from __future__ import annotations

import dataclasses
import itertools

import pandas as pd

from analysis.measures.row_columns import RowCol
from analysis.measures.run_outcome import STATUSES
from analysis.measures.sweep_manifest import SweepManifest
from analysis.measures.world_sharing import world_sharing
from analysis.report.report_files import ReportError
from analysis.report.sweep_world import world_summary
from analysis.stats.gate import Gate, gate
from analysis.stats.rates import (
    CollisionRate,
    Method,
    PairedTest,
    SafeEnvelope,
    StopPossible,
    WarmStates,
    by_controller,
    group_label,
    mcnemar,
    rates_by,
    safe_envelope,
    stop_possible_summary,
    warm_state_summary,
)
from analysis.stats.verdicts import Verdicts, verdict_summary
from scenarios.common.plain_json import json_scalar
from scenarios.spec.sweep_spec import PARAM_PREFIX

SPEED = f"{PARAM_PREFIX}ego.speed_mps"


def varying_parameters(results: pd.DataFrame) -> list[str]:
    return [c for c in results.columns
            if c.startswith(PARAM_PREFIX) and results[c].nunique() > 1]


@dataclasses.dataclass(frozen=True)
class Coverage:
    """What the sweep ran of its plan, and which samples the controllers are compared on."""

    runs_planned: int | None  # None: the manifest does not say
    runs: int
    runs_missing: int | None
    partial: bool
    sweep_status: str | None
    samples: int  # with a run
    samples_compared: int  # that every controller ran
    runs_left_out: int  # of every table: runs of the samples not compared


def coverage(results: pd.DataFrame, manifest: SweepManifest, shared: pd.Index) -> Coverage:
    """The :class:`Coverage` of the results (``shared``: the samples compared)."""
    planned = manifest.runs
    missing = max(0, planned - len(results)) if planned is not None else None
    compared = results[RowCol.sample].isin(shared)
    return Coverage(planned, len(results), missing,
                    bool(missing) or manifest.status not in (None, "complete"),
                    manifest.status, int(results[RowCol.sample].nunique()), len(shared),
                    int((~compared).sum()))


@dataclasses.dataclass(frozen=True)
class SweepSummary:
    """Everything a sweep's report says; :meth:`to_plain` is its ``summary.json``. Its
    parts are typed (:mod:`analysis.stats`); the tables by parameter, the world audit and
    the warm-up's word stay plain records."""

    sweep: str
    runs_planned: int | None
    runs: int
    counts: dict[str, int]  # runs by status: ok, error, timeout
    sweep_status: str | None
    coverage: Coverage
    interval: Method
    warm_states: WarmStates | None  # runs sharing a warm state: clustered intervals
    verdicts: Verdicts | None  # how each controller's runs ended (None: not recorded)
    by_controller: dict[str, CollisionRate]
    by_backend: dict[str, dict[str, CollisionRate]]  # side by side, when several ran
    paired: list[PairedTest]  # McNemar on collisions
    stop_possible: StopPossible | None  # the same where braking alone could have stopped
    by: dict[str, list[dict]]  # rates by parameter
    envelope: list[SafeEnvelope]  # the speed envelope
    gate: Gate | None
    traffic_model: str | None
    sumo_config: list | None
    world: dict  # the world audit and who hit whom
    settling: dict | None = None  # the warm-up's word
    sweep_dir: str | None = None  # where its runs are (the replay commands name it)
    shared_worlds: dict | None = None  # runs that shared a world (shared_world_summary)

    def to_plain(self) -> dict:
        plain = {field.name: getattr(self, field.name) for field in dataclasses.fields(self)}
        return {**plain, "coverage": dataclasses.asdict(self.coverage),
                "warm_states": _recorded(self.warm_states),
                "verdicts": _recorded(self.verdicts),
                "by_controller": _plain_rates(self.by_controller),
                "by_backend": {b: _plain_rates(rates) for b, rates in self.by_backend.items()},
                "paired": [dataclasses.asdict(p) for p in self.paired],
                "stop_possible": _recorded(self.stop_possible),
                "envelope": [dataclasses.asdict(e) for e in self.envelope],
                "gate": dataclasses.asdict(self.gate) if self.gate else None}


def _recorded(part) -> dict:
    """A part that results from before its columns cannot give (None) is ``{"recorded":
    False}``; any other is its fields with ``"recorded": True``."""
    return ({"recorded": False} if part is None
            else {"recorded": True, **dataclasses.asdict(part)})


def _plain_rates(rates: dict[str, CollisionRate]) -> dict[str, dict]:
    return {controller: dataclasses.asdict(rate) for controller, rate in rates.items()}


def build_summary(results: pd.DataFrame, manifest: SweepManifest, by: list[str], method: Method,
                  shared: pd.Index, fail_above: float | None = None,
                  min_completed: float | None = None,
                  max_pedestrian_rate: float | None = None) -> SweepSummary:
    """Everything the report says. Controllers are compared on the ``shared`` samples,
    those every one of them ran (:func:`analysis.stats.verdicts.shared_samples`: all of them,
    unless the sweep is partial or lost runs)."""
    counted = results[results[RowCol.sample].isin(shared)]
    controllers = list(dict.fromkeys(results[RowCol.controller]))
    grouped = {}
    for column in by:
        table = rates_by(counted, column, method)
        grouped[column] = [{**row, "group": group_label(row["group"]),
                            "collision_rate": json_scalar(row["collision_rate"])}
                           for row in table.to_dict(orient="records")]
    status = results[RowCol.status].value_counts()
    return SweepSummary(
        sweep=manifest.sweep_name,
        runs_planned=manifest.runs,
        runs=len(results),
        counts={s: int(status.get(s, 0)) for s in STATUSES},
        sweep_status=manifest.status,
        coverage=coverage(results, manifest, shared),
        interval=method,
        # runs that started from one warm state share their traffic: wider intervals
        warm_states=warm_state_summary(counted),
        verdicts=verdict_summary(counted, method),
        by_controller=by_controller(counted),
        # side by side when a sweep ran on more than one world backend
        by_backend=({str(b): by_controller(rows) for b, rows in
                        counted.groupby(RowCol.backend, sort=False)}
                       if counted[RowCol.backend].nunique() > 1 else {}),
        paired=[mcnemar(counted, a, b) for a, b in itertools.combinations(controllers, 2)],
        # the same where braking alone could have stopped the car before the obstacle
        stop_possible=stop_possible_summary(counted, controllers),
        by=grouped,
        envelope=([safe_envelope(counted, SPEED, c) for c in controllers]
                     if SPEED in counted.columns else []),
        gate=(None if fail_above is None and min_completed is None
              and max_pedestrian_rate is None
              else gate(counted, controllers, fail_above, method, min_completed,
                        max_pedestrian_rate)),
        traffic_model=manifest.traffic_model,
        sumo_config=manifest.sumo_config,
        world=world_summary(counted),
        shared_worlds=world_sharing(results, manifest.egos_per_world),
    )


def by_column(results: pd.DataFrame, name: str) -> str:
    """The column ``--by NAME`` means: a swept parameter's path with or without its
    ``p.`` prefix (``ego.speed_mps`` or ``p.ego.speed_mps``), or any other column."""
    for column in (name, f"{PARAM_PREFIX}{name}"):
        if column in results.columns:
            return column
    known = ", ".join(c for c in results.columns if c.startswith(PARAM_PREFIX)) or "none"
    raise ReportError("--by", f"no column {name!r} (swept parameters: {known})")
