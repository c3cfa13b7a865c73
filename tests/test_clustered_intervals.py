"""Rate intervals over runs that share a warm state (their background traffic).

Runs started from one warm state are a cluster, not independent samples: the
intervals are taken on the effective number of runs (:func:`clustered_counts`).
Checked here: the plain interval comes back exactly without shared clusters; the
design effect by hand; the rule when no variance can be estimated; and, on
clustered data with a known truth over 2,000 seeds, that the corrected interval
covers the truth about 95% of the time where the plain one does not, and that the
error it reports is the error it makes. Then the report that says so.
"""

from __future__ import annotations

import functools
import html
import json
import math

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from scipy import stats

from analysis.report.sweep_report import write_report
from analysis.report.sweep_words import FEW_WARM_STATES
from analysis.stats.gate import gate
from analysis.stats.rates import (
    ClusteredCounts,
    clopper_pearson_interval,
    clustered_counts,
    rate_summary,
    rates_by,
    safe_envelope,
    warm_state_summary,
    wilson_interval,
)
from analysis.stats.verdicts import outcome_summary

COUNTS = [(0, 1), (1, 1), (0, 10), (10, 10), (3, 10), (1, 40), (57, 200), (999, 1000)]


def _flags(k: int, n: int) -> np.ndarray:
    return np.arange(n) < k


@pytest.mark.parametrize(("k", "n"), COUNTS)
@pytest.mark.parametrize("labels", ["none", "distinct", "all null", "some null"])
def test_without_a_shared_cluster_the_interval_is_the_plain_one_exactly(k, n, labels):
    clusters = {"none": None,
                "distinct": [f"w{i}" for i in range(n)],
                "all null": [None] * n,
                "some null": [None if i % 2 else f"w{i}" for i in range(n)]}[labels]
    counts = clustered_counts(_flags(k, n), clusters)
    assert counts == ClusteredCounts(k, n, 1.0, n)
    assert isinstance(counts.k_eff, int) and isinstance(counts.n_eff, int)
    assert wilson_interval(counts.k_eff, counts.n_eff) == wilson_interval(k, n)
    assert clopper_pearson_interval(counts.k_eff, counts.n_eff) == \
        clopper_pearson_interval(k, n)


def test_no_runs_have_the_uninformative_interval():
    counts = clustered_counts(np.array([], dtype=bool), [])
    assert counts == (0, 0, 1.0, 0)
    assert wilson_interval(counts.k_eff, counts.n_eff) == (0.0, 1.0)


def test_the_design_effect_by_hand():
    # clusters a (3 of 3), b (0 of 3), c (1 of 2): p = 1/2, Y - p m = (1.5, -1.5, 0)
    flags = [1, 1, 1, 0, 0, 0, 1, 0]
    counts = clustered_counts(flags, list("aaabbbcc"))
    variance = 3 / 2 * (1.5**2 + 1.5**2) / 8**2
    deff = variance / (0.25 / 8)
    assert counts.deff == pytest.approx(deff) == pytest.approx(3.375)
    # the variance rests on 3 clusters: t with 2 degrees of freedom, not 7
    shrink = (stats.t.ppf(0.975, 7) / stats.t.ppf(0.975, 2)) ** 2
    assert counts.n_eff == pytest.approx(8 / deff * shrink)
    assert counts.k_eff == pytest.approx(counts.n_eff / 2) and counts.n_clusters == 3


def test_null_labels_are_clusters_of_one_run():
    flags = [1, 1, 0, 1, 0, 0]
    assert clustered_counts(flags, ["a", "a", "a", None, None, np.nan]) == \
        clustered_counts(flags, ["a", "a", "a", "x", "y", "z"])


def test_the_interval_is_never_narrower_than_the_plain_one():
    # every cluster has the same rate: no spread between them, a design effect of 1,
    # and still the fewer degrees of freedom
    flags = np.tile([True, False, False, False], 6)
    counts = clustered_counts(flags, np.repeat(np.arange(6), 4))
    assert counts.deff == 1.0 and counts.n_eff < 24
    low, high = wilson_interval(counts.k_eff, counts.n_eff)
    plain_low, plain_high = wilson_interval(6, 24)
    assert low < plain_low and high > plain_high


def test_no_event_counts_each_warm_state_once():
    """0 or all events: no spread to estimate; runs of a cluster are taken to agree
    (the worst case), so 8 warm states of 25 runs are worth 8 runs."""
    clusters = np.repeat(np.arange(8), 25)
    none = clustered_counts(np.zeros(200, bool), clusters)
    assert none == pytest.approx((0.0, 8.0, 25.0, 8))
    assert wilson_interval(none.k_eff, none.n_eff) == pytest.approx(wilson_interval(0, 8))
    assert clopper_pearson_interval(none.k_eff, none.n_eff) == \
        pytest.approx(clopper_pearson_interval(0, 8))
    every = clustered_counts(np.ones(200, bool), clusters)
    assert every == pytest.approx((8.0, 8.0, 25.0, 8))
    assert clopper_pearson_interval(every.k_eff, every.n_eff) == \
        pytest.approx(clopper_pearson_interval(8, 8))
    # unequal clusters: n^2 / sum m^2 (a big cluster weighs more), between 1 and G
    sizes = np.array([50, 10, 10, 10, 1, 1])
    unequal = clustered_counts(np.zeros(sizes.sum(), bool), np.repeat(np.arange(6), sizes))
    assert unequal.n_eff == pytest.approx(82**2 / (2500 + 300 + 2)) and 1 < unequal.n_eff < 6


def test_one_warm_state_is_worth_one_run():
    counts = clustered_counts([1, 0, 0, 1, 0], ["w"] * 5)
    assert counts.n_eff == pytest.approx(1.0) and counts.n_clusters == 1
    assert counts.k_eff == pytest.approx(0.4)
    assert wilson_interval(counts.k_eff, counts.n_eff)[1] - \
        wilson_interval(counts.k_eff, counts.n_eff)[0] > 0.7


# known truth: 8 warm states of 25 runs; a warm state's collision rate is drawn from
# Beta(0.8, 3.2): mean 0.2, intraclass correlation 1 / (0.8 + 3.2 + 1) = 0.2
TRUE_RATE, ICC, WARM_STATES, RUNS_PER_STATE, SEEDS = 0.2, 0.2, 8, 25, 2000
TRUE_SE = math.sqrt(TRUE_RATE * (1 - TRUE_RATE) / (WARM_STATES * RUNS_PER_STATE)
                    * (1 + (RUNS_PER_STATE - 1) * ICC))


@functools.cache
def replications(icc: float = ICC) -> pd.DataFrame:
    """Per seed: the observed rate, the plain and the corrected Wilson intervals, and
    the error each reports (the binomial one, and the one with the design effect)."""
    rng = np.random.default_rng(20240611)
    shape = 1 / icc - 1
    clusters = np.repeat(np.arange(WARM_STATES), RUNS_PER_STATE)
    rows = []
    for _ in range(SEEDS):
        rates = rng.beta(TRUE_RATE * shape, (1 - TRUE_RATE) * shape, WARM_STATES)
        flags = rng.random(clusters.size) < rates[clusters]
        k, n = int(flags.sum()), flags.size
        counts = clustered_counts(flags, clusters)
        p = k / n
        rows.append({"p": p,
                     "plain": wilson_interval(k, n),
                     "corrected": wilson_interval(counts.k_eff, counts.n_eff),
                     "plain_se": math.sqrt(p * (1 - p) / n),
                     "corrected_se": math.sqrt(p * (1 - p) * counts.deff / n)})
    return pd.DataFrame(rows)


def coverage(intervals: pd.Series, truth: float = TRUE_RATE) -> float:
    return float(np.mean([low <= truth <= high for low, high in intervals]))


def test_the_corrected_interval_covers_the_truth_the_plain_one_misses():
    """Measured (these 2,000 seeds): plain Wilson covers 0.2 in 58.5% of them, the
    corrected one in 94.9%; with a normal critical value instead of t on 7 degrees
    of freedom it was 90.5%."""
    runs = replications()
    plain, corrected = coverage(runs.plain), coverage(runs.corrected)
    assert plain < 0.7
    assert 0.92 <= corrected <= 0.975


def test_the_corrected_error_is_the_error_made():
    """The standard error behind the interval, sqrt(p (1 - p) deff / n), against the
    spread of the rate over seeds (0.0688; the model's 0.0681): measured 0.0684 (root
    mean square; mean 0.0652), where the binomial one is 0.0279. The half-width over
    t is 0.0622, 0.91 of the truth."""
    runs = replications()
    made = runs.p.std()
    assert made == pytest.approx(TRUE_SE, rel=0.06)  # the simulation is the model
    reported = math.sqrt((runs.corrected_se**2).mean())
    assert reported / made == pytest.approx(1.0, abs=0.1)
    assert math.sqrt((runs.plain_se**2).mean()) / made < 0.5
    # the width follows: its half over the t critical value (7 degrees of freedom)
    half = runs.corrected.map(lambda iv: (iv[1] - iv[0]) / 2)
    assert half.mean() / stats.t.ppf(0.975, WARM_STATES - 1) / TRUE_SE == \
        pytest.approx(1.0, abs=0.15)


def test_without_a_warm_state_effect_the_cost_is_bounded():
    """Independent runs labelled with 8 warm states (ICC 0.001): still at least
    nominal (measured 98.5%), and the price of 7 degrees of freedom is under 1.5 times
    the width (measured 1.31)."""
    runs = replications(0.001)
    assert coverage(runs.corrected) >= 0.94
    width = runs.corrected.map(lambda iv: iv[1] - iv[0]).mean()
    plain = runs.plain.map(lambda iv: iv[1] - iv[0]).mean()
    assert 1.0 < width / plain < 1.5


def _results(warm: bool) -> pd.DataFrame:
    """Two controllers on 60 samples, 20 from each of 3 warm states: both collide in
    15 of the 20 samples of w0, 2 of w1, none of w2 (17 in all); lane-keep's runs of
    two samples of w2 are errors."""
    runs = []
    for sample in range(60):
        state, nth = sample % 3, sample // 3  # the nth sample of its warm state
        hit = {0: nth % 4 != 3, 1: nth in (0, 10), 2: False}[state]
        for controller in ("seed", "lane-keep"):
            error = controller == "lane-keep" and sample in (2, 5)
            runs.append({"run_id": f"{sample:03d}-{controller}", "run_index": len(runs),
                         "sample": sample, "controller": controller, "backend": "sumo",
                         "status": "error" if error else "ok",
                         "error": "RuntimeError: boom" if error else None,
                         "collision": None if error else hit,
                         "collision_with": None if error else ("obstacle" if hit else "none"),
                         "collision_time_s": 3.0 if hit and not error else float("nan"),
                         "min_gap_obstacle_m": 0.0 if hit else 4.0, "min_ttc_s": 1.0,
                         "wall_time_s": 0.5,
                         "outcome": None if error else ("collided" if hit else "completed"),
                         "progress_m": 50.0, "time_lost_s": 1.0,
                         "p.ego.speed_mps": 5.0 + sample % 4,
                         "warm_state": f"w{state}"})
    frame = pd.DataFrame(runs)
    return frame if warm else frame.drop(columns="warm_state")


def _sweep(tmp_path, name: str, results: pd.DataFrame):
    directory = tmp_path / name
    directory.mkdir()
    manifest = {"sweep": {"sweep": {"name": name}}, "runs": len(results), "status": "complete"}
    (directory / "manifest.json").write_text(json.dumps(manifest))
    pq.write_table(pa.Table.from_pandas(results, preserve_index=False),
                   directory / "results.parquet")
    return directory


def test_the_report_says_how_few_warm_states_and_widens(tmp_path):
    warm = write_report(_sweep(tmp_path, "warm", _results(True)), fail_above=0.99)
    plain = write_report(_sweep(tmp_path, "plain", _results(False)), fail_above=0.99)
    assert warm.summary["warm_states"] == {"recorded": True, "runs": 120, "distinct": 3,
                                           "runs_sharing": 120, "shared": True}
    assert plain.summary["warm_states"] == {"recorded": False}

    seed, seed_plain = warm.summary["by_controller"]["seed"], plain.summary["by_controller"]["seed"]
    assert seed["collisions"] == seed_plain["collisions"] == 17
    assert seed["deff"] > 5 and seed["warm_states"] == 3 and seed_plain["warm_states"] is None
    assert seed["wilson_high"] - seed["wilson_low"] > \
        2 * (seed_plain["wilson_high"] - seed_plain["wilson_low"])
    assert (seed_plain["wilson_low"], seed_plain["wilson_high"]) == wilson_interval(17, 60)
    done = warm.summary["verdicts"]["by_controller"]["seed"]["outcomes"]["completed"]
    done_plain = plain.summary["verdicts"]["by_controller"]["seed"]["outcomes"]["completed"]
    assert done["high"] - done["low"] > done_plain["high"] - done_plain["low"]
    assert warm.summary["gate"]["upper_bounds"]["seed"] > \
        plain.summary["gate"]["upper_bounds"]["seed"]

    markdown = (tmp_path / "warm" / "report.md").read_text()
    warning = ("WARNING: the traffic's variety is only 3 warm states: the intervals cannot "
               f"speak for traffic beyond them; raise [sweep] warm_states to {FEW_WARM_STATES} "
               "or more.")
    assert FEW_WARM_STATES > 3
    assert "the 120 runs drew their background traffic from 3 distinct warm states" in markdown
    assert "every interval is widened by its design effect" in markdown
    assert f"**{warning}**" in markdown
    assert f"collision rate: seed {seed['deff']:.2f}, lane-keep" in markdown
    assert "| controller | ok runs | collisions | rate | 95% interval | people | vehicles | " \
           "obstacles | road edge | errors | timeouts | design effect |" in markdown
    assert "| seed | 60 | 17 | 28.3% |" in markdown
    assert warning in warm.terminal
    assert f'<p class="warn">{html.escape(warning)}</p>' in warm.html_path.read_text()
    assert any("widened for runs sharing a warm state" in line for line in warm.terminal)

    plain_markdown = (tmp_path / "plain" / "report.md").read_text()
    assert "warm state" not in plain_markdown and "design effect" not in plain_markdown
    assert not any("warm state" in line for line in plain.terminal)


def test_one_run_a_warm_state_needs_no_warning(tmp_path):
    results = _results(True).assign(warm_state=lambda f: [f"w{i}" for i in range(len(f))])
    report = write_report(_sweep(tmp_path, "own", results))
    assert report.summary["warm_states"]["shared"] is False
    assert not any("warm state" in line for line in report.terminal)
    seed = report.summary["by_controller"]["seed"]
    assert (seed["wilson_low"], seed["wilson_high"]) == wilson_interval(17, 60)


def test_every_rate_of_the_report_is_clustered():
    results, plain = _results(True), _results(False)
    seed = results[results.controller == "seed"]
    width = {name: rate_summary(rows).wilson_high - rate_summary(rows).wilson_low
             for name, rows in (("warm", seed), ("plain", seed.drop(columns="warm_state")))}
    assert width["warm"] > width["plain"]
    by = rates_by(results, "p.ego.speed_mps")
    by_plain = rates_by(plain, "p.ego.speed_mps")
    assert ((by.high - by.low) >= (by_plain.high - by_plain.low)).all()
    assert (by.deff > 1).any() and (by.warm_states == 3).all()
    outcomes = outcome_summary(seed).outcomes["collided"]
    assert outcomes.deff > 1
    assert outcome_summary(plain[plain.controller == "seed"]).outcomes["collided"].high \
        == wilson_interval(17, 60)[1] < outcomes.high
    bound = gate(results, ["seed", "lane-keep"], 0.5, "wilson")
    bound_plain = gate(plain, ["seed", "lane-keep"], 0.5, "wilson")
    assert bound_plain.upper_bounds["lane-keep"] == wilson_interval(19, 60)[1]
    assert bound.upper_bounds["lane-keep"] > bound_plain.upper_bounds["lane-keep"]
    assert bound.design_effects["lane-keep"] > 1 == bound_plain.design_effects["seed"]
    envelope = safe_envelope(results, "p.ego.speed_mps", "seed", threshold=0.6)
    envelope_plain = safe_envelope(plain, "p.ego.speed_mps", "seed", threshold=0.6)
    # plain: 15 runs a speed show the rate at or below 60% up to 7 m/s; clustered, not one
    assert envelope_plain.safe_up_to == 7.0 and envelope.safe_up_to is None
    assert envelope.stopped_at.why == "too_few"


def test_many_warm_states_are_named_without_a_warning(tmp_path):
    results = _results(True).assign(warm_state=lambda f: [f"w{s % 12}" for s in f["sample"]])
    report = write_report(_sweep(tmp_path, "many", results))
    assert FEW_WARM_STATES <= 12
    assert any("from 12 distinct warm states" in line for line in report.terminal)
    assert not any(line.startswith("WARNING") for line in report.terminal)


def test_a_sample_whose_controllers_share_its_warm_state_is_no_cluster():
    """Without ``sweep.warm_states`` each sample warms up its own traffic and its
    controllers share it: the paired design, each controller's runs independent."""
    rows = pd.DataFrame({"controller": ["seed", "avoid"] * 6,
                         "warm_state": [f"s{i // 2}" for i in range(12)]})
    summary = warm_state_summary(rows)
    assert summary.distinct == 6 and not summary.shared
    rows.loc[rows.index[-2:], "warm_state"] = "s0"  # sample 5 drew sample 0's state
    assert warm_state_summary(rows).runs_sharing == 4
