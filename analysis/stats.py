"""Collision statistics of a sweep's result table: rates with honest intervals.

Only ``status == "ok"`` rows count toward a rate; error and timeout rows are
counted beside it, never as "no collision".
"""

from __future__ import annotations

import itertools
import math
from statistics import NormalDist
from typing import Literal

import pandas as pd
from scipy import stats

Method = Literal["wilson", "clopper-pearson"]
#: a continuous parameter with more distinct values than this is binned for grouping
MAX_GROUPS = 12
ENVELOPE_RATE = 0.05


def wilson_interval(k: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval for ``k`` successes in ``n`` trials ((0, 1) when n = 0)."""
    if n == 0:
        return 0.0, 1.0
    z = NormalDist().inv_cdf(0.5 + confidence / 2)
    p = k / n
    denom = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    return max(0.0, centre - half), min(1.0, centre + half)


def clopper_pearson_interval(k: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Exact (Clopper-Pearson) interval from beta quantiles ((0, 1) when n = 0)."""
    if n == 0:
        return 0.0, 1.0
    alpha = 1 - confidence
    low = 0.0 if k == 0 else float(stats.beta.ppf(alpha / 2, k, n - k + 1))
    high = 1.0 if k == n else float(stats.beta.ppf(1 - alpha / 2, k + 1, n - k))
    return low, high


def interval_of(k: int, n: int, method: Method) -> tuple[float, float]:
    """The 95% interval of ``k`` in ``n`` by ``method``."""
    return (wilson_interval if method == "wilson" else clopper_pearson_interval)(k, n)


def rate_summary(rows: pd.DataFrame) -> dict:
    """Counts by status, collisions among the ok rows, their rate and 95% intervals
    (Wilson, and Clopper-Pearson as ``cp_low``/``cp_high``)."""
    ok = rows[rows.status == "ok"]
    k, n = int(ok.collision.sum()), len(ok)
    wilson, exact = wilson_interval(k, n), clopper_pearson_interval(k, n)
    return {
        "n_ok": n,
        "n_error": int((rows.status == "error").sum()),
        "n_timeout": int((rows.status == "timeout").sum()),
        "collisions": k,
        "collision_rate": k / n if n else None,
        "wilson_low": wilson[0], "wilson_high": wilson[1],
        "cp_low": exact[0], "cp_high": exact[1],
        "collision_with": {str(kind): int(count) for kind, count in
                           ok.collision_with[ok.collision].value_counts().sort_index().items()},
    }


def interval(summary: dict, method: Method) -> tuple[float, float]:
    """The 95% interval of a :func:`rate_summary` by ``method``."""
    prefix = "wilson" if method == "wilson" else "cp"
    return summary[f"{prefix}_low"], summary[f"{prefix}_high"]


def by_controller(results: pd.DataFrame) -> dict[str, dict]:
    return {str(c): rate_summary(rows)
            for c, rows in results.groupby("controller", sort=False)}


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
    """A group as people read it: a bin as ``(a, b]``, a number to 3 digits."""
    if isinstance(group, float):
        return f"{group:.3g}"
    return str(group)


def rates_by(results: pd.DataFrame, column: str, method: Method = "wilson") -> pd.DataFrame:
    """One row per (group of ``column``, controller): counts, rate, interval."""
    if column not in results.columns:
        known = ", ".join(c for c in results.columns if c.startswith("p.")) or "none"
        raise KeyError(f"--by: no column {column!r} (swept parameters: {known})")
    groups = group_values(results[column])
    out = []
    for (group, controller), rows in results.groupby([groups, "controller"], sort=True,
                                                     observed=True):
        summary = rate_summary(rows)
        low, high = interval(summary, method)
        out.append({"group": group, "controller": controller, "n_ok": summary["n_ok"],
                    "n_failed": summary["n_error"] + summary["n_timeout"],
                    "collisions": summary["collisions"],
                    "collision_rate": summary["collision_rate"], "low": low, "high": high})
    return pd.DataFrame(out)


def paired_test(flags: pd.DataFrame, a: str, b: str) -> dict:
    """McNemar's exact test of controllers ``a`` and ``b`` on ``flags``: one row per
    sample, one bool column per controller (NaN where it has no run to count).

    ``only_a`` counts samples where the flag holds for ``a`` alone, ``only_b`` for
    ``b`` alone; the two-sided p-value is a binomial test of ``only_a`` among the
    discordant pairs at 1/2. Samples missing either controller are left out.
    """
    pairs = flags.reindex(columns=[a, b]).dropna()
    ca, cb = pairs[a].astype(bool), pairs[b].astype(bool)
    only_a, only_b = int((ca & ~cb).sum()), int((~ca & cb).sum())
    discordant = only_a + only_b
    p = 1.0 if discordant == 0 else float(stats.binomtest(only_a, discordant, 0.5).pvalue)
    return {"a": a, "b": b, "pairs": len(pairs), "both": int((ca & cb).sum()),
            "neither": int((~ca & ~cb).sum()), "only_a": only_a, "only_b": only_b,
            "p_value": p}


def mcnemar(results: pd.DataFrame, a: str, b: str) -> dict:
    """:func:`paired_test` of collisions on the samples both controllers ran ok
    (``only_a``: samples where only ``a`` collided)."""
    ok = results[results.status == "ok"]
    flags = (ok.pivot_table(index="sample", columns="controller", values="collision",
                            aggfunc="first") if len(ok) else pd.DataFrame())
    return paired_test(flags, a, b)


def sample_stop_possible(results: pd.DataFrame) -> pd.Series | None:
    """Per sample with an obstacle in the ego's path, whether braking alone could stop
    the car before it (``stop_possible`` depends on the sample's scenario alone, so every
    controller's ok run of a sample holds the same); None when the results do not
    record it (written before the column)."""
    if "stop_possible" not in results.columns:
        return None
    known = results.dropna(subset=["stop_possible"])
    return known.groupby("sample").stop_possible.first().astype(bool)


def stop_possible_summary(results: pd.DataFrame, controllers: list[str]) -> dict:
    """The collision rates and the paired comparisons restricted to the samples where
    a brake-only stop was possible; ``{"recorded": False}`` without the column."""
    flags = sample_stop_possible(results)
    if flags is None:
        return {"recorded": False}
    possible = results[results["sample"].isin(flags.index[flags])]
    return {"recorded": True,
            "samples": int(results["sample"][results.status == "ok"].nunique()),  # with a run
            "samples_obstacle_in_path": len(flags),
            "samples_stop_possible": int(flags.sum()),
            "by_controller": {c: rate_summary(possible[possible.controller == c])
                              for c in controllers},
            "paired": [mcnemar(possible, a, b)
                       for a, b in itertools.combinations(controllers, 2)]}


def safe_envelope(results: pd.DataFrame, column: str, controller: str,
                  threshold: float = ENVELOPE_RATE) -> dict:
    """How far along ``column`` the collision rate of ``controller`` is shown to stay at
    or below ``threshold``.

    Groups (bins) are walked in increasing order. A group is *shown* at or below
    ``threshold`` when the upper end of its Wilson 95% interval is, its error and
    timeout runs counted as collisions (missing evidence is never safety).
    ``safe_up_to`` is the upper edge of the last such group before the first that is
    not (None when the first is not); that group is ``stopped_at``, and ``why`` says
    why: ``above`` (its rate exceeds ``threshold``), ``too_few`` (its rate does not,
    but its runs are too few to show it), ``no_runs`` (no ok run). ``why`` is None
    when every group was shown at or below.
    """
    groups = group_levels(group_values(results[column]))  # every controller's: same bins
    table = rates_by(results, column)
    rows = {str(r.group): r for r in table[table.controller == controller].itertuples()}
    safe_up_to, stopped = None, None
    for group in groups:
        row = rows.get(str(group))
        n_ok = 0 if row is None else int(row.n_ok)
        k = 0 if row is None else int(row.collisions)
        failed = 0 if row is None else int(row.n_failed)
        high = wilson_interval(k + failed, n_ok + failed)[1]
        if n_ok == 0:
            why = "no_runs"
        elif high <= threshold:
            safe_up_to = group.right if isinstance(group, pd.Interval) else group
            continue
        else:
            why = "above" if k / n_ok > threshold else "too_few"
        stopped = {"group": group_label(group), "why": why, "n_ok": n_ok, "collisions": k,
                   "n_failed": failed, "high": high}
        break
    return {"controller": controller, "column": column, "threshold": threshold,
            "safe_up_to": None if safe_up_to is None else float(safe_up_to),
            "stopped_at": stopped}
