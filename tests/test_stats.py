"""Intervals against scipy's references, grouping, the paired test and the envelope."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from analysis.stats import (
    by_controller,
    clopper_pearson_interval,
    group_values,
    mcnemar,
    rates_by,
    safe_envelope,
    wilson_interval,
)

COUNTS = [(0, 1), (1, 1), (0, 10), (10, 10), (3, 10), (1, 40), (57, 200), (999, 1000)]


@pytest.mark.parametrize(("k", "n"), COUNTS)
def test_wilson_equals_scipy(k, n):
    reference = stats.binomtest(k, n).proportion_ci(0.95, method="wilson")
    assert wilson_interval(k, n) == pytest.approx((reference.low, reference.high), abs=1e-12)


@pytest.mark.parametrize(("k", "n"), COUNTS)
def test_clopper_pearson_equals_scipy_exact(k, n):
    reference = stats.binomtest(k, n).proportion_ci(0.95, method="exact")
    assert clopper_pearson_interval(k, n) == pytest.approx((reference.low, reference.high),
                                                           abs=1e-12)


def test_intervals_of_nothing_are_uninformative():
    assert wilson_interval(0, 0) == (0.0, 1.0) == clopper_pearson_interval(0, 0)


def rows(controller, collisions, statuses=None, **params):
    n = len(collisions)
    return pd.DataFrame({"run_id": [f"{i:03d}-{controller}" for i in range(n)],
                         "sample": range(n), "controller": controller,
                         "status": statuses or ["ok"] * n, "collision": collisions,
                         "collision_with": ["obstacle" if c else "none" for c in collisions],
                         **params})


def test_error_and_timeout_rows_are_counted_apart_never_as_safe():
    results = rows("seed", [True, False, None, None],
                   statuses=["ok", "ok", "error", "timeout"])
    summary = by_controller(results)["seed"]
    assert (summary["n_ok"], summary["n_error"], summary["n_timeout"]) == (2, 1, 1)
    assert summary["collisions"] == 1 and summary["collision_rate"] == 0.5
    assert summary["wilson_low"] == pytest.approx(wilson_interval(1, 2)[0])
    assert summary["collision_with"] == {"obstacle": 1}


def test_continuous_parameters_are_binned_and_discrete_ones_kept():
    speeds = pd.Series(np.linspace(2.0, 30.0, 100))
    binned = group_values(speeds, max_groups=4)
    assert binned.nunique() == 4 and binned.iloc[0].left <= 2.0 and binned.iloc[-1].right >= 30
    kinds = pd.Series(["car", "barrel"] * 50)
    assert group_values(kinds).equals(kinds)


def test_rates_by_a_parameter_and_the_safe_envelope():
    speeds = np.linspace(2.0, 30.0, 120)
    collided = list(speeds > 10.0)  # safe below 10 m/s, always hit above
    results = rows("seed", collided, **{"p.ego.speed_mps": speeds})
    table = rates_by(results, "p.ego.speed_mps")
    assert list(table.controller.unique()) == ["seed"] and table.n_ok.sum() == 120
    assert table.collision_rate.is_monotonic_increasing
    envelope = safe_envelope(results, "p.ego.speed_mps", "seed")
    assert 7.0 <= envelope["safe_up_to"] <= 10.0 + 1e-9
    assert envelope["crossing_group"] is not None
    with pytest.raises(KeyError, match="p.ego.speed_mps"):
        rates_by(results, "p.nothing")


def test_mcnemar_counts_discordant_pairs_and_matches_the_exact_binomial():
    a = rows("seed", [False] * 9 + [True] * 11)
    b = rows("lane-keep", [True] * 20)
    result = mcnemar(pd.concat([a, b]), "seed", "lane-keep")
    assert (result["pairs"], result["only_a"], result["only_b"], result["both"]) == (20, 0, 9, 11)
    assert result["p_value"] == pytest.approx(2 * 0.5**9)  # exact two-sided, b = 0, c = 9
    same = mcnemar(pd.concat([a, a.assign(controller="lane-keep")]), "seed", "lane-keep")
    assert same["p_value"] == 1.0 and not math.isnan(same["p_value"])
