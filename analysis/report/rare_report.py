"""The report of a search or estimate directory (``sdc search``, ``sdc estimate``).

Its runs were drawn toward failure on purpose, so their plain collision rate is
no probability and is not shown as one. An estimate's report recomputes the
importance-sampling estimate from the rows' weights (it equals
``estimate.json``'s), shows how it converged, and what plain Monte Carlo would
have cost; a search's report says how soon it found a collision. Both group the
failures into modes (:mod:`analysis.rare.failure_modes`).
"""

from __future__ import annotations

import math

import pandas as pd

from analysis.measures.failure_event import FAILURE
from analysis.measures.row_columns import RowCol
from analysis.measures.run_outcome import STUCK, failed_or_collided, outcomes_text
from analysis.rare.adaptive_summary import RareSummary, convergence
from analysis.rare.failure_modes import OTHER, region_words
from analysis.rare.rare_events import unjudged
from analysis.report import plots
from scenarios.spec.sweep_spec import PARAM_PREFIX

MAX_LISTED = 50  # runs listed by a search's or estimate's report; all are in results.parquet
LOOK_AT = ("Runs with no outcome (error, timeout) first, then collisions and stuck runs: "
           "in an estimate, its failed estimation runs by weight (the most of P first), "
           "then the rest by run; in a search, by run.")


def runs_to_look_at(results: pd.DataFrame, estimate: bool = False) -> pd.DataFrame:
    """Runs to look at in a search or estimate: failed runs (error, timeout) first, then
    collisions and stuck runs; in an estimate, the estimation runs that count in P (those
    of the failure event) by weight, the largest share of P first, before the rest;
    otherwise by run."""
    stuck = results[RowCol.outcome] == STUCK if RowCol.outcome in results else False
    bad = results[failed_or_collided(results) | stuck]
    counted = (bad[RowCol.phase] == "estimate") & FAILURE.failed_rows(bad) & estimate
    key = pd.DataFrame({"ok": bad[RowCol.status] == "ok", "counted": counted,
                        "counted_weight": bad[RowCol.weight].where(counted, 0.0),
                        RowCol.run_index: bad[RowCol.run_index]})
    order = key.sort_values(["ok", "counted", "counted_weight", RowCol.run_index],
                            ascending=[True, False, False, True], kind="stable").index
    return bad.loc[order]


def first_failure_words(first_run: int | None, first_run_id: str | None) -> str:
    """", the first: run ID, after N runs" (ids count from 0, N from 1), or nothing."""
    if not first_run:
        return ""
    return (f", the first: run {first_run_id}, after {first_run} run"
            + ("" if first_run == 1 else "s"))


def headline(summary: RareSummary) -> list[str]:
    """The lines that say what the directory found."""
    counts = summary.counts
    lines = [f"{summary.mode} of {summary.sweep} for {summary.controller}: "
             f"{summary.runs} runs in {summary.batches} batches ({counts['ok']} ok, "
             f"{counts['error']} error, {counts['timeout']} timeout); {summary.state}"]
    if summary.mode == "estimate":
        lines += estimate_lines(summary.estimate_plain, summary.stopped, summary.target_rhw,
                                summary.judged_from)
        if summary.estimate is not None and summary.estimate.failures:
            lines.append(_diagnostics(summary))
    lines.append(f"{summary.failures} failed runs"
                 + first_failure_words(summary.first_failure_run, summary.first_failure_run_id)
                 + ("; the drawn runs are aimed at failure, so their share is no probability"))
    lines.append(f"outcomes: {outcomes_text(summary.outcomes)}, "
                 f"{summary.outcomes['failed']} failed (no outcome); "
                 f"{_modes_count(summary.failure_modes, 'failure')}, "
                 f"{_modes_count(summary.stuck_modes, 'stuck')} (tables below)")
    return lines


def estimate_lines(e: dict | None, stopped: str | None, target_rhw: float | None,
                   judged_from: dict[str, float] | None = None) -> list[str]:
    """What an estimate says: P(collision) with its interval, or its bound when no run
    failed, and what plain Monte Carlo would have cost. ``e``: the estimate's fields
    (``estimate.json``'s, or :attr:`RareSummary.estimate_plain`), None before the
    estimation phase; ``stopped`` and ``judged_from``: its fields of those names (when
    the budget stopped it before its RHW could be judged, it says why)."""
    if e is None:
        return ["no estimate: the adaptation had not ended when the runs stopped"]
    unmet = unjudged(e, judged_from) if judged_from and stopped == "budget" else []
    why = ("budget spent before the RHW could be judged: " + ", ".join(unmet) if unmet else
           {"target_rhw": "target RHW reached",
            "budget": "budget spent before the target RHW"}.get(stopped, "not finished"))
    if e["failures"] == 0:
        return [f"P(collision) <= {e['ci_high']:.3g} (95%): no collision in "
                f"{e['estimation_runs']} weighted runs ({why})"]
    return [f"P(collision) = {e['p_collision']:.3g}, 95% interval "
            f"[{e['ci_low']:.3g}, {e['ci_high']:.3g}], RHW {e['rhw']:.2f} "
            f"(target {target_rhw:g}; {why})",
            f"plain Monte Carlo would need {e['mc_equivalent_runs']:,.0f} runs for "
            f"this RHW: {_times(e['acceleration'])} the {e['runs']} runs spent "
            f"({e['estimation_runs']} weighted, ESS {e['ess']:.0f})"]


def _times(ratio: float) -> str:
    """``25x``, ``1.4x`` or ``0.9x``: a ratio of run counts (under 10 with its tenth, so
    an estimate that cost more than plain Monte Carlo never reads as 1x)."""
    return f"{ratio:.0f}x" if ratio >= 10 else f"{ratio:.1f}x"


def _modes_count(modes: list[dict], what: str) -> str:
    named = sum(m["outcome"] != OTHER for m in modes)
    other = sum(m["runs"] for m in modes if m["outcome"] == OTHER)
    return (f"{named} {what} mode" + ("" if named == 1 else "s")
            + (f" (+ {other} runs in other)" if other else ""))


#: the terms of an estimate's headline, said under it
ESTIMATE_TERMS = (
    "P(collision): the importance-sampling estimate, mean(weight x failed) over the "
    "estimation runs (a run with no outcome counts as failed). RHW: the 95% interval's "
    "half-width over P. Plain Monte Carlo: the independent runs that would reach the same "
    "RHW at this P. weighted: the estimation runs (the adaptation's are not counted). "
    "ESS: Kish's effective sample size of their weights. The largest run's part of P: "
    "above 10% the interval says little. Adaptation thresholds: each level's score "
    "quantile (0 once its elites are failures), with its elites' ESS and the failures "
    "it found beyond its kernels.")


def _diagnostics(summary: RareSummary) -> str:
    """The sampler's own diagnostics, one line."""
    e, levels = summary.estimate_plain, summary.adaptation_levels or []
    ess = list(summary.level_ess or [])
    ess += [None] * (len(levels) - len(ess))
    uncovered = list(summary.level_uncovered or [])
    uncovered += [0] * (len(levels) - len(uncovered))
    steps = ", ".join(f"{g:.3g}" + (f" (ESS {n:.0f})" if n is not None else "")
                      + (f" ({u} beyond its kernels)" if u else "")
                      for g, n, u in zip(levels, ess, uncovered, strict=True))
    return (f"diagnostics: the largest run "
            f"carries {100 * e['max_term_share']:.1f}% of P; adaptation thresholds {steps}")


def mode_rows(modes: list[dict]) -> list[list[str]]:
    """Failure or stuck modes as a table; an estimate's with each mode's part of P."""
    split = any("p_collision" in m for m in modes)
    rows = [["mode", "outcome", "runs"] + (["P (95% interval)", "share of P"] if split
                                           else ["share"])
            + ["example run", "parameter region"]]
    for i, mode in enumerate(modes, start=1):
        if split:
            part = [f"{mode['p_collision']:.3g} [{mode['ci_low']:.3g}, {mode['ci_high']:.3g}]",
                    f"{100 * mode['share']:.0f}%"]
        else:
            part = ["-" if mode["share"] is None else f"{100 * mode['share']:.0f}%"]
        rows.append([str(i), mode["outcome"], str(mode["runs"]), *part, mode["example_run"],
                     region_words(mode)])
    return rows


def mode_columns(modes: list[dict]) -> str:
    """What the mode table's columns mean, said under it."""
    split = any("p_collision" in m for m in modes)
    share = ("P (95% interval): its part of P(collision), from the estimation runs' "
             "weights; the parts add up to the total. share of P: that part over the total."
             if split else
             "share: its part of the failures' importance weights, a rough guide to its "
             "part of P (a search estimates nothing: sdc estimate measures it).")
    return ("A mode is one connected region of one outcome kind in the parameters' normal "
            "scores (analysis/rare/failure_modes.py). outcome: what its runs hit (error or "
            "timeout: no outcome; other: the modes each under 1% of the weight, folded "
            f"together). runs: its runs, from every batch. {share} example run: its first "
            "run drawn. parameter region: the span of each parameter over its runs (the "
            "box they fill, not the region's true edges).")


def adaptive_figures(results: pd.DataFrame, summary: RareSummary,
                     max_weight: float = math.inf) -> list[tuple[str, bytes]]:
    out = []
    if summary.mode == "estimate":
        history = convergence(results, max_weight)
        if len(history):
            out.append(("Convergence: the estimate and its relative half-width against runs",
                        plots.convergence(history, summary.target_rhw)))
        split = [m for m in summary.failure_modes if "p_collision" in m]
        if split and summary.estimate and summary.estimate.failures:
            out.append(("Where P(collision) comes from: each failure mode's part",
                        plots.mode_probabilities(split, summary.estimate_plain)))
    varying = [c for c in results.columns if c.startswith(PARAM_PREFIX)
               and pd.api.types.is_numeric_dtype(results[c]) and results[c].nunique() > 1]
    if len(varying) >= 2:
        stuck = frozenset(r for m in summary.stuck_modes for r in m["run_ids"])
        out.append((f"Runs drawn over {varying[0]} and {varying[1]}, failures ringed by mode",
                    plots.sampling_path(results, varying[0], varying[1],
                                        summary.failure_modes, stuck)))
    out.append(("How the runs failed", plots.collision_breakdown(results)))
    return out
