"""The report of a search or estimate directory (``sdc search``, ``sdc estimate``).

Its runs were drawn toward failure on purpose, so their plain collision rate is
no probability and is not shown as one. An estimate's report recomputes the
importance-sampling estimate from the rows' weights (it equals
``estimate.json``'s), shows how it converged, and what plain Monte Carlo would
have cost; a search's report says how soon it found a collision. Both group the
failures into modes (:mod:`analysis.failure_modes`).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from analysis import plots
from analysis.failure_modes import OTHER, failure_modes, region_words, weighed_rows
from analysis.rare_events import Estimate, estimate_from_rows
from analysis.run_outcome import OUTCOMES, STUCK, outcomes_text
from scenarios.file_read import read_json
from scenarios.sweep_spec import Param, parse_param


def sweep_params(manifest: dict) -> list[Param]:
    """The swept parameters as the manifest records them."""
    table = manifest["sweep"]["sweep"].get("params", {})
    return [parse_param(path, dist, f'sweep.params."{path}"') for path, dist in table.items()]


def _failed(rows: pd.DataFrame) -> pd.Series:
    return rows.score.notna() & (rows.score <= 0)


def estimate_of(results: pd.DataFrame, upto_batch: int | None = None,
                max_weight: float = math.inf) -> Estimate | None:
    """The estimate from the rows' weights: the estimation-phase rows (of batches up to
    ``upto_batch``), counting every run drawn so far. None before the estimation phase."""
    rows = results if upto_batch is None else results[results.batch <= upto_batch]
    estimation = rows[rows.phase == "estimate"]
    if estimation.empty:
        return None
    return estimate_from_rows(estimation.weight.to_numpy(dtype=float),
                              _failed(estimation).to_numpy(), runs=len(rows),
                              max_weight=max_weight)


def mode_estimates(results: pd.DataFrame, modes: list[dict],
                   max_weight: float = math.inf) -> list[dict]:
    """Each failure mode's part of the estimate: ``p_k = mean(w * 1{row in mode k})`` over
    the estimation rows, with its own interval (:func:`estimate_from_rows`, so a mode
    with no estimation failure gets 0 and the rule-of-three bound). Every failed row is
    in exactly one mode, so the parts add up to the total. ``modes``: plain failure
    modes (``FailureMode.to_plain``); returns them with ``p_collision, ci_low,
    ci_high, share`` (of the total) and ``estimation_failures`` added."""
    estimation = results[results.phase == "estimate"]
    if estimation.empty:
        return modes
    weights = estimation.weight.to_numpy(dtype=float)
    failed = _failed(estimation).to_numpy()
    total = float(np.mean(weights * failed))
    out = []
    for mode in modes:
        in_mode = failed & estimation.run_id.isin(mode["run_ids"]).to_numpy()
        part = estimate_from_rows(weights, in_mode, max_weight=max_weight)
        out.append({**mode, "p_collision": part.p_collision, "ci_low": part.ci_low,
                    "ci_high": part.ci_high, "share": part.p_collision / total if total else 0.0,
                    "estimation_failures": part.failures})
    return out


def _described(results: pd.DataFrame, params: list[Param], failed: pd.Series,
               sweep_dir: Path) -> list[dict]:
    """The modes of the ``failed`` rows among the runs (a sample that made no valid
    scenario, score None, is no run: no evidence either way)."""
    runs = results[results.score.notna()] if "score" in results else results
    return [{**m.to_plain(), "replay": f"sdc replay {sweep_dir} --run {m.example_run}"}
            for m in failure_modes(runs, params, failed[runs.index], weighed_rows(runs))]


def described_modes(results: pd.DataFrame, params: list[Param], sweep_dir: Path,
                    max_weight: float = math.inf) -> list[dict]:
    """The failure modes of a search or estimate directory's rows, plain: each with the
    command that replays its example run and, where there are estimation rows, its part
    of P (:func:`mode_estimates`). The one place ``search.json``, ``estimate.json`` and
    the report get them from."""
    if results.empty:
        return []
    return mode_estimates(results, _described(results, params, _failed(results), sweep_dir),
                          max_weight)


def stuck_modes(results: pd.DataFrame, params: list[Param], sweep_dir: Path) -> list[dict]:
    """The stuck runs (no collision, standing still at the end) grouped the same way as
    the failures, plain, each with its replay command."""
    if results.empty or "outcome" not in results:
        return []
    return _described(results, params, results.outcome == STUCK, sweep_dir)


def outcome_counts(results: pd.DataFrame) -> dict[str, int]:
    """Runs per outcome (:data:`analysis.run_outcome.OUTCOMES`), and ``failed`` for the
    runs without one (error, timeout)."""
    outcomes = results.get("outcome", pd.Series(index=results.index, dtype=object))
    counts = {o: int((outcomes[results.status == "ok"] == o).sum()) for o in OUTCOMES}
    return {**counts, "failed": int((results.status != "ok").sum())}


def convergence(results: pd.DataFrame, max_weight: float = math.inf) -> pd.DataFrame:
    """The estimate after each estimation batch: runs, p_collision, ci_low, ci_high, rhw."""
    batches = sorted(results[results.phase == "estimate"].batch.unique())
    points = []
    for batch in batches:
        e = estimate_of(results, batch, max_weight)
        points.append({"runs": e.runs, "p_collision": e.p_collision, "ci_low": e.ci_low,
                       "ci_high": e.ci_high, "rhw": e.rhw})
    return pd.DataFrame(points, columns=["runs", "p_collision", "ci_low", "ci_high", "rhw"])


def summary_path(sweep_dir: Path, mode: str) -> Path:
    """Where a search or estimate says how it stands: DIR/search.json, DIR/estimate.json."""
    return Path(sweep_dir) / f"{mode}.json"


def saved_summary(sweep_dir: Path, mode: str) -> dict:
    """What the search or estimate wrote of itself (empty when it wrote nothing yet)."""
    path = summary_path(sweep_dir, mode)
    return read_json(path, f"the {mode} summary") if path.exists() else {}


def adaptive_summary(results: pd.DataFrame, manifest: dict, saved: dict,
                     sweep_dir: Path) -> dict:
    """The report's summary of a search or estimate; ``saved``: its :func:`saved_summary`."""
    settings = manifest["adaptive"]
    mode = settings["mode"]
    failed = results[_failed(results)]
    summary = {
        "mode": mode,
        "sweep": manifest["sweep"]["sweep"]["name"],
        "controller": saved.get("controller", results.controller.iloc[0]),
        "runs": len(results),
        "counts": {s: int((results.status == s).sum()) for s in ("ok", "error", "timeout")},
        "state": saved.get("state", manifest.get("status")),
        "score": settings["score"],
        "batches": int(results.batch.max()) + 1,
        "failures": len(failed),
        "first_failure_run": (int(failed.run_index.min()) + 1) if len(failed) else None,
        "first_failure_run_id": (failed.loc[failed.run_index.idxmin(), "run_id"]
                                 if len(failed) else None),
        "outcomes": outcome_counts(results),
        "failure_modes": described_modes(results, sweep_params(manifest), sweep_dir,
                                         saved.get("max_weight") or math.inf),
        "stuck_modes": stuck_modes(results, sweep_params(manifest), sweep_dir),
        "adaptation_levels": saved.get("adaptation_levels"),
    }
    if mode == "estimate":
        max_weight = saved.get("max_weight") or math.inf
        estimate = estimate_of(results, max_weight=max_weight)
        summary["target_rhw"] = settings["target_rhw"]
        summary["stopped"] = saved.get("stopped")
        summary["level_ess"] = saved.get("level_ess")
        summary["level_uncovered"] = saved.get("level_uncovered")
        summary["estimate"] = None if estimate is None else {
            "p_collision": estimate.p_collision, "ci_low": estimate.ci_low,
            "ci_high": estimate.ci_high, "rhw": estimate.rhw, "runs": estimate.runs,
            "estimation_runs": estimate.estimation_runs, "failures": estimate.failures,
            "ess": estimate.ess, "max_term_share": estimate.max_term_share,
            "mc_equivalent_runs": estimate.mc_equivalent_runs,
            "acceleration": estimate.mc_equivalent_runs / estimate.runs}
    return summary


def first_failure_words(summary: dict) -> str:
    """", the first: run ID, after N runs" (ids count from 0, N from 1), or nothing."""
    first = summary.get("first_failure_run")
    if not first:
        return ""
    return f", the first: run {summary['first_failure_run_id']}, after {first} runs"


def headline(summary: dict) -> list[str]:
    """The lines that say what the directory found."""
    counts = summary["counts"]
    lines = [f"{summary['mode']} of {summary['sweep']} for {summary['controller']}: "
             f"{summary['runs']} runs in {summary['batches']} batches ({counts['ok']} ok, "
             f"{counts['error']} error, {counts['timeout']} timeout); {summary['state']}"]
    if summary["mode"] == "estimate":
        e = summary["estimate"]
        if e is None:
            lines.append("no estimate yet: the adaptation has not ended")
        elif e["failures"] == 0:
            lines.append(f"P(collision) <= {e['ci_high']:.3g} (95%): no collision in "
                         f"{e['estimation_runs']} weighted runs")
        else:
            stopped = {"target_rhw": "target RHW reached",
                       "budget": "budget spent before the target RHW"}.get(
                summary["stopped"], "not finished")
            lines.append(f"P(collision) = {e['p_collision']:.3g}, 95% interval "
                         f"[{e['ci_low']:.3g}, {e['ci_high']:.3g}], RHW {e['rhw']:.2f} "
                         f"(target {summary['target_rhw']:g}; {stopped})")
            lines.append(f"plain Monte Carlo would need {e['mc_equivalent_runs']:,.0f} runs for "
                         f"this RHW: {e['acceleration']:.0f}x the {e['runs']} runs spent "
                         f"({e['estimation_runs']} weighted, ESS {e['ess']:.0f})")
            lines.append(_diagnostics(summary))
    lines.append(f"{summary['failures']} failed runs" + first_failure_words(summary)
                 + ("; the drawn runs are aimed at failure, so their share is no probability"))
    lines.append(f"outcomes: {outcomes_text(summary['outcomes'])}, "
                 f"{summary['outcomes']['failed']} failed (no outcome); "
                 f"{_modes_count(summary['failure_modes'], 'failure')}, "
                 f"{_modes_count(summary['stuck_modes'], 'stuck')} (tables below)")
    return lines


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


def _diagnostics(summary: dict) -> str:
    """The sampler's own diagnostics, one line."""
    e, levels = summary["estimate"], summary.get("adaptation_levels") or []
    ess = list(summary.get("level_ess") or [])
    ess += [None] * (len(levels) - len(ess))
    uncovered = list(summary.get("level_uncovered") or [])
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
            "scores (analysis/failure_modes.py). outcome: what its runs hit (error or "
            "timeout: no outcome; other: the modes each under 1% of the weight, folded "
            f"together). runs: its runs, from every batch. {share} example run: its first "
            "run drawn. parameter region: the span of each parameter over its runs (the "
            "box they fill, not the region's true edges).")


def adaptive_figures(results: pd.DataFrame, summary: dict,
                     max_weight: float = math.inf) -> list[tuple[str, bytes]]:
    out = []
    if summary["mode"] == "estimate":
        history = convergence(results, max_weight)
        if len(history):
            out.append(("Convergence: the estimate and its relative half-width against runs",
                        plots.convergence(history, summary["target_rhw"])))
        split = [m for m in summary["failure_modes"] if "p_collision" in m]
        if split and summary["estimate"] and summary["estimate"]["failures"]:
            out.append(("Where P(collision) comes from: each failure mode's part",
                        plots.mode_probabilities(split, summary["estimate"])))
    varying = [c for c in results.columns if c.startswith("p.")
               and pd.api.types.is_numeric_dtype(results[c]) and results[c].nunique() > 1]
    if len(varying) >= 2:
        stuck = frozenset(r for m in summary["stuck_modes"] for r in m["run_ids"])
        out.append((f"Runs drawn over {varying[0]} and {varying[1]}, failures ringed by mode",
                    plots.sampling_path(results, varying[0], varying[1],
                                        summary["failure_modes"], stuck)))
    out.append(("What was hit", plots.collision_breakdown(results)))
    return out
