"""Reliability problems with exactly known failure probabilities, to check estimators on.

Each :class:`Problem` lives in standard-normal space ``z`` (the space of
:mod:`analysis.rare_events`) and fails where its vectorised score ``g(z) <= 0``.
The bank holds the standard cases where a sampler that adapts to one failure
region goes wrong: several regions of equal or unequal mass, regions on
opposite sides, curved boundaries, and one region in ten dimensions.

The truths are exact (normal tails) except the four-branch series system,
whose values are the literature's (Waarts 2000; Au and Beck 1999), checked
here by 10^8 plain Monte Carlo draws (``tests/test_rare_bank.py`` redoes a
smaller check).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np
from scipy import special

ScoreFn = Callable[[np.ndarray], np.ndarray]
_ROOT2 = math.sqrt(2.0)


def _tail(beta: float) -> float:
    """``P(N(0, 1) > beta)``."""
    return float(special.ndtr(-beta))


@dataclasses.dataclass(frozen=True)
class Problem:
    name: str
    dims: int
    score: ScoreFn  # z (n, dims) -> n scores, <= 0: failure
    truth: float
    regions: int  # separate failure regions
    about: str


def _three_regions(z: np.ndarray) -> np.ndarray:
    return np.minimum(3.66 - z[:, 0], 3.6775 - np.abs(z[:, 1]))


def _blind_three_regions(z: np.ndarray) -> np.ndarray:
    offset = np.abs(z[:, 1]) > 3.6775
    return np.where(offset, 0.0, np.maximum(3.66 - z[:, 0], 0.0))


def _four_branch(k: float) -> ScoreFn:
    def score(z: np.ndarray) -> np.ndarray:
        a, b = z[:, 0], z[:, 1]
        bent = 3.0 + 0.1 * (a - b) ** 2
        return np.minimum.reduce([bent - (a + b) / _ROOT2, bent + (a + b) / _ROOT2,
                                  (a - b) + k / _ROOT2, (b - a) + k / _ROOT2])
    return score


def _linear(beta: float) -> ScoreFn:
    def score(z: np.ndarray) -> np.ndarray:
        return beta - z.sum(axis=1) / math.sqrt(z.shape[1])
    return score


def _opposite(beta: float) -> ScoreFn:
    def score(z: np.ndarray) -> np.ndarray:
        return beta - np.abs(z.sum(axis=1)) / math.sqrt(z.shape[1])
    return score


def _unequal_modes(z: np.ndarray) -> np.ndarray:
    return np.minimum(3.74555 - z[:, 0], 4.26489 + z[:, 0])


BANK: tuple[Problem, ...] = (
    Problem("three-regions", 2, _three_regions,
            1.0 - (1.0 - _tail(3.66)) * (1.0 - 2.0 * _tail(3.6775)), 3,
            "min(3.66 - z0, 3.6775 - |z1|): too fast, or an offset to either side"),
    Problem("blind-three-regions", 2, _blind_three_regions,
            1.0 - (1.0 - _tail(3.66)) * (1.0 - 2.0 * _tail(3.6775)), 3,
            "three-regions where the score warns of one region only: |z1| > 3.6775 fails "
            "with no near miss before it (a detection that misses, like seed-modes' barrel)"),
    Problem("four-branch-k6", 2, _four_branch(6.0), 4.4573e-3, 4,
            "the four-branch series system, k = 6: four regions of similar mass"),
    Problem("four-branch-k7", 2, _four_branch(7.0), 2.2228e-3, 4,
            "the four-branch series system, k = 7: two regions dominate"),
    Problem("linear-d2", 2, _linear(3.71902), _tail(3.71902), 1,
            "3.71902 - sum(z) / sqrt(2): one half-space"),
    Problem("linear-d10", 10, _linear(3.71902), _tail(3.71902), 1,
            "3.71902 - sum(z) / sqrt(10): one half-space in ten dimensions"),
    Problem("opposite-d6", 6, _opposite(3.89059), 2.0 * _tail(3.89059), 2,
            "3.89059 - |sum(z)| / sqrt(6): two half-spaces on opposite sides"),
    Problem("unequal-modes-d4", 4, _unequal_modes, _tail(3.74555) + _tail(4.26489), 2,
            "min(3.74555 - z0, 4.26489 + z0): modes holding 90 % and 10 %"),
)


def problem(name: str) -> Problem:
    for candidate in BANK:
        if candidate.name == name:
            return candidate
    raise KeyError(f"no problem {name!r} in the bank ({', '.join(p.name for p in BANK)})")


@dataclasses.dataclass(frozen=True)
class BankResult:
    """How an estimator did on one problem over many seeds.

    ``coverage``: the share of seeds whose 95 % interval holds the truth;
    ``mean_over_truth``: the mean estimate over the truth; ``reported_cov``: the
    mean coefficient of variation the estimates reported (``se / p``);
    ``measured_error``: the root mean square of ``(p - truth) / truth``, the
    error they made; ``median_runs``: the median runs spent; ``budget_stops``:
    seeds that ran out of budget before the target.
    """

    problem: str
    seeds: int
    coverage: float
    mean_over_truth: float
    reported_cov: float
    measured_error: float
    median_runs: float
    budget_stops: int

    @property
    def error_ratio(self) -> float:
        """Reported over measured error: 1 is honest, below 1 over-confident."""
        return self.reported_cov / self.measured_error


def run_bank(case: Problem, seeds: range, target_rhw: float = 0.3, max_runs: int = 20_000,
             **options) -> BankResult:
    """:func:`analysis.rare_events.estimate` on ``case`` once per seed (``options`` go to
    it), summed up against the truth."""
    from analysis.rare_events import Z_95, estimate

    found = [estimate(case.score, case.dims, target_rhw, max_runs, np.random.default_rng(seed),
                      **options)[0] for seed in seeds]
    p = np.array([e.p_collision for e in found])
    covered = [e.ci_low <= case.truth <= e.ci_high for e in found]
    reported = [e.rhw / Z_95 for e in found if math.isfinite(e.rhw)]
    return BankResult(
        problem=case.name, seeds=len(found), coverage=float(np.mean(covered)),
        mean_over_truth=float(p.mean() / case.truth),
        reported_cov=float(np.mean(reported)) if reported else math.inf,
        measured_error=float(np.sqrt(np.mean((p / case.truth - 1.0) ** 2))),
        median_runs=float(np.median([e.runs for e in found])),
        budget_stops=sum(e.stopped == "budget" for e in found))
