"""The rare-event estimator on synthetic problems whose failure probability is known exactly."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from analysis.rare.failure_estimate import estimate_from_rows
from analysis.rare.multilevel_is import MultilevelIS
from analysis.rare.proposals import (
    KernelMixture,
    gaussian_proposal,
    nominal_log_density,
    nominal_proposal,
    unit_points,
    weights_from_log_densities,
)
from analysis.rare.rare_events import EstimationLoop, estimate

REPEATS = 120


def linear_problem(dims: int, p_failure: float):
    """Fail when z_1 + ... + z_d > c: exactly p = 1 - Phi(c / sqrt(d))."""
    threshold = math.sqrt(dims) * stats.norm.isf(p_failure)
    return (lambda z: threshold - z.sum(axis=1)), threshold


def discrete_problem():
    """A 3-way choice (a step function of u_3) matters: only choice 2 fails easily.

    score = c - z1 - z2 + 3 * (choice != 2), choice = floor(3 u_3).
    """
    threshold = 4.5

    def score(z):
        choice = np.minimum((unit_points(z[:, 2]) * 3).astype(int), 2)
        return threshold - z[:, 0] - z[:, 1] + 3.0 * (choice != 2)

    root2 = math.sqrt(2.0)
    truth = (stats.norm.sf(threshold / root2) / 3
             + 2 * stats.norm.sf((threshold + 3.0) / root2) / 3)
    return score, truth


def repeated(score_fn, dims, target_rhw=0.3, max_runs=5000, batch_size=100, repeats=REPEATS):
    return [estimate(score_fn, dims, target_rhw, max_runs, np.random.default_rng(seed),
                     batch_size)[0] for seed in range(repeats)]


def coverage(results, truth):
    return np.mean([r.ci_low <= truth <= r.ci_high for r in results])


def standard_errors_off(results, truth):
    ps = np.array([r.p_collision for r in results])
    return abs(ps.mean() - truth) / (ps.std(ddof=1) / math.sqrt(ps.size))


CASES = {
    "d2_p1e-4": (2, 1e-4),
    "d2_p1e-3": (2, 1e-3),
    "d4_p1e-4": (4, 1e-4),
}


@pytest.mark.parametrize("case", CASES)
def test_interval_covers_and_estimate_is_unbiased(case):
    dims, truth = CASES[case]
    score_fn, _ = linear_problem(dims, truth)
    results = repeated(score_fn, dims)
    assert coverage(results, truth) >= 0.90
    assert standard_errors_off(results, truth) < 3.0
    assert all(r.stopped == "target_rhw" for r in results)


def test_a_discrete_coordinate_is_found_and_estimated():
    score_fn, truth = discrete_problem()
    results = repeated(score_fn, 3)
    assert coverage(results, truth) >= 0.90
    assert standard_errors_off(results, truth) < 3.0


def test_importance_sampling_beats_monte_carlo_twentyfold_at_1e_minus_4():
    score_fn, _ = linear_problem(2, 1e-4)
    results = repeated(score_fn, 2, repeats=30)
    assert all(r.rhw <= 0.3 and r.stopped == "target_rhw" for r in results)
    speedups = [r.mc_equivalent_runs / r.runs for r in results]
    assert np.median(speedups) >= 20


def test_history_ends_at_the_estimate():
    score_fn, _ = linear_problem(2, 1e-3)
    result, history = estimate(score_fn, 2, 0.3, 5000, np.random.default_rng(0), 100)
    assert history[-1].runs == result.runs
    assert history[-1].p_collision == result.p_collision
    assert [h.runs for h in history] == sorted(h.runs for h in history)
    assert result.runs > result.estimation_runs  # adaptation runs count, but not in p


def test_the_runs_still_planned_track_what_the_estimate_takes():
    """The progress bar's total (its ETA): the budget until a first estimate, then a projection
    from the RHW that ends at the runs taken; never past the budget nor behind the runs
    done. Over 20 seeds, the first projection in the estimation is within 2x of the end
    (measured: 0.7-1.4; the budget, the bar's old total, is 14x the median 2850)."""
    score_fn, _ = linear_problem(2, 1e-3)
    ratios = []
    for seed in range(20):
        loop = EstimationLoop(2, 0.07, 40000, np.random.default_rng(seed), 100)
        planned = []
        while (z := loop.ask()) is not None:
            loop.tell(z, score_fn(z))
            planned.append((not loop.history, loop.sampler.runs, loop.planned_runs))
        assert loop.stopped == "target_rhw"
        assert all(p == 40000 for no_estimate, _, p in planned if no_estimate)
        assert all(runs <= p <= 40000 for _, runs, p in planned)
        assert planned[-1][2] == loop.sampler.runs  # finished: the runs it took
        first = next(p for no_estimate, _, p in planned if not no_estimate)
        ratios.append(first / loop.sampler.runs)
    assert min(ratios) >= 0.5 and max(ratios) <= 2.0, ratios


def test_weights_are_the_nominal_over_the_mixture_proposal():
    rng = np.random.default_rng(1)
    mean, cov, alpha = np.array([2.0, -1.0]), np.array([[0.5, 0.2], [0.2, 0.8]]), 0.1
    proposal = gaussian_proposal(mean, cov, defensive_fraction=alpha)
    z = proposal.sample(500, rng)
    nominal = stats.multivariate_normal(np.zeros(2), np.eye(2)).pdf(z)
    mixture = alpha * nominal + (1 - alpha) * stats.multivariate_normal(mean, cov).pdf(z)
    weights = weights_from_log_densities(nominal_log_density(z), proposal.log_density(z))
    np.testing.assert_allclose(weights, nominal / mixture, rtol=1e-10)
    np.testing.assert_allclose(np.exp(proposal.log_weights(z)), nominal / mixture, rtol=1e-10)
    assert weights.max() <= proposal.max_weight == pytest.approx(1 / alpha)


def test_proposal_equal_to_nominal_is_plain_monte_carlo():
    rng = np.random.default_rng(2)
    z = nominal_proposal(3).sample(4000, rng)
    failed = z[:, 0] > 1.5
    weights = weights_from_log_densities(nominal_log_density(z),
                                         nominal_proposal(3).log_density(z))
    np.testing.assert_allclose(weights, 1.0)
    result = estimate_from_rows(weights, failed, max_weight=1.0)
    p = failed.mean()
    half_width = 1.959963984540054 * math.sqrt(p * (1 - p) / (failed.size - 1))
    assert result.p_collision == pytest.approx(p)
    assert result.ci_high - result.p_collision == pytest.approx(half_width, rel=1e-9)
    assert result.ess == pytest.approx(failed.size)
    assert result.mc_equivalent_runs == pytest.approx(failed.size - 1, rel=1e-9)


def test_every_run_failing_is_a_probability_of_at_most_one():
    """Where every run failed, the weights' mean may pass 1 by chance (a lane-keep
    estimate over a parked car read P(collision) = 1.09 with its interval [0.987, 1]):
    the estimate is 1 and its interval holds it."""
    weights = np.array([1.4, 0.9, 1.3, 1.2, 0.8, 1.5])  # mean 1.18
    result = estimate_from_rows(weights, np.ones(6, bool), max_weight=10.0)
    assert result.p_collision == 1.0
    assert result.ci_low <= result.p_collision <= result.ci_high == 1.0


def test_estimate_from_rows_recomputes_the_samplers_estimate():
    score_fn, _ = linear_problem(2, 1e-3)
    sampler = MultilevelIS(2, np.random.default_rng(3), 100)
    for _ in range(15):
        z = sampler.ask()
        sampler.tell(z, score_fn(z))
    assert not sampler.adapting
    rows = estimate_from_rows(sampler.estimation_weights(), sampler.estimation_failed,
                              runs=sampler.runs, max_weight=10.0)
    assert rows == sampler.estimate()


def test_no_failure_seen_gives_zero_with_a_rule_of_three_bound():
    result, history = estimate(lambda z: np.ones(len(z)), 2, 0.3, 1000,
                               np.random.default_rng(4), 100)
    assert result.no_failure_seen and result.p_collision == 0.0
    assert result.rhw == math.inf and math.isnan(result.mc_equivalent_runs)
    assert result.stopped == "budget" and result.runs == 1000
    assert result.ci_low == 0.0
    assert result.ci_high == pytest.approx(-math.log(0.05) * 10 / result.estimation_runs)


def test_unit_points_stay_in_the_half_open_cube():
    u = unit_points(np.array([[-40.0, 0.0, 9.0, 40.0]]))
    assert u[0, 0] == 0.0 and u[0, 1] == 0.5 and np.all(u < 1.0)


@pytest.mark.parametrize("kwargs, argument", [
    ({"dims": 0}, "dims"),
    ({"target_rhw": 0.0}, "target_rhw"),
    ({"target_rhw": -0.1}, "target_rhw"),
    ({"max_runs": 150}, "max_runs"),
])
def test_wrong_use_names_the_argument(kwargs, argument):
    call = {"score_fn": lambda z: np.ones(len(z)), "dims": 2, "target_rhw": 0.3,
            "max_runs": 1000, "rng": np.random.default_rng(0), "batch_size": 100} | kwargs
    with pytest.raises(ValueError, match=argument):
        estimate(**call)


def test_tell_rejects_a_batch_of_the_wrong_shape_or_with_nan_scores():
    sampler = MultilevelIS(2, np.random.default_rng(0), 10)
    z = sampler.ask()
    with pytest.raises(ValueError, match="scores"):
        sampler.tell(z, np.ones(9))
    with pytest.raises(ValueError, match="scores"):
        sampler.tell(z, np.full(10, np.nan))
    with pytest.raises(ValueError, match="z"):
        sampler.tell(z[:, :1], np.ones(10))


@pytest.mark.parametrize("bad", [{"shrinkage": 0.0}, {"shrinkage": 1.5}, {"bandwidth_scale": 0.0},
                                 {"explore_scale": -1.0}, {"elite_fraction": 1.0}])
def test_both_samplers_refuse_the_same_kernel_options(bad):
    from analysis.rare.mode_search import ModeSearch

    rng = np.random.default_rng(0)
    name = next(iter(bad))
    with pytest.raises(ValueError, match=name):
        MultilevelIS(2, rng, 20, **bad)
    with pytest.raises(ValueError, match=name):
        ModeSearch(2, 100, rng, 20, **bad)


@pytest.mark.parametrize("dims,kernels,points", [(1, 1, 1), (12, 1, 40), (2, 7, 500),
                                                 (6, 300, 3000), (10, 50, 1000),
                                                 (17, 2500, 40)])
def test_a_mixtures_density_is_the_textbook_sum_to_the_bit(dims, kernels, points):
    """``KernelMixture.log_density`` adds its squares and its kernels in its own loops (the
    estimator's cost): it equals the textbook expression, scipy's ``logsumexp`` over the
    (points, kernels, dims) distances, bit for bit, ties at the maximum and far tails
    included, so a search or an estimate draws what it drew before."""
    from scipy import special

    rng = np.random.default_rng(dims * 1000 + kernels)
    centres = rng.standard_normal((kernels, dims)) * 2.0
    centres[: kernels // 3] = centres[0]  # tied kernels
    mix = rng.dirichlet(np.ones(kernels))
    lower = rng.standard_normal((dims, dims)) * 0.3
    cov = lower @ lower.T + np.eye(dims)
    z = rng.standard_normal((points, dims)) * 3.0
    z[::7] *= 1e3  # far tails
    mixture = KernelMixture(centres, mix, cov)
    chol = np.linalg.cholesky(cov)
    white_c = np.linalg.solve(chol, centres.T).T

    def textbook(points_z: np.ndarray) -> np.ndarray:
        white_z = np.linalg.solve(chol, points_z.T).T
        diff = white_z[:, None, :] - white_c[None, :, :]
        return (special.logsumexp(np.log(mix) - 0.5 * np.sum(diff * diff, axis=2), axis=1)
                - (np.sum(np.log(np.diag(chol))) + 0.5 * dims * math.log(2 * math.pi)))

    assert np.array_equal(mixture.log_density(z), textbook(z))
    # one point at a time (with one kernel: a single distance, summed its own way)
    for i in range(min(points, 40)):
        assert np.array_equal(mixture.log_density(z[i:i + 1]), textbook(z[i:i + 1])), i
