"""Intervals against scipy's references, grouping, the paired test and the envelope."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from analysis.stats.rates import (
    _degrees_of_freedom_factor,
    by_controller,
    clopper_pearson_interval,
    group_values,
    mcnemar,
    rates_by,
    safe_envelope,
    sample_stop_possible,
    stop_possible_summary,
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


def test_the_quantiles_are_scipy_stats_own_to_the_bit():
    """rates.py takes its beta and t quantiles from scipy.special (scipy.stats costs a
    second to import): the same numbers, bit for bit, so no report changed with it;
    whole and fractional (effective) counts."""
    rng = np.random.default_rng(7)
    counts = [*COUNTS, *((k, n) for n in (2, 33, 1500) for k in range(n + 1)),
              *((f * n, n) for n, f in zip(rng.uniform(1, 5000, 300), rng.uniform(0, 1, 300),
                                             strict=True))]
    for k, n in counts:
        for confidence in (0.9, 0.95, 0.99):
            alpha = 1 - confidence
            low = 0.0 if k == 0 else float(stats.beta.ppf(alpha / 2, k, n - k + 1))
            high = 1.0 if k == n else float(stats.beta.ppf(1 - alpha / 2, k + 1, n - k))
            assert clopper_pearson_interval(k, n, confidence) == (low, high), (k, n)
    for n_runs, n_clusters in ((3, 2), (40, 7), (1500, 30), (2000, 1999)):
        upper = 0.975
        expected = float(stats.t.ppf(upper, n_runs - 1) / stats.t.ppf(upper, n_clusters - 1)) ** 2
        assert _degrees_of_freedom_factor(n_runs, n_clusters, 0.95) == expected


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
    assert (summary.n_ok, summary.n_error, summary.n_timeout) == (2, 1, 1)
    assert summary.collisions == 1 and summary.collision_rate == 0.5
    assert summary.wilson_low == pytest.approx(wilson_interval(1, 2)[0])
    assert summary.collision_with == {"pedestrian": 0, "obstacle": 1}  # people always first


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
    # 10 runs a bin: 0 of 10 is not enough to show a rate under 5% (Wilson: up to 27.8%)
    envelope = safe_envelope(results, "p.ego.speed_mps", "seed")
    assert envelope.safe_up_to is None
    assert envelope.stopped_at.why == "too_few"
    assert envelope.stopped_at.high == pytest.approx(wilson_interval(0, 10)[1])
    # 100 runs a bin: 0 of 100 is shown (up to 3.7%) until the first bin with collisions
    many = np.repeat(speeds, 10)
    results = rows("seed", list(many > 10.0), **{"p.ego.speed_mps": many})
    envelope = safe_envelope(results, "p.ego.speed_mps", "seed")
    assert 7.0 <= envelope.safe_up_to <= 10.0 + 1e-9
    assert envelope.stopped_at.why == "above"


def test_the_envelope_counts_errors_against_safety_and_stops_at_empty_bins():
    speeds = np.repeat(np.linspace(2.0, 30.0, 12), 100)  # 12 bins of 100 runs
    statuses = np.where(speeds > 20, "error", "ok")  # no ok run above 20 m/s
    results = rows("avoid", [False] * len(speeds), statuses=list(statuses),
                   **{"p.ego.speed_mps": speeds})
    envelope = safe_envelope(results, "p.ego.speed_mps", "avoid")
    assert envelope.safe_up_to <= 20.0 + 1e-9  # never over the errored bins
    assert envelope.stopped_at.why == "no_runs"
    # every run errored: nothing is shown safe
    every = safe_envelope(results.assign(status="error"), "p.ego.speed_mps", "avoid")
    assert every.safe_up_to is None and every.stopped_at.why == "no_runs"
    # 4 errors among 100 runs of a bin: counted as collisions, 95% up to 9.8% > 5%
    statuses = np.where((speeds < 3) & (np.arange(len(speeds)) % 25 == 0), "error", "ok")
    some = safe_envelope(results.assign(status=statuses), "p.ego.speed_mps", "avoid")
    assert some.safe_up_to is None and some.stopped_at.why == "too_few"
    assert some.stopped_at.n_failed == 4
    with pytest.raises(KeyError, match="p.ego.speed_mps"):
        rates_by(results, "p.nothing")


def test_mcnemar_counts_discordant_pairs_and_matches_the_exact_binomial():
    a = rows("seed", [False] * 9 + [True] * 11)
    b = rows("lane-keep", [True] * 20)
    result = mcnemar(pd.concat([a, b]), "seed", "lane-keep")
    assert (result.pairs, result.only_a, result.only_b, result.both) == (20, 0, 9, 11)
    assert result.p_value == pytest.approx(2 * 0.5**9)  # exact two-sided, b = 0, c = 9
    same = mcnemar(pd.concat([a, a.assign(controller="lane-keep")]), "seed", "lane-keep")
    assert same.p_value == 1.0 and not math.isnan(same.p_value)


def test_the_rates_where_a_stop_was_possible_are_per_sample():
    # 6 samples; a stop was possible in samples 0-2, not in 3-4, and sample 5 has no
    # obstacle in the path; lane-keep's run of sample 2 errored (no value there)
    possible = [True, True, True, False, False, None]
    a = rows("seed", [False, False, True, True, True, False], stop_possible=possible)
    b = rows("lane-keep", [True, True, None, True, True, True],
             statuses=["ok", "ok", "error", "ok", "ok", "ok"],
             stop_possible=[True, True, None, False, False, None])
    results = pd.concat([a, b], ignore_index=True)
    flags = sample_stop_possible(results)
    assert flags.to_dict() == {0: True, 1: True, 2: True, 3: False, 4: False}
    stop = stop_possible_summary(results, ["seed", "lane-keep"])
    assert (stop.samples, stop.samples_obstacle_in_path, stop.samples_stop_possible) \
        == (6, 5, 3)
    seed, lane_keep = stop.by_controller["seed"], stop.by_controller["lane-keep"]
    assert (seed.n_ok, seed.collisions) == (3, 1)
    assert (lane_keep.n_ok, lane_keep.n_error, lane_keep.collisions) == (2, 1, 2)
    [pair] = stop.paired
    assert (pair.pairs, pair.only_a, pair.only_b, pair.both) == (2, 0, 2, 0)
    assert by_controller(results)["seed"].collisions == 3  # overall: every sample


def test_results_without_the_column_do_not_record_it():
    results = pd.concat([rows("seed", [True, False]), rows("lane-keep", [True, True])])
    assert sample_stop_possible(results) is None
    assert stop_possible_summary(results, ["seed", "lane-keep"]) is None


def test_mcnemar_without_an_ok_run_of_one_controller_has_no_pairs():
    results = pd.concat([rows("seed", [True, False]),
                         rows("lane-keep", [None, None], statuses=["error", "error"])])
    assert mcnemar(results, "seed", "lane-keep").pairs == 0
    assert mcnemar(results.iloc[:0], "seed", "lane-keep").p_value == 1.0


def test_results_without_warm_states_have_no_design_effect():
    summary = by_controller(rows("seed", [True, False, False]))["seed"]
    assert (summary.deff, summary.n_eff, summary.warm_states) == (1.0, 3.0, None)
    assert (summary.wilson_low, summary.wilson_high) == wilson_interval(1, 3)
