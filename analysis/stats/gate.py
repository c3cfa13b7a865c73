"""The CI gate of ``sdc report``: which controllers fail it, and why.

A controller fails when its collision rate may exceed ``--fail-above`` (the upper
end of its 95% interval, error and timeout runs counted as collisions), or when
its rate of runs completed without a collision may fall short of
``--min-completed`` (the lower end, error and timeout runs counted as not
completed), or when its rate of collisions with people may exceed
``--max-pedestrian-rate`` (people held to a stricter bound than the rest; error and
timeout runs counted as such collisions). The intervals are clustered by warm state.
Missing evidence never passes: a controller without runs has the bounds 100% and 0%.
"""

from __future__ import annotations

import dataclasses

import pandas as pd

from analysis.measures.row_columns import RowCol
from analysis.measures.run_outcome import STATUSES
from analysis.stats.rates import Method, flag_interval, upper_bound_counting_failures
from analysis.stats.verdicts import completed_runs, percent
from scenarios.spec.bodies import PEDESTRIAN


@dataclasses.dataclass(frozen=True)
class Gate:
    """The gate's options, per controller its 95% bounds and their design effects, and
    the controllers that failed it (``failed``, in order) with their ``reasons``."""

    rate: float | None  # --fail-above
    min_completed: float | None
    upper_bounds: dict[str, float]  # of the collision rate
    design_effects: dict[str, float]
    completed_lower_bounds: dict[str, float]
    completed_design_effects: dict[str, float]
    failed: list[str]
    reasons: dict[str, list[str]]
    max_pedestrian_rate: float | None = None
    pedestrian_upper_bounds: dict[str, float] = dataclasses.field(default_factory=dict)
    pedestrian_design_effects: dict[str, float] = dataclasses.field(default_factory=dict)


def gate(results: pd.DataFrame, controllers: list[str], fail_above: float | None,
         method: Method, min_completed: float | None = None,
         max_pedestrian_rate: float | None = None) -> Gate:
    """The :class:`Gate` on ``results``."""
    upper, lower, effects, completed_effects, reasons = {}, {}, {}, {}, {}
    people, people_effects = {}, {}
    for c in controllers:
        rows = results[results[RowCol.controller] == c]
        why = []
        if fail_above is not None:
            upper[c], effects[c] = upper_bound_counting_failures(rows, method)
            if upper[c] > fail_above:
                why.append(f"collision rate up to {percent(upper[c])}, over --fail-above "
                           f"{fail_above:g}")
        if max_pedestrian_rate is not None:
            people[c], people_effects[c] = upper_bound_counting_failures(rows, method,
                                                                         PEDESTRIAN)
            if people[c] > max_pedestrian_rate:
                why.append(f"collisions with people up to {percent(people[c])}, over "
                           f"--max-pedestrian-rate {max_pedestrian_rate:g}")
        if min_completed is not None:
            counted = rows[rows[RowCol.status].isin(STATUSES)]
            (lower[c], _), counts = flag_interval(completed_runs(counted), counted, method)
            completed_effects[c] = counts.deff
            if lower[c] < min_completed:
                why.append(f"completed as few as {percent(lower[c])}, under --min-completed "
                           f"{min_completed:g}")
        if why:
            reasons[c] = why
    return Gate(fail_above, min_completed, upper, effects, lower, completed_effects,
                list(reasons), reasons, max_pedestrian_rate, people, people_effects)


def gate_bounds_line(gate: Gate) -> str:
    """The bounds the gate judged, per controller (and the design effects that widened
    them, where runs shared a warm state)."""
    parts = []
    if gate.rate is not None:
        parts.append("collision rate at most (errors and timeouts counted as collisions): "
                     + _bounds(gate.upper_bounds, gate.design_effects))
    if gate.min_completed is not None:
        parts.append("completed at least (errors and timeouts counted as not completed): "
                     + _bounds(gate.completed_lower_bounds, gate.completed_design_effects))
    if gate.max_pedestrian_rate is not None:
        parts.append("collisions with people at most (errors and timeouts counted as such): "
                     + _bounds(gate.pedestrian_upper_bounds, gate.pedestrian_design_effects))
    return "gate, 95% bounds: " + "; ".join(parts)


def _bounds(bounds: dict[str, float], effects: dict[str, float]) -> str:
    text = ", ".join(f"{c} {percent(b)}" for c, b in bounds.items())
    if all(effects.get(c, 1) == 1 for c in bounds):
        return text
    return (text + " (widened for runs sharing a warm state, design effects "
            + ", ".join(f"{c} {effects[c]:.2f}" for c in bounds) + ")")


def gate_verdict_line(gate: Gate) -> str:
    """``gate passed`` or ``gate FAILED:`` with each failing controller and why."""
    options = " ".join(f"{name} {value:g}" for name, value in
                       (("--fail-above", gate.rate), ("--min-completed", gate.min_completed),
                        ("--max-pedestrian-rate", gate.max_pedestrian_rate))
                       if value is not None)
    if not gate.failed:
        return f"gate passed ({options})"
    return "gate FAILED: " + "; ".join(f"{c}: {' and '.join(why)}"
                                       for c, why in gate.reasons.items())
