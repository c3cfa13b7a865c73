"""The result row: its columns (name, type, meaning) and every kind of row.

One row per run (docs/architecture.md, "The result row": add columns, never rename them). The
columns come in parts, each filled by one party:

- ``identity``: which run (the task or ``sdc run`` names it; the spec gives the rest)
- ``status``: ok | error | timeout, and why a run has no outcome
- ``outcome``: what the episode measured (None when the run produced no outcome)
- ``metric``: the outcome columns that :func:`analysis.measures.metrics.trace_metrics` computes
- ``sweep``: where the run sits in its sweep, with one ``p.<path>`` column per
  swept parameter; only in a sweep's ``results.parquet``
- ``adaptive``: the batch, phase, importance weight and score of a run drawn by
  ``sdc search`` or ``sdc estimate`` (:data:`ADAPTIVE_COLUMNS`); only in their
  directories' ``results.parquet``

A run's own row (``Episode.row``, ``sdc run --json``) holds every column but the
sweep's; :func:`sweep_row` adds those. Each constructor returns a complete row,
None where a column does not apply, and raises :class:`RowKeyError` for a
missing or unknown key, so a column cannot vanish on its way to the results.

The columns' names are :class:`analysis.measures.row_columns.RowCol`'s (the one home
of the names sdc writes and analysis reads); this module gives each its type, part and
meaning, in the same order, and refuses to load when the two differ.
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Iterable, Mapping
from typing import Any

import pyarrow as pa

from analysis.measures.row_columns import ADAPTIVE_NAMES, ROW_NAMES, RowCol
from analysis.measures.run_outcome import STUCK_HOLD_S, STUCK_SPEED_MPS
from scenarios.common.plain_json import json_scalar
from scenarios.spec.sweep_spec import PARAM_PREFIX

IDENTITY, STATUS, OUTCOME, METRIC, SWEEP = "identity", "status", "outcome", "metric", "sweep"
ADAPTIVE = "adaptive"


@dataclasses.dataclass(frozen=True)
class Column:
    name: str
    arrow_type: pa.DataType
    part: str  # IDENTITY, STATUS, OUTCOME, METRIC, SWEEP or ADAPTIVE (the module's docstring)
    meaning: str


#: every column but the ``p.<path>`` ones, in the order of ``results.parquet``
COLUMNS: tuple[Column, ...] = (
    Column(RowCol.run_id, pa.string(), IDENTITY,
           "the run's ID: the sweep plan's, or <scenario>-<controller>-<seed> for sdc run"),
    Column(RowCol.run_index, pa.int64(), SWEEP, "position in the sweep's plan"),
    Column(RowCol.sample, pa.int64(), SWEEP, "the scenario sample; its controllers share it"),
    Column(RowCol.world_id, pa.string(), SWEEP,
           "the shared world the run's traffic came from ([sweep] egos_per_world): "
           "w<its first sample>-<controller>; its runs are one cluster in every interval; "
           "None: the run had a world of its own"),
    Column(RowCol.world_slot, pa.int64(), SWEEP,
           "the run's place among its world's runs, from 0; None: a world of its own"),
    Column(RowCol.seed, pa.int64(), IDENTITY,
           "scenario.seed: the run's own randomness (its lidar's noise; on a network its "
           "route) and its traffic's, unless traffic.warm_seed gives the traffic its own "
           "(a warm-state pool's, a shared world's)"),
    Column(RowCol.controller, pa.string(), IDENTITY, "the controller's name"),
    Column(RowCol.backend, pa.string(), IDENTITY,
           "the world simulator: sumo | highway | scripted (a scripted world, no simulator)"),
    Column(RowCol.status, pa.string(), STATUS, "ok | error | timeout"),
    Column(RowCol.error, pa.string(), STATUS, "why an error or timeout row has no outcome"),
    Column(RowCol.termination, pa.string(), OUTCOME, "what ended the run: "
           "collision | duration | route_end"),
    Column(RowCol.collision, pa.bool_(), OUTCOME, "the ego's body touched something"),
    Column(RowCol.collision_with, pa.string(), OUTCOME,
           "none | obstacle | vehicle | road_edge | pedestrian (a person: one of SUMO's, or "
           "a standing person among the obstacles; first whatever else was touched)"),
    Column(RowCol.collision_time_s, pa.float64(), OUTCOME, "simulated time of the collision [s]"),
    Column(RowCol.collision_part, pa.string(), OUTCOME,
           "front | side | rear: the part of the ego's body nearest the contact (sdc.car."
           "collision); None: no collision"),
    Column(RowCol.collision_role, pa.string(), OUTCOME,
           "ran_into: the ego closed in on the contact faster than the other body | "
           "was_hit: the other body did (obstacles and road edges stand still), and always "
           "when the ego stood still (under 0.1 m/s) and the other body moved; None: no "
           "collision"),
    Column(RowCol.collision_vclass, pa.string(), OUTCOME,
           "the SUMO vehicle class (vClass) of the vehicle hit: passenger, truck, bus, "
           "motorcycle, bicycle, ...; pedestrian for a person; in a shared world, "
           "another ego is passenger and another run's barrel barrel; None unless "
           "collision_with is vehicle or pedestrian"),
    Column(RowCol.collision_body, pa.string(), OUTCOME,
           "whose the body hit was: traffic (SUMO's vehicles and persons) | obstacle (the "
           "run's own) | other_ego | other_obstacle (another run's ego or obstacle, in a "
           "shared world: collision_with vehicle, or pedestrian for a standing person); "
           "None: a road edge, or no collision"),
    Column(RowCol.world_overlaps, pa.int64(), OUTCOME,
           "steps in which a traffic vehicle or person overlapped another one or an "
           "obstacle within the sensing radius, two persons aside "
           "(analysis.measures.world_audit), where SUMO's own placement of the two (along their "
           "lanes) does not overlap: what the coupling made up (sdc.run.world_witness); "
           "in a shared world also any overlap with another run's obstacle (one with "
           "another ego is that ego's collision); 0 in a consistent world"),
    Column(RowCol.sumo_overlaps, pa.int64(), OUTCOME,
           "steps in which such an overlap is SUMO's own: its placement of the two along "
           "their lanes overlaps too (vehicles waiting inside each other on a junction's "
           "crossing lanes, a bicycle through a pedestrian); SUMO's world, not the coupling"),
    Column(RowCol.first_overlap_s, pa.float64(), OUTCOME,
           "simulated time of the first step counted in world_overlaps; None: none [s]"),
    Column(RowCol.first_overlap, pa.string(), OUTCOME,
           "that step's overlap in words (analysis.measures.overlap_detail): its time and "
           "step, the two bodies (SUMO's ids where the audit's replay read them, else "
           "traffic[i] / obstacles[j] of the trace; their vehicle classes), how deep they "
           "are inside each other (the shortest move that parts their boxes) [m], whose"),
    Column(RowCol.first_sumo_overlap_s, pa.float64(), OUTCOME,
           "simulated time of the first step counted in sumo_overlaps; None: none [s]"),
    Column(RowCol.first_sumo_overlap, pa.string(), OUTCOME,
           "that step's overlap in words, as first_overlap"),
    Column(RowCol.red_light_violations, pa.int64(), OUTCOME,
           "stop lines the ego's front bumper crossed while their traffic light showed red "
           "for its way (sdc.run.stop_lines); 0 on roads without lights"),
    Column(RowCol.outcome, pa.string(), OUTCOME,
           "how the run ended (analysis/measures/run_outcome.py): completed (passed every obstacle "
           "ahead of its start, no collision) | collided | stuck (neither; under "
           f"{STUCK_SPEED_MPS:g} m/s for the last {STUCK_HOLD_S:g} s or more, and not at a red "
           "light or in the queue before one for less than its cycle) | unfinished "
           "(neither; still moving when it ended, or waiting at a red light for less than its "
           "cycle: the run was too short)"),
    Column(RowCol.progress_m, pa.float64(), OUTCOME,
           "distance the body centre made along the route, measured along the ego's lane [m]"),
    Column(RowCol.time_lost_s, pa.float64(), OUTCOME,
           "the run's time minus the time driving progress_m at the start speed would take; "
           "None: it started at rest [s]"),
    Column(RowCol.collision_speed_mps, pa.float64(), OUTCOME,
           "the ego's speed at the collision; None unless collision [m/s]"),
    Column(RowCol.stood_at_end_s, pa.float64(), OUTCOME,
           f"how long the ego had stood still (under {STUCK_SPEED_MPS:g} m/s) when the run "
           "ended; 0 when it was moving [s]"),
    Column(RowCol.stood_for, pa.string(), OUTCOME,
           "what the ego stood for when the run ended standing (analysis/measures/"
           "stood_for.py): red_light | queue (a vehicle in its path) | give_way | obstacle "
           "| person | crossing | nothing (none of them within 30 m ahead); None: it ended "
           "moving"),
    Column(RowCol.stood_for_gap_m, pa.float64(), OUTCOME,
           "from the front bumper to what it stood for, along the road; None: nothing, or "
           "it ended moving [m]"),
    Column(RowCol.stood_for_cycle_s, pa.float64(), OUTCOME,
           "the cycle of the light it waited for (at a red light, or in the queue before "
           "one); standing less than that is unfinished, not stuck; None: no light [s]"),
    Column(RowCol.min_gap_obstacle_m, pa.float64(), METRIC,
           "smallest distance between the ego's body and any obstacle [m]"),
    Column(RowCol.min_ttc_s, pa.float64(), METRIC,
           "smallest time until the ego's body would touch an obstacle or a vehicle, all "
           "at constant velocities along the road (sdc.car.road_frame); 0 only on contact, "
           "None: never on a course to touch [s]"),
    Column(RowCol.max_drac_mps2, pa.float64(), METRIC,
           "largest deceleration the ego needed to avoid a leader ahead of it along the "
           "road, closing speed^2 / (2 gap); 0: it never closed in on one [m/s^2]"),
    Column(RowCol.min_headway_s, pa.float64(), METRIC,
           "smallest time headway to a leader ahead along the road, gap / ego speed; "
           "None: no leader [s]"),
    Column(RowCol.min_road_edge_gap_m, pa.float64(), OUTCOME,
           "closest approach of a body corner to a road edge, negative beyond it [m]"),
    Column(RowCol.stop_gap_m, pa.float64(), OUTCOME,
           "at the start, from the front bumper to the rear of the nearest obstacle ahead "
           "whose box reaches into the band the body covers along its lane, along the "
           "lane; None: no obstacle in that path [m]"),
    Column(RowCol.stop_possible, pa.bool_(), OUTCOME,
           "braking alone could stop the car before it: start speed^2 / (2 * min(the "
           "vehicle model's max_decel_mps2, friction_mu * g)) <= stop_gap_m, braking from "
           "the first step (analysis.measures.safety.REACTION_TIME_S = 0); None: no obstacle "
           "in the path"),
    Column(RowCol.maneuver_started, pa.bool_(), METRIC,
           "the controller entered a phase named avoid_*"),
    Column(RowCol.detection_range_m, pa.float64(), METRIC,
           "shortest central lidar range as the maneuver started [m]"),
    Column(RowCol.returned_to_lane, pa.bool_(), METRIC,
           "the body centre came back within 0.5 m of its lane's centre for 2 s"),
    Column(RowCol.return_time_s, pa.float64(), METRIC,
           "from the maneuver's start to the start of that hold [s]"),
    Column(RowCol.max_abs_lane_offset_m, pa.float64(), METRIC,
           "largest |offset| of the body centre from its lane's centre [m]"),
    Column(RowCol.sim_time_s, pa.float64(), OUTCOME, "simulated time at the end of the run [s]"),
    Column(RowCol.steps, pa.int64(), OUTCOME, "steps in the trace"),
    Column(RowCol.wall_time_s, pa.float64(), OUTCOME,
           "wall time of the run [s] (of a timeout: until it was stopped)"),
    Column(RowCol.network_vehicles, pa.int64(), OUTCOME,
           "traffic in the whole network as it entered, one step after the ego"),
    Column(RowCol.warm_state, pa.string(), OUTCOME,
           "the warm state the run's traffic started from (its key's first 16 hex "
           "digits); runs that share one share their traffic; None: no warm-up"),
    Column(RowCol.world_egos, pa.int64(), OUTCOME,
           "the runs that shared the run's SUMO world ([sweep] runs_per_world, up to "
           "egos_per_world of them at a time; each ego a body to the others); 1: it ran "
           "alone"),
    Column(RowCol.world_entry_step, pa.int64(), OUTCOME,
           "the step of its shared world at which the run's ego entered it (0: as the "
           "world started; later: as a seat freed, on the world's traffic as it was "
           "then); its world's SUMO stepped at least world_entry_step + steps times; "
           "None: a world of its own"),
    Column(RowCol.trace_sha256, pa.string(), OUTCOME,
           "hash of the trace: same spec and seed, same hash"),
    Column(RowCol.traceback, pa.string(), STATUS, "the Python traceback of a run that raised"),
)


#: the columns a run drawn by ``sdc search`` or ``sdc estimate`` adds, after the ``p.<path>``
ADAPTIVE_COLUMNS: tuple[Column, ...] = (
    Column(RowCol.batch, pa.int64(), ADAPTIVE, "the batch (iteration) of the search or estimate "
           "that drew the run's sample, from 0"),
    Column(RowCol.phase, pa.string(), ADAPTIVE, "adapt: the batch moved the sampling distribution "
           "| estimate: drawn from the frozen one, counted in the estimate"),
    Column(RowCol.weight, pa.float64(), ADAPTIVE, "importance weight of the run's sample: nominal "
           "density / the density it was drawn from"),
    Column(RowCol.score, pa.float64(), ADAPTIVE, "the run's distance from collision that guides "
           "the sampling; <= 0: it collided, or has no outcome (error, timeout); None: its "
           "sample made no valid scenario"),
)


def _check_names() -> None:
    """The columns here are exactly the home's names, in its order (a column added or
    renamed in one place and not the other is a programming error, found at import)."""
    for defined, named in ((COLUMNS, ROW_NAMES), (ADAPTIVE_COLUMNS, ADAPTIVE_NAMES)):
        names = tuple(c.name for c in defined)
        if names != named:
            raise RuntimeError("sdc/run/result_row.py defines the columns "
                               f"{names}, analysis/measures/row_columns.py names {named}")


_check_names()


def _names(*parts: str) -> tuple[str, ...]:
    return tuple(c.name for c in COLUMNS if c.part in parts)


#: a run's own row, in order (every column but the sweep's)
RUN_COLUMNS = _names(IDENTITY, STATUS, OUTCOME, METRIC)
#: what ``sdc run --json`` prints: the run's row but its traceback (which goes to stderr)
JSON_COLUMNS = tuple(n for n in RUN_COLUMNS if n != RowCol.traceback)
#: the columns :func:`analysis.measures.metrics.trace_metrics` returns
METRIC_COLUMNS = _names(METRIC)
_IDENTITY_COLUMNS = _names(IDENTITY)
_ARROW_TYPES = {float: pa.float64(), int: pa.int64(), bool: pa.bool_(), str: pa.string()}


class RowKeyError(ValueError):
    """A row (or part of one) with a key missing, or a key it may not hold: one
    no column defines, or a column this kind of row does not take from its caller."""

    def __init__(self, what: str, missing: Iterable[str], unknown: Iterable[str]):
        self.missing, self.unknown = sorted(missing), sorted(unknown)
        problems = []
        if self.missing:
            problems.append(f"missing {', '.join(self.missing)}")
        if self.unknown:
            problems.append(f"unexpected {', '.join(self.unknown)}")
        super().__init__(f"{what}: {'; '.join(problems)}; the result row's columns are "
                         "defined in sdc/run/result_row.py")


def check_keys(row: Mapping[str, Any], expected: Iterable[str], what: str = "result row") -> None:
    """Raise :class:`RowKeyError` unless ``row``'s keys are exactly ``expected``."""
    expected = set(expected)
    missing, unknown = expected - row.keys(), row.keys() - expected
    if missing or unknown:
        raise RowKeyError(what, missing, unknown)


def _run_row(kind: str, status: str, given: Mapping[str, Any], names: tuple[str, ...]) -> dict:
    """A run's complete row: ``given`` must hold exactly ``names``; the rest is None."""
    check_keys(given, names, f"{kind} row")
    row = dict.fromkeys(RUN_COLUMNS)
    row.update({k: json_scalar(v) for k, v in given.items()}, status=status)
    return row


def ok_row(metrics: Mapping[str, Any], **values: Any) -> dict:
    """The row of a run that ended: ``metrics`` is what ``trace_metrics`` returned
    (exactly :data:`METRIC_COLUMNS`), ``values`` every identity and outcome column."""
    check_keys(metrics, METRIC_COLUMNS, "trace_metrics' result (a metric needs a column)")
    check_keys(values, _names(IDENTITY, OUTCOME), "ok row")
    return _run_row("ok", "ok", {**values, **metrics}, _names(IDENTITY, OUTCOME, METRIC))


def error_row(**values: Any) -> dict:
    """The row of a run that raised or whose worker died: the identity columns,
    ``error`` and ``traceback`` (None when there is none)."""
    return _run_row("error", "error", values,
                    (*_IDENTITY_COLUMNS, RowCol.error, RowCol.traceback))


def raised_at(traceback_text: str | None) -> str | None:
    """Where a run raised, from its ``traceback`` column: ``FILE:LINE in FUNCTION``
    of the innermost frame (None: no traceback)."""
    frames = re.findall(r'^  File "(.*)", line (\d+), in (.*)$', traceback_text or "", re.M)
    if not frames:
        return None
    file, line, function = frames[-1]
    return f"{file}:{line} in {function}"


def timeout_row(**values: Any) -> dict:
    """The row of a run stopped at the run timeout: the identity columns, ``error``
    and ``wall_time_s`` (how long it ran)."""
    return _run_row("timeout", "timeout", values,
                    (*_IDENTITY_COLUMNS, RowCol.error, RowCol.wall_time_s))


@dataclasses.dataclass(frozen=True)
class SweepColumns:
    """A run's place in its sweep: the row's ``sweep`` columns."""

    run_index: int
    sample: int
    params: Mapping[str, Any]  # swept path -> value; the columns p.<path>
    world_id: str | None = None  # its shared world (scenarios/spec/world_seating.py)
    world_slot: int | None = None

    def values(self) -> dict[str, Any]:
        return {RowCol.run_index: self.run_index, RowCol.sample: self.sample,
                RowCol.world_id: self.world_id, RowCol.world_slot: self.world_slot,
                **{PARAM_PREFIX + path: value for path, value in self.params.items()}}


def sweep_row(row: Mapping[str, Any], sweep: SweepColumns) -> dict:
    """A run's row with its sweep's columns, in the order of ``results.parquet``."""
    check_keys(row, RUN_COLUMNS, "run row")
    values = {**row, **{k: json_scalar(v) for k, v in sweep.values().items()}}
    params = [k for k in values if k.startswith(PARAM_PREFIX)]
    return {name: values[name] for name in (*(c.name for c in COLUMNS), *params)}


def invalid_sample_row(sweep: SweepColumns, **values: Any) -> dict:
    """The error row of a planned run whose sample made no valid scenario: the
    identity columns and ``error``, with its sweep's columns."""
    row = _run_row("invalid sample", "error", values, (*_IDENTITY_COLUMNS, RowCol.error))
    return sweep_row(row, sweep)


def adaptive_row(row: Mapping[str, Any], *, batch: int, phase: str, weight: float,
                 score: float | None) -> dict:
    """A sweep row (:func:`sweep_row`) with the :data:`ADAPTIVE_COLUMNS` of its run."""
    values = {RowCol.batch: batch, RowCol.phase: phase, RowCol.weight: weight,
              RowCol.score: score}
    return {**row, **{k: json_scalar(v) for k, v in values.items()}}


def result_schema(param_types: Mapping[str, type], adaptive: bool = False) -> pa.Schema:
    """The columns of a sweep's ``results.parquet``: every column, then one
    ``p.<path>`` column per swept parameter, typed by its values' Python type,
    then (``adaptive``: a search or estimate) the :data:`ADAPTIVE_COLUMNS`."""
    params = [(PARAM_PREFIX + path, _ARROW_TYPES[tp]) for path, tp in param_types.items()]
    extra = [(c.name, c.arrow_type) for c in ADAPTIVE_COLUMNS] if adaptive else []
    return pa.schema([(c.name, c.arrow_type) for c in COLUMNS] + params + extra)
