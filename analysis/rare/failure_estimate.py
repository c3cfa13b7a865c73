"""A failure probability estimated from importance-weighted runs: :class:`Estimate`
(the probability, its 95 % interval, what it cost), :func:`estimate_from_rows` from the
weights stored in the rows (the rule of three where none failed), and the plain Monte
Carlo runs an estimate is worth. The method: :mod:`analysis.rare.rare_events`."""

from __future__ import annotations

import dataclasses
import math
from typing import Literal

import numpy as np

from analysis.rare.proposals import effective_sample_size

Z_95 = 1.959963984540054  # two-sided 95 % normal quantile
#: -ln(0.05): with no failure in n plain Monte Carlo runs, p < 3.0/n at 95 % (rule of three)
RULE_OF_THREE = -math.log(0.05)


Stopped = Literal["target_rhw", "budget"]


@dataclasses.dataclass(frozen=True)
class Estimate:
    """A failure probability with its 95 % interval and what it cost.

    ``rhw`` is the relative half-width ``1.96 * se / p``; ``mc_equivalent_runs``
    the plain Monte Carlo runs that would reach the same RHW at this ``p``,
    ``(1.96 / rhw)^2 (1 - p) / p``. ``ess`` is ``(sum w)^2 / sum w^2`` over the
    estimation runs; ``max_term_share`` the largest run's share of ``p``, ``max(w
    failed) / sum(w failed)`` (nan with no failure). With no failure seen,
    ``p_collision`` is 0, ``rhw`` is inf, ``mc_equivalent_runs`` is nan
    (undefined) and the interval is ``[0, upper bound]`` (see :func:`estimate_from_rows`).
    """

    p_collision: float
    ci_low: float
    ci_high: float
    rhw: float
    runs: int
    estimation_runs: int
    failures: int  # estimation-phase failures
    ess: float
    mc_equivalent_runs: float
    stopped: Stopped
    max_term_share: float = math.nan

    @property
    def no_failure_seen(self) -> bool:
        return self.failures == 0

    def to_plain(self) -> dict:
        """Its fields but ``stopped`` (which a summary says apart), and its
        ``acceleration`` over plain Monte Carlo, ``mc_equivalent_runs / runs``."""
        plain = {field.name: getattr(self, field.name) for field in dataclasses.fields(self)
                 if field.name != "stopped"}
        return {**plain, "acceleration": self.mc_equivalent_runs / self.runs}


def estimate_from_rows(weights: np.ndarray, failed: np.ndarray, *, runs: int | None = None,
                       max_weight: float = math.inf, stopped: Stopped = "budget") -> Estimate:
    """The importance-sampling estimate from the estimation-phase rows.

    ``weights`` are each row's ``nominal / proposal`` and ``failed`` its
    ``score <= 0``; ``runs`` counts every run spent (adaptation included,
    default: these rows). ``p = mean(w * failed)``, unbiased when the rows are
    drawn from one fixed proposal, and at most 1 (where every run failed, a mean of
    weights may pass 1 by chance); the interval is ``p +- 1.96 se`` clipped to
    [0, 1], with ``se`` the sample standard deviation of ``w * failed`` over sqrt(n).

    With no failure in n rows the estimate is 0 and the interval
    ``[0, min(1, 3.0 * max_weight / n)]``, the rule of three carried over:
    ``max_weight`` bounds ``nominal / proposal`` (``1 / alpha`` for a
    defensive mixture, 1 for the nominal), so the proposal puts at least
    ``p / max_weight`` on the failures and seeing none in n draws makes that
    below 3.0/n at 95 %. Without a bound (no mixture) the upper end is 1.
    """
    weights = np.asarray(weights, dtype=float)
    failed = np.asarray(failed, dtype=bool)
    if weights.shape != failed.shape or weights.ndim != 1:
        raise ValueError(f"weights {weights.shape} and failed {failed.shape} must be equal 1-d")
    count = weights.size
    if count == 0:
        raise ValueError("weights: no estimation rows")
    if np.any(~np.isfinite(weights)) or np.any(weights < 0):
        raise ValueError("weights must be finite and >= 0")
    runs = count if runs is None else runs
    ess = effective_sample_size(weights)
    failures = int(failed.sum())
    if failures == 0:
        upper = min(1.0, RULE_OF_THREE * max_weight / count) if max_weight < math.inf else 1.0
        return Estimate(0.0, 0.0, upper, math.inf, runs, count, 0, ess, math.nan, stopped)
    terms = weights * failed
    # a mean of weights can pass 1 (every run failed, the weights' mean above 1 by
    # chance): a probability is at most 1, and its interval holds it
    p = min(1.0, float(terms.mean()))
    se = float(terms.std(ddof=1) / math.sqrt(count)) if count > 1 else math.inf
    half_width = Z_95 * se
    rhw = half_width / p if p > 0 else math.inf
    return Estimate(p, max(0.0, p - half_width), min(1.0, p + half_width), rhw, runs, count,
                    failures, ess, mc_equivalent_runs(p, rhw), stopped,
                    float(terms.max() / terms.sum()))


def mc_equivalent_runs(p: float, rhw: float) -> float:
    """Plain Monte Carlo runs whose binomial estimate reaches relative half-width ``rhw``."""
    if not 0 < p < 1 or rhw <= 0 or not math.isfinite(rhw):
        return math.nan if p <= 0 else (math.inf if rhw == 0 else 0.0)
    return (Z_95 / rhw) ** 2 * (1.0 - p) / p
