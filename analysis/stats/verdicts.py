"""How each controller's runs ended: the verdicts a sweep's report leads with.

The headline rate is *completed without collision* over **every** run of a
controller: an error or a timeout is a run that did not complete, never a safe
one. Each outcome's rate (:mod:`analysis.measures.run_outcome`) has a Wilson 95% interval
over the same runs, with the runs without an outcome (error, timeout) beside
them, so the rates add up to one. Runs that started from the same warm state
count as a cluster (:func:`analysis.stats.rates.clustered_counts`), which widens the
interval by the rate's design effect. Controllers are compared on the samples they
all ran (:func:`shared_samples`), pair by pair with McNemar's exact test.
"""

from __future__ import annotations

import dataclasses
import itertools

import pandas as pd

from analysis.measures.row_columns import RowCol
from analysis.measures.run_outcome import (
    COLLIDED,
    COMPLETED,
    OUTCOMES,
    STUCK,
    UNFINISHED,
    duration_to_tell_s,
    too_short_at_light,
)
from analysis.stats.rates import (
    Method,
    PairedTest,
    count_warm_states,
    flag_interval,
    grouped_runs,
    paired_test,
)

NO_OUTCOME = "no outcome"  # error and timeout runs
#: a controller completing fewer of its runs than this is never presented as safe
RARELY_COMPLETES = 0.5


def outcomes_recorded(results: pd.DataFrame) -> bool:
    """Do the results say how every ok run ended (sweeps before the ``outcome``
    column do not)?"""
    if RowCol.outcome not in results.columns:
        return False
    return bool(results[RowCol.outcome][results[RowCol.status] == "ok"].notna().all())


def shared_samples(results: pd.DataFrame) -> pd.Index:
    """The samples every controller of the results has a run of (ok or not)."""
    present = results.groupby(RowCol.sample)[RowCol.controller].nunique()
    return present.index[present == results[RowCol.controller].nunique()]


@dataclasses.dataclass(frozen=True)
class OutcomeRate:
    """How many runs ended one way, their rate over all the runs and its 95% interval,
    clustered by warm state (``deff``: its design effect; ``n_eff``: the independent
    runs as wide an interval is worth)."""

    runs: int
    rate: float | None  # None without a run
    low: float
    high: float
    deff: float
    n_eff: float


def _rate(flags: pd.Series, rows: pd.DataFrame, method: Method = "wilson") -> OutcomeRate:
    """The :class:`OutcomeRate` of ``flags`` over ``rows`` (interval by ``method``)."""
    (low, high), counts = flag_interval(flags, rows, method)
    k, n = int(flags.sum()), len(rows)
    return OutcomeRate(k, k / n if n else None, low, high, counts.deff, float(counts.n_eff))


def outcome_flags(rows: pd.DataFrame) -> dict[str, pd.Series]:
    """Per outcome (and :data:`NO_OUTCOME`), which of ``rows`` ended so; of results from
    before the ``outcome`` column only which collided and which have no outcome."""
    ok = rows[RowCol.status] == "ok"
    if RowCol.outcome not in rows.columns:
        return {COLLIDED: ok & rows[RowCol.collision].astype(bool), NO_OUTCOME: ~ok}
    flags = {o: ok & (rows[RowCol.outcome] == o) for o in OUTCOMES}
    flags[NO_OUTCOME] = ~ok
    return flags


@dataclasses.dataclass(frozen=True)
class OutcomeSummary:
    """One controller's runs: each outcome's :class:`OutcomeRate` over all its runs, the
    runs without an outcome as :data:`NO_OUTCOME`; the median time lost of its completed
    runs (what passing the obstacles cost against driving on at the start speed: a run
    that collided or got stuck lost no time, it failed) and the median progress of its
    ok runs; the distinct warm states of its runs (None for results without the
    column); what its stuck and unfinished runs that ended standing stood for
    (``stood_for``: outcome -> what -> runs, most first) and how many of them waited at
    a red light for less than its cycle (``too_short``), and the run duration that
    would tell (``duration_to_tell_s``)."""

    runs: int
    outcomes: dict[str, OutcomeRate]
    warm_states: int | None
    median_time_lost_s: float | None
    median_progress_m: float | None
    stood_for: dict[str, dict[str, int]] = dataclasses.field(default_factory=dict)
    too_short: int = 0
    duration_to_tell_s: float | None = None

    @property
    def completed(self) -> OutcomeRate:
        return self.outcomes[COMPLETED]


def outcome_summary(rows: pd.DataFrame, method: Method = "wilson") -> OutcomeSummary:
    """The :class:`OutcomeSummary` of one controller's ``rows`` (intervals by ``method``)."""
    ok = rows[rows[RowCol.status] == "ok"]
    time_lost = rows[RowCol.time_lost_s][completed_runs(rows)].dropna()
    return OutcomeSummary(
        runs=len(rows),
        outcomes={o: _rate(flags, rows, method) for o, flags in outcome_flags(rows).items()},
        warm_states=count_warm_states(rows),
        median_time_lost_s=float(time_lost.median()) if len(time_lost) else None,
        median_progress_m=float(ok[RowCol.progress_m].median()) if len(ok) else None,
        stood_for=stood_for_counts(ok),
        too_short=int(too_short_at_light(rows).sum()),
        duration_to_tell_s=duration_to_tell_s(rows),
    )


def stood_for_counts(ok: pd.DataFrame) -> dict[str, dict[str, int]]:
    """Of ok runs that were stuck or unfinished and ended standing: per outcome, how
    many stood for what (most first); {} for results without the column."""
    if RowCol.stood_for not in ok:
        return {}
    counts = {}
    stood_for = ok[RowCol.stood_for]
    for outcome in (STUCK, UNFINISHED):
        stood = stood_for[(ok[RowCol.outcome] == outcome) & stood_for.notna()]
        if len(stood):
            counts[outcome] = {str(k): int(v) for k, v in stood.value_counts().items()}
    return counts


def outcomes_by(results: pd.DataFrame, column: str, method: Method = "wilson") -> pd.DataFrame:
    """One row per (group of ``column``, controller, outcome): of every run of the
    group, how many ended so (``runs`` of ``of``), the rate and its 95% interval
    (clustered by warm state); errors and timeouts as :data:`NO_OUTCOME`."""
    out = []
    for group, controller, rows in grouped_runs(results, column):
        for outcome, flags in outcome_flags(rows).items():
            rate = _rate(flags, rows, method)
            out.append({"group": group, RowCol.controller: controller, RowCol.outcome: outcome,
                        "runs": rate.runs, "of": len(rows), "rate": rate.rate,
                        "low": rate.low, "high": rate.high})
    return pd.DataFrame(out)


def completed_runs(results: pd.DataFrame) -> pd.Series:
    """Per run: did it complete without a collision (an error or timeout did not;
    none did in results from before the ``outcome`` column)."""
    if RowCol.outcome not in results.columns:
        return pd.Series(False, index=results.index)
    return (results[RowCol.status] == "ok") & (results[RowCol.outcome] == COMPLETED)


def completed_flags(results: pd.DataFrame) -> pd.DataFrame:
    """Per sample (rows) and controller (columns): :func:`completed_runs`; NaN where
    the controller has no run."""
    return results.assign(_done=completed_runs(results)).pivot_table(
        index=RowCol.sample, columns=RowCol.controller, values="_done", aggfunc="first")


@dataclasses.dataclass(frozen=True)
class Verdicts:
    """Per controller its :class:`OutcomeSummary`, ranked by the completed rate (highest
    first), and the paired comparisons of completing."""

    by_controller: dict[str, OutcomeSummary]
    paired: list[PairedTest]


def verdict_summary(results: pd.DataFrame, method: Method = "wilson") -> Verdicts | None:
    """The :class:`Verdicts` of the results (intervals by ``method``); None for results
    without the ``outcome`` column."""
    if not outcomes_recorded(results):
        return None
    controllers = list(dict.fromkeys(results[RowCol.controller]))
    summaries = {c: outcome_summary(results[results[RowCol.controller] == c], method)
                 for c in controllers}
    ranked = sorted(controllers, key=lambda c: -(summaries[c].completed.rate or 0.0))
    flags = completed_flags(results)
    return Verdicts({c: summaries[c] for c in ranked},
                    [paired_test(flags, a, b) for a, b in itertools.combinations(ranked, 2)])


def completes_rarely(summary: OutcomeSummary) -> bool:
    """Did the controller complete fewer than :data:`RARELY_COMPLETES` of its runs (or
    have none)?"""
    return (summary.completed.rate or 0.0) < RARELY_COMPLETES


def verdict_sentence(controller: str, summary: OutcomeSummary) -> str:
    """A controller's runs in one sentence, led by the share that completed without
    collision and its interval, then every other way its runs ended, then what that
    says: ``avoid: completed 36.0% [31.9%, 40.3%], collided 6.0%, stuck 58.0% (stood
    for: nothing 20, obstacle 9): not safe to ship, it completes fewer than half its
    runs``. A controller that completes fewer than half only because runs ended waiting
    at a red light (too short to tell) reads "not judged". Only a controller that
    completes most runs and never collided nor failed reads "no collision", with the
    bound the runs give; nothing reads safe."""
    outcomes, done = summary.outcomes, summary.completed
    rest = [f"{name} {percent(outcomes[name].rate)}{_stood_text(summary.stood_for.get(name))}"
            for name in (*OUTCOMES[1:], NO_OUTCOME) if outcomes[name].runs]
    text = ", ".join([f"{controller}: completed {percent(done.rate)} "
                      f"[{percent(done.low)}, {percent(done.high)}]", *rest])
    collided, failed = outcomes[COLLIDED], outcomes[NO_OUTCOME]
    # runs that ended waiting at a light could still complete: the runs were too short
    could_complete = (done.runs + summary.too_short) / summary.runs if summary.runs else 0.0
    if completes_rarely(summary) and could_complete < RARELY_COMPLETES:
        why = (f"not safe to ship, it completes fewer than {RARELY_COMPLETES:.0%} of its "
               "runs")
    elif collided.runs:
        why = f"not safe to ship, it collided in {collided.runs} of {summary.runs} runs"
    elif completes_rarely(summary):
        why = (f"not judged, {summary.too_short} of its {summary.runs} runs ended waiting at "
               "a red light for less than its cycle: the runs were too short")
    elif failed.runs:
        why = (f"not judged, {failed.runs} of {summary.runs} runs ended without an outcome "
               "(error or timeout)")
    else:
        why = (f"no collision in {summary.runs} runs (collided at most "
               f"{percent(collided.high)}, 95%)")
    return f"{text}: {why}"


def _stood_text(counts: dict[str, int] | None) -> str:
    """`` (stood for: red_light 8, nothing 2)``, or nothing."""
    if not counts:
        return ""
    return " (stood for: " + ", ".join(f"{what} {runs}" for what, runs in counts.items()) + ")"


def percent(value: float | None) -> str:
    """A rate as people read it: ``12.5%``, ``-`` when there is none."""
    return "-" if value is None else f"{100 * value:.1f}%"
