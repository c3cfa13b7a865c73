"""The estimator on the bank of problems with exact truths, over many seeds.

The figures the issue measured on the single-Gaussian cross-entropy estimator
it replaced (200 seeds, target RHW 0.3): coverage 6 % (three regions), 38 and
47 % (four-branch), 0 % (opposite half-spaces), 59 % (90/10 modes); mean
estimate 0.50-0.91 of the truth; reported CoV 0.06-0.13 against a measured
error of 0.11-0.52. Every bound below fails on that estimator.
``benchmarks/bench_rare_bank.py`` runs the same with 200 seeds.
"""

from __future__ import annotations

import numpy as np
import pytest

from analysis.rare.failure_estimate import mc_equivalent_runs
from analysis.rare.rare_bank import BANK, EMULATED, problem, run_bank

SEEDS = range(40)


@pytest.mark.slow
@pytest.mark.parametrize("name", [p.name for p in (*BANK, *EMULATED)])
def test_the_interval_covers_the_truth_and_the_reported_error_is_the_real_one(name):
    """The bank's problems, and the emulators of the catalog's rare families."""
    result = run_bank(problem(name), SEEDS)
    # at a true 93 % coverage, 40 seeds fall below 80 % with probability ~0.1 %
    assert result.coverage >= 0.80, result
    assert 0.85 <= result.mean_over_truth <= 1.15, result
    # over-confidence (below 1) is the defect; 40 seeds measure the error to about +-11 %,
    # and the 200-seed benchmark holds the ratio to 0.93-1.03
    assert 0.7 <= result.error_ratio <= 1.4, result
    assert result.median_runs <= 6000, result
    assert result.budget_stops <= 1, result
    if name in {p.name for p in EMULATED}:  # the families' claim: 20x fewer runs than MC
        assert result.median_runs * 20 <= mc_equivalent_runs(problem(name).truth, 0.3), result


def test_the_bank_truths_agree_with_plain_monte_carlo():
    rng = np.random.default_rng(0)
    for case in BANK:
        if case.truth < 1e-3:
            continue  # the exact normal tails; the four-branch values are the literature's
        draws = 4_000_000
        failed = sum(int(np.sum(case.score(rng.standard_normal((draws // 4, case.dims))) <= 0))
                     for _ in range(4))
        se = np.sqrt(case.truth * (1 - case.truth) / draws)
        assert abs(failed / draws - case.truth) < 4 * se, case.name
