"""Collision statistics of a sweep's result table: rates with honest intervals.

Only ``status == "ok"`` rows count toward a rate; error and timeout rows are
counted beside it, never as "no collision".

Runs that started from the same warm state (column ``warm_state``: the background
traffic warmed up once and reused), or ran in one shared world (column ``world_id``),
are not independent samples of traffic. Every
rate interval here counts them as a cluster (:func:`clustered_counts`): the
binomial interval is taken on the effective number of independent runs, never
on more runs than the plain interval. Results without the column, or whose runs
each have their own warm state, get the plain binomial interval unchanged.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from statistics import NormalDist
from typing import Literal, NamedTuple

import numpy as np
import pandas as pd
from scipy import special

from analysis.measures.numbers import number_text
from analysis.measures.row_columns import RowCol
from analysis.measures.run_outcome import STATUSES, failed_or_collided
from scenarios.spec.bodies import PEDESTRIAN

Method = Literal["wilson", "clopper-pearson"]
#: a continuous parameter with more distinct values than this is binned for grouping
MAX_GROUPS = 12
ENVELOPE_RATE = 0.05


def wilson_interval(k: float, n: float, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval for ``k`` successes in ``n`` trials ((0, 1) when n = 0).

    ``k`` and ``n`` may be fractional (effective counts, :func:`clustered_counts`):
    the score formula only needs the proportion and the number of trials."""
    if n == 0:
        return 0.0, 1.0
    z = NormalDist().inv_cdf(0.5 + confidence / 2)
    p = k / n
    denom = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    return max(0.0, centre - half), min(1.0, centre + half)


def clopper_pearson_interval(k: float, n: float,
                             confidence: float = 0.95) -> tuple[float, float]:
    """Exact (Clopper-Pearson) interval from beta quantiles ((0, 1) when n = 0).

    Fractional ``k`` and ``n`` (effective counts) go into the same beta quantiles,
    whose shape parameters need not be whole: the interval is then exact for no
    binomial, but it is the one Korn and Graubard (1998) use for survey counts."""
    if n == 0:
        return 0.0, 1.0
    alpha = 1 - confidence
    # scipy.special's inverse incomplete beta gives scipy.stats.beta.ppf's numbers to
    # the bit without importing scipy.stats (a second of every report's start);
    # tests/test_stats.py holds them equal
    low = 0.0 if k == 0 else float(special.betaincinv(k, n - k + 1, alpha / 2))
    high = 1.0 if k == n else float(special.betaincinv(k + 1, n - k, 1 - alpha / 2))
    return low, high


def interval_of(k: float, n: float, method: Method) -> tuple[float, float]:
    """The 95% interval of ``k`` in ``n`` by ``method``."""
    return (wilson_interval if method == "wilson" else clopper_pearson_interval)(k, n)


class ClusteredCounts(NamedTuple):
    """Binary outcomes of runs in clusters, as the binomial counts with the same
    uncertainty: give ``(k_eff, n_eff)`` to any binomial interval."""

    k_eff: float  #: events among the effective runs: the observed rate times ``n_eff``
    n_eff: float  #: the number of independent runs the clustered runs are worth
    deff: float  #: design effect: the rate's variance over the binomial one, at least 1
    n_clusters: int  #: independent units: the distinct clusters, a run without one its own


def cluster_codes(clusters, n_runs: int) -> np.ndarray:
    """One integer per run naming its cluster; a run whose label is null (or every run,
    when ``clusters`` is None) is a cluster of its own."""
    if clusters is None:
        return np.arange(n_runs)
    codes, labels = pd.factorize(pd.Series(clusters).to_numpy(), use_na_sentinel=True)
    alone = codes < 0
    codes[alone] = len(labels) + np.arange(int(alone.sum()))
    return codes


def clustered_counts(flags, clusters=None, confidence: float = 0.95) -> ClusteredCounts:
    """The effective binomial counts of the 0/1 ``flags`` of runs grouped by ``clusters``
    (labels, one a run; null: a run alone), for a rate whose runs are not independent.

    The rate is p = k / n. Its cluster-robust variance is
    ``V = G / (G - 1) * sum_g (Y_g - p m_g)^2 / n^2`` over the G clusters (Y_g events
    in the m_g runs of cluster g); the design effect ``deff = V / (p (1 - p) / n)`` is
    held at 1 or more, so no interval comes out narrower than the plain one. The
    effective number of runs is ``n / deff``, further shrunk by
    ``(t_{n-1} / t_{G-1})^2`` (Student-t quantiles at ``confidence``): V is estimated
    from G clusters only, and with few of them a normal critical value undercovers
    (Korn and Graubard's degrees-of-freedom adjustment; measured in
    ``tests/test_clustered_intervals.py``).

    When V cannot be estimated (no event, or no non-event, or a single cluster) the
    runs are counted as if every run of a cluster had the same outcome (intraclass
    correlation 1, the worst case): ``n_eff = n^2 / sum_g m_g^2``, which is G for
    clusters of equal size, and ``deff = n / n_eff``. So 0 events in 8 clusters of 25
    runs have the interval of 0 in 8 runs (Wilson: up to 32%), while 1 event among
    them is worth 0.69 in 138 runs (up to 3.6%): zero events say nothing of how much
    the cluster matters, and the interval may not assume that it matters little.

    Without a shared cluster (no labels, or every label distinct or null) the counts
    are the plain ``(k, n)`` as integers and ``deff`` is 1: the plain interval, exactly.
    """
    events = np.asarray(pd.array(flags, dtype="boolean").fillna(False), dtype=float)
    n = len(events)
    k = int(events.sum())
    codes = cluster_codes(clusters, n)
    n_clusters = len(np.unique(codes))
    if n_clusters == n:  # no shared cluster (or no run): independent runs
        return ClusteredCounts(k, n, 1.0, n_clusters)
    runs_per_cluster = np.bincount(codes)
    p = k / n
    if k in (0, n) or n_clusters < 2:
        n_eff = n * n / float(np.sum(runs_per_cluster.astype(float) ** 2))
        return ClusteredCounts(p * n_eff, n_eff, n / n_eff, n_clusters)
    events_per_cluster = np.bincount(codes, weights=events)
    spread = np.sum((events_per_cluster - p * runs_per_cluster) ** 2)
    variance = n_clusters / (n_clusters - 1) * spread / (n * n)
    deff = max(1.0, variance / (p * (1 - p) / n))
    n_eff = n / deff * _degrees_of_freedom_factor(n, n_clusters, confidence)
    return ClusteredCounts(p * n_eff, n_eff, deff, n_clusters)


def _degrees_of_freedom_factor(n_runs: int, n_clusters: int, confidence: float) -> float:
    """``(t_{n-1} / t_{G-1})^2``: how much fewer runs a variance estimated from G
    clusters is worth than one from n independent runs."""
    upper = 0.5 + confidence / 2
    # stdtrit: scipy.stats.t.ppf to the bit (as betaincinv above)
    return float(special.stdtrit(n_runs - 1, upper) / special.stdtrit(n_clusters - 1, upper)) ** 2


def warm_states_of(rows: pd.DataFrame) -> pd.Series | None:
    """The warm state each run started from (null: none shared), or None for results
    from before the ``warm_state`` column."""
    return rows[RowCol.warm_state] if RowCol.warm_state in rows.columns else None


def traffic_clusters(rows: pd.DataFrame) -> pd.Series | None:
    """The traffic each run shares with others, its cluster in every interval: its warm
    state, else its shared world (``world_id``: a world without a warm-up shares its
    traffic's seed; null: its own traffic); None for results with neither column."""
    states = warm_states_of(rows)
    if RowCol.world_id not in rows.columns:
        return states
    worlds = "world " + rows[RowCol.world_id]
    return worlds if states is None else states.where(states.notna(), worlds)


def count_warm_states(rows: pd.DataFrame) -> int | None:
    """How many distinct warm states ``rows`` started from (None without the column)."""
    states = warm_states_of(rows)
    return None if states is None else int(states.nunique(dropna=True))


@dataclasses.dataclass(frozen=True)
class WarmStates:
    """How the runs shared their traffic: the distinct warm states, how many runs started
    from a warm state another run of the same controller also started from
    (``runs_sharing``; a sample's controllers sharing theirs is the paired design, not a
    cluster), and whether any did (``shared``)."""

    runs: int
    distinct: int
    runs_sharing: int
    shared: bool


def warm_state_summary(rows: pd.DataFrame) -> WarmStates | None:
    """The :class:`WarmStates` of ``rows``; None without the column."""
    states = warm_states_of(rows)
    if states is None:
        return None
    per_controller = rows.assign(_state=states).dropna(subset=["_state"]).groupby(
        [RowCol.controller, "_state"]).size()
    sharing = int(per_controller[per_controller > 1].sum())
    return WarmStates(len(rows), int(states.nunique(dropna=True)), sharing, sharing > 0)


def flag_interval(flags, rows: pd.DataFrame, method: Method) -> tuple[tuple[float, float],
                                                                      ClusteredCounts]:
    """The 95% interval by ``method`` of the rate of ``flags`` (one per row of ``rows``),
    clustered by the rows' warm states, and the counts it was taken on."""
    counts = clustered_counts(flags, traffic_clusters(rows))
    return interval_of(counts.k_eff, counts.n_eff, method), counts


@dataclasses.dataclass(frozen=True)
class CollisionRate:
    """Counts by status, collisions among the ok rows, their rate and 95% intervals
    (Wilson, and Clopper-Pearson as ``cp_low``/``cp_high``), clustered by warm state:
    ``deff`` is the design effect, ``n_eff`` the effective number of ok runs the
    intervals were taken on, ``warm_states`` the distinct warm states of the ok runs
    (None for results without the column), ``collision_with`` the collisions by what
    was hit, people first (:data:`HIT_ORDER`)."""

    n_ok: int
    n_error: int
    n_timeout: int
    collisions: int
    collision_rate: float | None  # None without an ok run
    wilson_low: float
    wilson_high: float
    cp_low: float
    cp_high: float
    deff: float
    n_eff: float
    warm_states: int | None
    collision_with: dict[str, int]

    @property
    def n_failed(self) -> int:
        """The runs without an outcome (error, timeout)."""
        return self.n_error + self.n_timeout

    @property
    def people_hit(self) -> int:
        """The collisions with a person."""
        return self.collision_with.get(PEDESTRIAN, 0)

    def interval(self, method: Method) -> tuple[float, float]:
        """The 95% interval by ``method``."""
        return ((self.wilson_low, self.wilson_high) if method == "wilson"
                else (self.cp_low, self.cp_high))


def rate_summary(rows: pd.DataFrame) -> CollisionRate:
    """The :class:`CollisionRate` of ``rows``."""
    status = rows[RowCol.status]
    ok = rows[status == "ok"]
    collision = ok[RowCol.collision]
    k, n = int(collision.sum()), len(ok)
    counts = clustered_counts(collision, traffic_clusters(ok))
    wilson = wilson_interval(counts.k_eff, counts.n_eff)
    exact = clopper_pearson_interval(counts.k_eff, counts.n_eff)
    return CollisionRate(
        n_ok=n,
        n_error=int((status == "error").sum()),
        n_timeout=int((status == "timeout").sum()),
        collisions=k,
        collision_rate=k / n if n else None,
        wilson_low=wilson[0], wilson_high=wilson[1],
        cp_low=exact[0], cp_high=exact[1],
        deff=counts.deff, n_eff=float(counts.n_eff),
        warm_states=count_warm_states(ok),
        collision_with=hits_by_kind(ok[RowCol.collision_with][collision]),
    )


#: what a collision was with, in the order the reports list it: people first, always
HIT_ORDER = (PEDESTRIAN, "vehicle", "obstacle", "road_edge")


def hits_by_kind(collision_with: pd.Series) -> dict[str, int]:
    """Collisions counted by what was hit: people first (0 too), then the kinds of
    :data:`HIT_ORDER` that were hit, then any other, by name."""
    counts = collision_with.astype(str).value_counts()
    kinds = [PEDESTRIAN, *(k for k in HIT_ORDER[1:] if k in counts),
             *sorted(k for k in counts.index if k not in HIT_ORDER)]
    return {kind: int(counts.get(kind, 0)) for kind in kinds}


def counted_failures(rows: pd.DataFrame) -> pd.Series:
    """Per run of the rows with a known status: did it fail or collide
    (:func:`analysis.measures.run_outcome.failed_or_collided`)?"""
    return failed_or_collided(rows[rows[RowCol.status].isin(STATUSES)])


def upper_bound_counting_failures(rows: pd.DataFrame, method: Method = "wilson",
                                  collision_with: str | None = None) -> tuple[float, float]:
    """The upper end of the 95% interval (by ``method``, clustered by warm state) of
    the collision rate (with ``collision_with``: of the collisions with that only, e.g.
    ``pedestrian``) with error and timeout runs counted as collisions, and the design
    effect it was taken with."""
    flags = counted_failures(rows)
    if collision_with is not None:
        counted = rows.loc[flags.index]
        flags = ((counted[RowCol.status] != "ok")
                 | (counted[RowCol.collision_with] == collision_with))
    (_, high), counts = flag_interval(flags, rows.loc[flags.index], method)
    return high, counts.deff


def by_controller(results: pd.DataFrame) -> dict[str, CollisionRate]:
    return {str(c): rate_summary(rows)
            for c, rows in results.groupby(RowCol.controller, sort=False)}


def group_values(column: pd.Series, max_groups: int = MAX_GROUPS) -> pd.Series:
    """The column itself, or equal-width bins (an ``Interval`` per row) when it is numeric
    with more than ``max_groups`` distinct values."""
    numeric = pd.api.types.is_numeric_dtype(column) and not pd.api.types.is_bool_dtype(column)
    if numeric and column.nunique() > max_groups:
        return pd.cut(column, max_groups, precision=3)
    return column


def group_levels(groups: pd.Series) -> list:
    """Every group of a :func:`group_values` column, in order: its bins, or its values."""
    if isinstance(groups.dtype, pd.CategoricalDtype):
        return list(groups.cat.categories)
    return sorted(groups.dropna().unique())


def group_label(group) -> str:
    """A group as people read it: a bin as ``12.5 to 20``, a number to 4 digits."""
    if isinstance(group, pd.Interval):
        return f"{number_text(group.left)} to {number_text(group.right)}"
    return number_text(group)


def grouped_runs(results: pd.DataFrame, column: str):
    """(group of ``column``, controller, rows) for every pair with a run, in order."""
    if column not in results.columns:
        known = ", ".join(c for c in results.columns if c.startswith("p.")) or "none"
        raise KeyError(f"--by: no column {column!r} (swept parameters: {known})")
    groups = group_values(results[column])
    for (group, controller), rows in results.groupby([groups, RowCol.controller], sort=True,
                                                     observed=True):
        yield group, controller, rows


def rates_by(results: pd.DataFrame, column: str, method: Method = "wilson") -> pd.DataFrame:
    """One row per (group of ``column``, controller): counts, rate, interval (clustered
    by warm state, with its design effect ``deff`` and the group's ``warm_states``)."""
    out = []
    for group, controller, rows in grouped_runs(results, column):
        rate = rate_summary(rows)
        low, high = rate.interval(method)
        out.append({"group": group, RowCol.controller: controller, "n_ok": rate.n_ok,
                    "n_failed": rate.n_failed, "collisions": rate.collisions,
                    "collision_rate": rate.collision_rate, "low": low, "high": high,
                    "deff": rate.deff, "warm_states": rate.warm_states})
    return pd.DataFrame(out)


@dataclasses.dataclass(frozen=True)
class PairedTest:
    """McNemar's exact test of controllers ``a`` and ``b`` on the samples both ran:
    ``only_a`` samples where the flag held for ``a`` alone, ``only_b`` for ``b`` alone."""

    a: str
    b: str
    pairs: int
    both: int
    neither: int
    only_a: int
    only_b: int
    p_value: float  # two-sided


def paired_test(flags: pd.DataFrame, a: str, b: str) -> PairedTest:
    """McNemar's exact test of controllers ``a`` and ``b`` on ``flags``: one row per
    sample, one bool column per controller (NaN where it has no run to count).

    The two-sided p-value is a binomial test of ``only_a`` among the discordant pairs
    at 1/2. Samples missing either controller are left out.
    """
    pairs = flags.reindex(columns=[a, b]).dropna()
    ca, cb = pairs[a].astype(bool), pairs[b].astype(bool)
    only_a, only_b = int((ca & ~cb).sum()), int((~ca & cb).sum())
    discordant = only_a + only_b
    from scipy import stats  # here: only a comparison of controllers needs it

    p = 1.0 if discordant == 0 else float(stats.binomtest(only_a, discordant, 0.5).pvalue)
    return PairedTest(a, b, len(pairs), int((ca & cb).sum()), int((~ca & ~cb).sum()),
                      only_a, only_b, p)


def mcnemar(results: pd.DataFrame, a: str, b: str) -> PairedTest:
    """:func:`paired_test` of collisions on the samples both controllers ran ok
    (``only_a``: samples where only ``a`` collided)."""
    ok = results[results[RowCol.status] == "ok"]
    flags = (ok.pivot_table(index=RowCol.sample, columns=RowCol.controller,
                            values=RowCol.collision, aggfunc="first")
             if len(ok) else pd.DataFrame())
    return paired_test(flags, a, b)


def sample_stop_possible(results: pd.DataFrame) -> pd.Series | None:
    """Per sample with an obstacle in the ego's path, whether braking alone could stop
    the car before it (``stop_possible`` depends on the sample's scenario alone, so every
    controller's ok run of a sample holds the same); None when the results do not
    record it (written before the column)."""
    if RowCol.stop_possible not in results.columns:
        return None
    known = results.dropna(subset=[RowCol.stop_possible])
    return known.groupby(RowCol.sample)[RowCol.stop_possible].first().astype(bool)


@dataclasses.dataclass(frozen=True)
class StopPossible:
    """The collision rates and paired comparisons on the samples where braking alone
    could stop the car before the obstacle."""

    samples: int  # with an ok run
    samples_obstacle_in_path: int
    samples_stop_possible: int
    by_controller: dict[str, CollisionRate]
    paired: list[PairedTest]


def stop_possible_summary(results: pd.DataFrame, controllers: list[str]) -> StopPossible | None:
    """The :class:`StopPossible` of the results; None for results without the
    ``stop_possible`` column."""
    flags = sample_stop_possible(results)
    if flags is None:
        return None
    possible = results[results[RowCol.sample].isin(flags.index[flags])]
    return StopPossible(
        samples=int(results[RowCol.sample][results[RowCol.status] == "ok"].nunique()),
        samples_obstacle_in_path=len(flags),
        samples_stop_possible=int(flags.sum()),
        by_controller={c: rate_summary(possible[possible[RowCol.controller] == c])
                       for c in controllers},
        paired=[mcnemar(possible, a, b) for a, b in itertools.combinations(controllers, 2)])


@dataclasses.dataclass(frozen=True)
class EnvelopeStop:
    """The group where a :class:`SafeEnvelope` stopped, why (``above``, ``too_few``,
    ``no_runs``), its counts and the upper end of its interval."""

    group: str
    why: str
    n_ok: int
    collisions: int
    n_failed: int  # errors and timeouts, counted as collisions
    high: float


@dataclasses.dataclass(frozen=True)
class SafeEnvelope:
    """How far along ``column`` the collision rate of ``controller`` is shown to stay at
    or below ``threshold`` (:func:`safe_envelope`)."""

    controller: str
    column: str
    threshold: float
    safe_up_to: float | None
    stopped_at: EnvelopeStop | None  # None: every group was shown at or below


def safe_envelope(results: pd.DataFrame, column: str, controller: str,
                  threshold: float = ENVELOPE_RATE) -> SafeEnvelope:
    """How far along ``column`` the collision rate of ``controller`` is shown to stay at
    or below ``threshold``.

    Groups (bins) are walked in increasing order. A group is *shown* at or below
    ``threshold`` when the upper end of its Wilson 95% interval is, its error and
    timeout runs counted as collisions (missing evidence is never safety).
    ``safe_up_to`` is the upper edge of the last such group before the first that is
    not (None when the first is not); that group is ``stopped_at``, and ``why`` says
    why: ``above`` (its rate exceeds ``threshold``), ``too_few`` (its rate does not,
    but its runs are too few to show it), ``no_runs`` (no ok run). ``why`` is None
    when every group was shown at or below. The interval is clustered by warm state
    (:func:`upper_bound_counting_failures`).
    """
    groups = group_levels(group_values(results[column]))  # every controller's: same bins
    mine = {str(group): rows for group, c, rows in grouped_runs(results, column)
            if c == controller}
    safe_up_to, stopped = None, None
    for group in groups:
        rows = mine.get(str(group))
        rate = rate_summary(rows) if rows is not None else None
        n_ok = 0 if rate is None else rate.n_ok
        k = 0 if rate is None else rate.collisions
        failed = 0 if rate is None else rate.n_failed
        high = 1.0 if rows is None else upper_bound_counting_failures(rows)[0]
        if n_ok == 0:
            why = "no_runs"
        elif high <= threshold:
            safe_up_to = group.right if isinstance(group, pd.Interval) else group
            continue
        else:
            why = "above" if k / n_ok > threshold else "too_few"
        stopped = EnvelopeStop(group_label(group), why, n_ok, k, failed, high)
        break
    return SafeEnvelope(controller, column, threshold,
                        None if safe_up_to is None else float(safe_up_to), stopped)
