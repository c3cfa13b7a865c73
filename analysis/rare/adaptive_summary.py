"""What a search or estimate directory says of itself, from its rows: the
importance-sampling estimate recomputed from the rows' weights (it equals
``estimate.json``'s), how it converged, its outcomes, and its failures and stuck runs
grouped into modes (:mod:`analysis.rare.failure_modes`). Plain data for the report
(:mod:`analysis.report.rare_report`) and for ``search.json`` / ``estimate.json``.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pandas as pd

from analysis.measures.commands import replay_command
from analysis.measures.failure_event import FAILURE
from analysis.measures.row_columns import RowCol
from analysis.measures.run_outcome import OUTCOMES, STATUSES, STUCK
from analysis.measures.sweep_manifest import SweepManifest
from analysis.rare.failure_estimate import Estimate, estimate_from_rows
from analysis.rare.failure_modes import failure_modes, weighed_rows
from scenarios.common.file_read import read_json
from scenarios.spec.sweep_params import Param, parse_param


def sweep_params(manifest: SweepManifest) -> list[Param]:
    """The swept parameters as the manifest records them."""
    return [parse_param(path, dist, f'sweep.params."{path}"')
            for path, dist in manifest.sweep_params.items()]


def estimate_of(results: pd.DataFrame, upto_batch: int | None = None,
                max_weight: float = math.inf) -> Estimate | None:
    """The estimate from the rows' weights: the estimation-phase rows (of batches up to
    ``upto_batch``), counting every run drawn so far. None before the estimation phase."""
    rows = results if upto_batch is None else results[results[RowCol.batch] <= upto_batch]
    estimation = rows[rows[RowCol.phase] == "estimate"]
    if estimation.empty:
        return None
    return estimate_from_rows(estimation[RowCol.weight].to_numpy(dtype=float),
                              FAILURE.failed_rows(estimation).to_numpy(), runs=len(rows),
                              max_weight=max_weight)


def mode_estimates(results: pd.DataFrame, modes: list[dict],
                   max_weight: float = math.inf) -> list[dict]:
    """Each failure mode's part of the estimate: ``p_k = mean(w * 1{row in mode k})`` over
    the estimation rows, with its own interval (:func:`estimate_from_rows`, so a mode
    with no estimation failure gets 0 and the rule-of-three bound). Every failed row is
    in exactly one mode, so the parts add up to the total. ``modes``: plain failure
    modes (``FailureMode.to_plain``); returns them with ``p_collision, ci_low,
    ci_high, share`` (of the total) and ``estimation_failures`` added."""
    estimation = results[results[RowCol.phase] == "estimate"]
    if estimation.empty:
        return modes
    weights = estimation[RowCol.weight].to_numpy(dtype=float)
    failed = FAILURE.failed_rows(estimation).to_numpy()
    total = float(np.mean(weights * failed))
    out = []
    for mode in modes:
        in_mode = failed & estimation[RowCol.run_id].isin(mode["run_ids"]).to_numpy()
        part = estimate_from_rows(weights, in_mode, max_weight=max_weight)
        out.append({**mode, "p_collision": part.p_collision, "ci_low": part.ci_low,
                    "ci_high": part.ci_high, "share": part.p_collision / total if total else 0.0,
                    "estimation_failures": part.failures})
    return out


def _described(results: pd.DataFrame, params: list[Param], failed: pd.Series,
               sweep_dir: Path) -> list[dict]:
    """The modes of the ``failed`` rows among the runs (a sample that made no valid
    scenario, score None, is no run: no evidence either way)."""
    runs = results[results[RowCol.score].notna()] if RowCol.score in results else results
    return [{**m.to_plain(), "replay": replay_command(sweep_dir, m.example_run)}
            for m in failure_modes(runs, params, failed[runs.index], weighed_rows(runs))]


def described_modes(results: pd.DataFrame, params: list[Param], sweep_dir: Path,
                    max_weight: float = math.inf) -> list[dict]:
    """The failure modes of a search or estimate directory's rows, plain: each with the
    command that replays its example run and, where there are estimation rows, its part
    of P (:func:`mode_estimates`). The one place ``search.json``, ``estimate.json`` and
    the report get them from."""
    if results.empty:
        return []
    return mode_estimates(results, _described(results, params, FAILURE.failed_rows(results),
                                              sweep_dir), max_weight)


def stuck_modes(results: pd.DataFrame, params: list[Param], sweep_dir: Path) -> list[dict]:
    """The stuck runs (no collision, standing still at the end) grouped the same way as
    the failures, plain, each with its replay command."""
    if results.empty or RowCol.outcome not in results:
        return []
    return _described(results, params, results[RowCol.outcome] == STUCK, sweep_dir)


def outcome_counts(results: pd.DataFrame) -> dict[str, int]:
    """Runs per outcome (:data:`analysis.measures.run_outcome.OUTCOMES`), and ``failed`` for the
    runs without one (error, timeout)."""
    outcomes = results.get(RowCol.outcome, pd.Series(index=results.index, dtype=object))
    status = results[RowCol.status]
    counts = {o: int((outcomes[status == "ok"] == o).sum()) for o in OUTCOMES}
    return {**counts, "failed": int((status != "ok").sum())}


def convergence(results: pd.DataFrame, max_weight: float = math.inf) -> pd.DataFrame:
    """The estimate after each estimation batch: runs, p_collision, ci_low, ci_high, rhw."""
    batches = sorted(results[results[RowCol.phase] == "estimate"][RowCol.batch].unique())
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


@dataclasses.dataclass(frozen=True)
class RareSummary:
    """What a search or estimate directory says of itself (the report's summary;
    :meth:`to_plain` is its ``summary.json``). Failure and stuck modes are plain
    (:meth:`analysis.rare.failure_modes.FailureMode.to_plain`)."""

    mode: str  # "search" or "estimate"
    sweep: str
    controller: str
    runs: int
    counts: dict[str, int]  # runs by status: ok, error, timeout
    state: str | None  # finished, interrupted, ...
    score: str
    batches: int
    failures: int  # runs that failed (analysis.measures.failure_event)
    first_failure_run: int | None  # counted from 1
    first_failure_run_id: str | None
    outcomes: dict[str, int]  # completed, collided, stuck, unfinished, failed
    failure_modes: list[dict]
    stuck_modes: list[dict]
    adaptation_levels: list[float] | None
    # an estimate's alone
    target_rhw: float | None = None
    judged_from: dict[str, float] | None = None  # when the RHW is judged (None: not saved)
    stopped: str | None = None
    level_ess: list[float] | None = None
    level_uncovered: list[int] | None = None
    estimate: Estimate | None = None

    @property
    def estimate_plain(self) -> dict | None:
        """The estimate as the report states it, with its acceleration over plain Monte
        Carlo (None before the estimation phase)."""
        return None if self.estimate is None else self.estimate.to_plain()

    def to_plain(self) -> dict:
        plain = {field.name: getattr(self, field.name) for field in dataclasses.fields(self)
                 if field.name not in _ESTIMATE_FIELDS}
        if self.mode == "estimate":
            plain.update({name: getattr(self, name) for name in _ESTIMATE_FIELDS},
                         estimate=self.estimate_plain)
        return plain


_ESTIMATE_FIELDS = ("target_rhw", "judged_from", "stopped", "level_ess", "level_uncovered",
                    "estimate")


def adaptive_summary(results: pd.DataFrame, manifest: SweepManifest, saved: dict,
                     sweep_dir: Path) -> RareSummary:
    """The report's summary of a search or estimate; ``saved``: its :func:`saved_summary`."""
    settings = manifest.adaptive
    mode = settings.mode
    failed = results[FAILURE.failed_rows(results)]
    max_weight = saved.get("max_weight") or math.inf
    first = failed[RowCol.run_index].idxmin() if len(failed) else None
    common = {
        "mode": mode,
        "sweep": manifest.sweep_name,
        "controller": saved.get("controller", results[RowCol.controller].iloc[0]),
        "runs": len(results),
        "counts": {s: int((results[RowCol.status] == s).sum()) for s in STATUSES},
        "state": saved.get("state", manifest.status),
        "score": settings.score,
        "batches": int(results[RowCol.batch].max()) + 1,
        "failures": len(failed),
        "first_failure_run": (None if first is None
                              else int(failed[RowCol.run_index].min()) + 1),
        "first_failure_run_id": None if first is None else failed.loc[first, RowCol.run_id],
        "outcomes": outcome_counts(results),
        "failure_modes": described_modes(results, sweep_params(manifest), sweep_dir,
                                         max_weight),
        "stuck_modes": stuck_modes(results, sweep_params(manifest), sweep_dir),
        "adaptation_levels": saved.get("adaptation_levels"),
    }
    if mode != "estimate":
        return RareSummary(**common)
    return RareSummary(**common, target_rhw=settings.target_rhw,
                       judged_from=saved.get("judged_from"), stopped=saved.get("stopped"),
                       level_ess=saved.get("level_ess"),
                       level_uncovered=saved.get("level_uncovered"),
                       estimate=estimate_of(results, max_weight=max_weight))
