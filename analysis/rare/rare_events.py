"""Rare failure probabilities by multilevel, non-parametric importance sampling.

Runs live in standard-normal space ``z = Phi^-1(u)``, where the nominal density is
``N(0, I)``; :func:`~analysis.rare.proposals.unit_points` maps a batch back to the
sweep's unit cube (the space and the proposals: :mod:`analysis.rare.proposals`). A run's
score is continuous and it fails when ``score <= 0`` (the failure event,
:mod:`analysis.measures.failure_event`). :class:`MultilevelIS` is
ask/tell (a caller evaluates each batch anywhere); :func:`estimate` is the loop for a
batch score function; :func:`estimate_from_rows` recomputes an estimate from the
weights stored in the rows.

* **Adaptation.** Per batch, ``gamma = max(elite quantile of the scores, 0)``; the
  runs of all levels with ``score <= gamma``, each weighted nominal / (the mixture of
  every proposal so far), fit the next proposal: a Gaussian kernel at each elite
  (:func:`~analysis.rare.proposals.kernel_mixture_fit`), with a fifth of every batch from the wide
  ``N(0, 4 I)``. It stops once ``gamma`` is 0, the failures are worth enough points
  and none lies beyond the kernels, or after ``max_levels`` batches.
* **Estimation.** Runs from a frozen mixture (the nominal, the wide Gaussian, the last
  level's kernels and the level's before), ``w = nominal / proposal``, and
  ``p = mean(w * 1{failed})`` over these runs only: adaptation runs are not pooled,
  their proposals depended on earlier scores.

Why kernels and a wide share: failures have several causes in separate regions, some
of which give no warning, and one Gaussian settles on one region with a confident
interval. The evidence (95 % intervals cover the truth in 93-95 % of seeds on every
bank problem) is in docs/rare_events_and_warm_up.md, reproduced by
``python benchmarks/bench_rare_bank.py``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Literal

import numpy as np
from scipy import special

from analysis.measures.failure_event import FAILURE
from analysis.rare.proposals import (
    KernelMixture,
    Proposal,
    effective_sample_size,
    kernel_mixture_fit,
    nominal_log_density,
    nominal_proposal,
    standard_normal,
    wide_normal,
)

Z_95 = 1.959963984540054  # two-sided 95 % normal quantile
#: -ln(0.05): with no failure in n plain Monte Carlo runs, p < 3.0/n at 95 % (rule of three)
RULE_OF_THREE = -math.log(0.05)
#: estimation runs before :func:`estimate` judges the RHW (see there)
MIN_ESTIMATION_RUNS = 1500


Stopped = Literal["target_rhw", "budget"]


# --- the level's threshold ----------------------------------------------------------------

def elite_threshold(scores: np.ndarray, elite_fraction: float) -> float:
    """``gamma = max(elite_fraction quantile of the scores, 0)``: never below failure."""
    return max(float(np.quantile(scores, elite_fraction)), FAILURE.threshold)


# --- the estimate -------------------------------------------------------------------------

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


# --- argument checks shared by the ask/tell samplers ---------------------------------------

def check_dims(dims: int) -> None:
    if not isinstance(dims, int | np.integer) or dims < 1:
        raise ValueError(f"dims must be a positive integer, got {dims!r}")


def check_budget(batch_size: int, max_runs: int | None = None) -> None:
    """A batch of at least 2 runs and, with ``max_runs``, room for two batches."""
    if batch_size < 2:
        raise ValueError(f"batch_size must be at least 2, got {batch_size!r}")
    if max_runs is not None and max_runs < 2 * batch_size:
        raise ValueError(f"max_runs={max_runs} is too small to adapt: at least 2 batches "
                         f"({2 * batch_size} runs)")


def check_kernels(elite_fraction: float, shrinkage: float, bandwidth_scale: float,
                  explore_scale: float) -> None:
    """The options both samplers' kernel fits and wide Gaussians share."""
    if not 0 < elite_fraction < 1:
        raise ValueError(f"elite_fraction must be in (0, 1), got {elite_fraction!r}")
    if not 0 < shrinkage <= 1:  # 0 would give a lone elite a singular kernel
        raise ValueError(f"shrinkage must be in (0, 1], got {shrinkage!r}")
    if not bandwidth_scale > 0:
        raise ValueError(f"bandwidth_scale must be > 0, got {bandwidth_scale!r}")
    if not explore_scale > 0:
        raise ValueError(f"explore_scale must be > 0, got {explore_scale!r}")


def checked_batch(z: np.ndarray, scores: np.ndarray, dims: int) -> tuple[np.ndarray, np.ndarray]:
    """A told batch as float arrays, or ValueError naming what is wrong with it."""
    z = np.asarray(z, dtype=float)
    scores = np.asarray(scores, dtype=float)
    if z.ndim != 2 or z.shape[1] != dims:
        raise ValueError(f"z must have shape (n, {dims}), got {z.shape}")
    if scores.shape != (z.shape[0],):
        raise ValueError(f"scores must have shape ({z.shape[0]},), got {scores.shape}")
    if np.any(np.isnan(scores)):
        raise ValueError("scores contain NaN: score every run (+inf for a run with no outcome)")
    return z, scores


# --- the sampler --------------------------------------------------------------------------

class MultilevelIS:
    """Ask/tell multilevel importance sampler in standard-normal space.

    ``ask()`` gives a batch ``z`` (batch_size, dims); evaluate it (through
    :func:`unit_points` on a sweep) and hand the scores back with
    ``tell(z, scores)``, one tell per ask. While :attr:`adapting`, each tell
    is one level: its elites (the ``elite_fraction`` lowest scores, or every
    failure once there are more) become a weighted kernel mixture
    (:func:`kernel_mixture_fit`), the next batch's proposal. Then the proposal
    is frozen, mixed with the nominal by ``defensive_fraction`` (see
    :class:`Proposal`), and tells accumulate the estimation rows
    (:attr:`estimation_log_weights`, :attr:`estimation_failed`) behind
    :meth:`estimate`.

    ``explore_fraction`` of every adaptation batch and
    ``estimation_explore_fraction`` of the estimation proposal come from
    ``N(0, explore_scale^2 I)`` (see the module's docstring). Finding regions
    is the adaptation's job, hence its fifth; the estimation keeps a tenth (a
    fifth there changed neither coverage nor runs beyond the noise of 40 bank
    seeds). ``shrinkage`` and ``bandwidth_scale`` shape
    the kernels (:func:`kernel_mixture_fit`); ``previous_share`` is the share
    of the estimation proposal's kernels fitted one level before the last.

    The adaptation ends at the first level whose threshold is 0 (its elites are
    failures), whose failures are worth at least ``min_elite_ess`` equally
    weighted points (default ``5 (dims + 1)``) and which found no failure
    outside its kernels' reach (below), or after ``max_levels``.
    :attr:`levels` keeps each level's threshold, :attr:`level_ess` its
    elites' ESS and :attr:`level_uncovered` its uncovered failures.

    A failure is *uncovered* when the wide share's density at it exceeds the
    kernels' (each with its share): the wide share drew it in a region the
    kernels do not reach, one the score gave no warning of. Freezing then would
    leave that region to the wide share alone, a few runs per thousand, and a
    region met by none of them is missing from a confident estimate (measured
    on seed-modes: 3 of 9 sweep seeds missed an offset region that the last
    level had just found or not yet met, their intervals 2-3.5 standard errors
    below the truth). One more level puts kernels on it and gives the wide
    share another batch to meet the rest.
    """

    def __init__(self, dims: int, rng: np.random.Generator, batch_size: int,
                 elite_fraction: float = 0.1, *, max_levels: int = 20,
                 defensive_fraction: float = 0.1, min_elite_ess: float | None = None,
                 shrinkage: float = 0.4, previous_share: float = 0.5,
                 bandwidth_scale: float = 2.0, explore_fraction: float = 0.2,
                 explore_scale: float = 2.0, estimation_explore_fraction: float = 0.1) -> None:
        check_dims(dims)
        check_budget(batch_size)
        check_kernels(elite_fraction, shrinkage, bandwidth_scale, explore_scale)
        if max_levels < 1:
            raise ValueError(f"max_levels must be at least 1, got {max_levels!r}")
        if not 0 <= defensive_fraction < 1:
            raise ValueError(f"defensive_fraction must be in [0, 1), got {defensive_fraction!r}")
        if not 0 <= previous_share < 1:
            raise ValueError(f"previous_share must be in [0, 1), got {previous_share!r}")
        self.shrinkage, self.previous_share = shrinkage, previous_share
        self.bandwidth_scale = bandwidth_scale
        self.explore_fraction = explore_fraction
        self.estimation_explore_fraction = estimation_explore_fraction
        self._wide = wide_normal(dims, explore_scale)
        self.dims = int(dims)
        self.rng = rng
        self.batch_size = int(batch_size)
        self.elite_fraction = elite_fraction
        self.max_levels = max_levels
        self.defensive_fraction = defensive_fraction
        self.min_elite_ess = 5.0 * (self.dims + 1) if min_elite_ess is None else min_elite_ess
        self.proposal = nominal_proposal(self.dims)
        self.adapting = True
        self.levels: list[float] = []  # gamma of each adaptation batch
        self.level_ess: list[float] = []  # the ESS of each level's elites
        self.level_uncovered: list[int] = []  # failures outside each level's kernels
        self.adaptation_runs = 0
        # every adaptation run so far, its score, and its log density under each proposal
        self._seen_z = np.empty((0, self.dims))
        self._seen_scores = np.empty(0)
        self._seen_log_q: list[np.ndarray] = []  # per proposal used, over all seen points
        self._proposals: list[Proposal] = []
        self._fits: list[KernelMixture] = [standard_normal(self.dims)]  # each level's
        self._proposal_runs: list[int] = []
        self.estimation_log_weights = np.empty(0)
        self.estimation_failed = np.empty(0, dtype=bool)

    @property
    def runs(self) -> int:
        return self.adaptation_runs + self.estimation_log_weights.size

    def ask(self) -> np.ndarray:
        """The next batch, (batch_size, dims), in normal space."""
        return self.proposal.sample(self.batch_size, self.rng)

    def freeze(self) -> None:
        """End the adaptation: later batches come from the current proposal, mixed with the
        nominal by ``defensive_fraction``, and count toward the estimate."""
        if self.adapting:
            self.adapting = False
            previous, last = self._fits[-2:] if len(self._fits) > 1 else self._fits * 2
            share = self.previous_share
            e = self.estimation_explore_fraction
            self.proposal = Proposal((self._wide, previous, last),
                                     (e, (1 - e) * share, (1 - e) * (1.0 - share)),
                                     self.defensive_fraction)

    def tell(self, z: np.ndarray, scores: np.ndarray) -> None:
        """Hand back the scores of a batch from :meth:`ask` (score <= 0: failure)."""
        z, scores = checked_batch(z, scores, self.dims)
        if self.adapting:
            self._adapt(z, scores)
        else:
            self.estimation_log_weights = np.concatenate([self.estimation_log_weights,
                                                          self.proposal.log_weights(z)])
            self.estimation_failed = np.concatenate([self.estimation_failed,
                                                     FAILURE.fails(scores)])

    def _adapt(self, z: np.ndarray, scores: np.ndarray) -> None:
        self.adaptation_runs += z.shape[0]
        uncovered = self._uncovered(z[FAILURE.fails(scores)])
        log_pooled = self._pool(z, scores)
        gamma = elite_threshold(scores, self.elite_fraction)
        elite = self._seen_scores <= gamma
        elite_z = self._seen_z[elite]
        elite_log_w = nominal_log_density(elite_z) - log_pooled[elite]
        elite_ess = effective_sample_size(np.exp(elite_log_w - elite_log_w.max()))
        self.levels.append(gamma)
        self.level_ess.append(elite_ess)
        self.level_uncovered.append(uncovered)
        self._fits.append(kernel_mixture_fit(elite_z, elite_log_w, self.shrinkage,
                                             self.bandwidth_scale))
        e = self.explore_fraction
        self.proposal = Proposal((self._wide, self._fits[-1]), (e, 1 - e))
        fitted_on_failures = FAILURE.fails(gamma) and elite_ess >= self.min_elite_ess
        if (fitted_on_failures and not uncovered) or len(self.levels) >= self.max_levels:
            self.freeze()

    def _uncovered(self, failed_z: np.ndarray) -> int:
        """How many failures of a batch from the current proposal lie where its wide share
        is denser than its kernels (none for the first batch, drawn from the nominal)."""
        if not self.levels or failed_z.shape[0] == 0 or self.explore_fraction == 0:
            return 0
        e = self.explore_fraction
        kernels = math.log1p(-e) + self._fits[-1].log_density(failed_z)
        wide = math.log(e) + self._wide.log_density(failed_z)
        return int(np.sum(wide > kernels))

    def _pool(self, z: np.ndarray, scores: np.ndarray) -> np.ndarray:
        """Add a batch drawn from the current proposal to the runs seen; return the log
        density of every seen run under the mixture of all proposals so far, each with its
        share of the runs (the balance heuristic: weights ``nominal / that`` are bounded by
        the number of levels, as the first proposal is the nominal)."""
        self._seen_log_q = [np.concatenate([q, p.log_density(z)])
                            for q, p in zip(self._seen_log_q, self._proposals, strict=True)]
        self._seen_z = np.concatenate([self._seen_z, z])
        self._seen_scores = np.concatenate([self._seen_scores, scores])
        self._proposals.append(self.proposal)
        self._proposal_runs.append(z.shape[0])
        self._seen_log_q.append(self.proposal.log_density(self._seen_z))
        shares = np.log(np.array(self._proposal_runs) / sum(self._proposal_runs))
        return special.logsumexp(np.stack(self._seen_log_q) + shares[:, None], axis=0)

    def estimation_weights(self) -> np.ndarray:
        return np.exp(self.estimation_log_weights)

    def estimate(self, stopped: Stopped = "budget") -> Estimate:
        """The estimate from the estimation runs so far (:func:`estimate_from_rows`)."""
        return estimate_from_rows(self.estimation_weights(), self.estimation_failed,
                                  runs=self.runs, max_weight=self.proposal.max_weight,
                                  stopped=stopped)


# --- the simple driver --------------------------------------------------------------------

@dataclasses.dataclass(frozen=True)
class HistoryPoint:
    """The estimate after one estimation batch, for a convergence plot."""

    runs: int  # all runs so far, adaptation included
    p_collision: float
    rhw: float


class EstimationLoop:
    """Multilevel IS with its stopping rule, ask/tell: ``ask()`` gives the next batch
    (None once finished), ``tell(z, scores)`` takes its scores back.

    It stops when the estimate's RHW is at most ``target_rhw`` or when the next
    batch would take the runs past ``max_runs`` (:attr:`stopped` says which).
    The RHW is judged after each estimation batch, and only once there are at
    least ``min_estimation_runs`` estimation runs (default: two batches and at
    least :data:`MIN_ESTIMATION_RUNS`) and ``min_failures`` failures among
    them, so a lucky 1-2 hits never stop it: stopping as soon as a small
    sample's RHW looks good picks the samples whose spread is underestimated
    (measured on the bank, 200 seeds each: 89-92 % coverage on the weakest
    problems with a 1000-run minimum, 93-94 % with 1500). Nor does it stop
    while one run carries more than ``max_term_share`` of the estimate: a
    failure the proposal barely covers (a region the adaptation missed,
    reached through the defensive share) shows as one large term, and the
    normal interval then says little.
    The adaptation is frozen early if it would take more than
    ``max_adaptation_share`` of the budget. ``sampler_options`` go to
    :class:`MultilevelIS`. :attr:`history` has one :class:`HistoryPoint`
    per estimation batch.

    The batches depend only on ``rng`` and the scores told, so replaying the
    same scores gives the same batches (how a killed estimate resumes).
    """

    def __init__(self, dims: int, target_rhw: float, max_runs: int, rng: np.random.Generator,
                 batch_size: int = 500, *, min_estimation_runs: int | None = None,
                 min_failures: int = 30, max_adaptation_share: float = 0.5,
                 max_term_share: float = 0.1, **sampler_options) -> None:
        check_dims(dims)
        if not target_rhw > 0:
            raise ValueError(f"target_rhw must be > 0, got {target_rhw!r}")
        check_budget(batch_size, max_runs)
        if not 0 < max_adaptation_share < 1:
            raise ValueError(f"max_adaptation_share must be in (0, 1), "
                             f"got {max_adaptation_share!r}")
        if not 0 < max_term_share <= 1:
            raise ValueError(f"max_term_share must be in (0, 1], got {max_term_share!r}")
        self.target_rhw, self.max_runs, self.min_failures = target_rhw, max_runs, min_failures
        self.max_term_share = max_term_share
        self.min_estimation_runs = (max(2 * batch_size, MIN_ESTIMATION_RUNS)
                                    if min_estimation_runs is None else min_estimation_runs)
        self.sampler = MultilevelIS(dims, rng, batch_size, **sampler_options)
        self.adaptation_budget = max(batch_size, int(max_adaptation_share * max_runs))
        self.history: list[HistoryPoint] = []
        self.stopped: Stopped | None = None

    @property
    def adapting(self) -> bool:
        return self.sampler.adapting

    @property
    def levels(self) -> list[float]:
        """Each adaptation level's threshold (the elite score quantile, 0 once failures)."""
        return self.sampler.levels

    @property
    def adaptation_runs(self) -> int:
        return self.sampler.adaptation_runs

    @property
    def max_weight(self) -> float:
        """The largest weight a run of the estimation proposal can carry."""
        return self.sampler.proposal.max_weight

    @property
    def planned_runs(self) -> int:
        """The runs the estimate is expected to take in all (a progress bar's total, for
        its ETA): the budget while adapting or before the RHW is finite; then the runs
        so far plus the estimation runs its 1/sqrt(n) decay needs to reach the target
        (at least the minimum), in whole batches, within the budget; once finished, the
        runs it took."""
        sampler = self.sampler
        if self.stopped is not None:
            return sampler.runs
        if sampler.adapting or not self.history or not math.isfinite(self.history[-1].rhw):
            return self.max_runs
        estimation_runs = sampler.runs - sampler.adaptation_runs
        needed = max(self.min_estimation_runs,
                     estimation_runs * (self.history[-1].rhw / self.target_rhw) ** 2)
        total = (sampler.adaptation_runs
                 + math.ceil(needed / sampler.batch_size) * sampler.batch_size)
        return int(min(self.max_runs, max(total, sampler.runs + sampler.batch_size)))

    def ask(self) -> np.ndarray | None:
        """The next batch in normal space, or None when the estimate is finished."""
        sampler = self.sampler
        if self.stopped is not None:
            return None
        if sampler.adapting and sampler.runs + sampler.batch_size > self.adaptation_budget:
            sampler.freeze()
        if sampler.runs + sampler.batch_size > self.max_runs:
            self.stopped = "budget"
            return None
        return sampler.ask()

    def log_weights(self, z: np.ndarray) -> np.ndarray:
        """``log(nominal / proposal)`` of a batch from :meth:`ask`, before it is told."""
        return self.sampler.proposal.log_weights(z)

    def tell(self, z: np.ndarray, scores: np.ndarray) -> None:
        adapting = self.sampler.adapting
        self.sampler.tell(z, scores)
        if adapting:
            return
        current = self.sampler.estimate()
        self.history.append(HistoryPoint(current.runs, current.p_collision, current.rhw))
        if not unjudged(current.to_plain(), self.judged_from) and current.rhw <= self.target_rhw:
            self.stopped = "target_rhw"

    @property
    def judged_from(self) -> dict[str, float]:
        """When the RHW is judged: at least these estimation runs and failures, at most
        this share of P in one run (:func:`unjudged`)."""
        return {"estimation_runs": self.min_estimation_runs, "failures": self.min_failures,
                "max_term_share": self.max_term_share}

    def result(self) -> Estimate:
        """The estimate so far; ``stopped`` is ``"budget"`` until the target was reached."""
        if self.sampler.estimation_log_weights.size == 0:
            raise ValueError(f"max_runs={self.max_runs} left no estimation batch")
        return self.sampler.estimate(stopped=self.stopped or "budget")


def unjudged(e: dict, judged_from: dict[str, float]) -> list[str]:
    """Why an estimate's RHW cannot be judged yet (nothing when it can), in words: ``e``
    its :meth:`Estimate.to_plain`, ``judged_from`` as :attr:`EstimationLoop.judged_from`.
    (Without a failure its RHW is infinite: never judged good.)"""
    words = []
    if e["estimation_runs"] < judged_from["estimation_runs"]:
        words.append(f"{e['estimation_runs']} of the {judged_from['estimation_runs']:g} "
                     "weighted runs it needs")
    if e["failures"] < judged_from["failures"]:
        words.append(f"{e['failures']} of the {judged_from['failures']:g} collisions it needs")
    if e["failures"] and e["max_term_share"] > judged_from["max_term_share"]:
        words.append(f"one run carries {100 * e['max_term_share']:.0f}% of P (at most "
                     f"{100 * judged_from['max_term_share']:g}%)")
    return words


ScoreFn = Callable[[np.ndarray], np.ndarray]


def estimate(score_fn: ScoreFn, dims: int, target_rhw: float, max_runs: int,
             rng: np.random.Generator, batch_size: int = 500,
             **options) -> tuple[Estimate, list[HistoryPoint]]:
    """Run an :class:`EstimationLoop` (``options`` go to it) with ``score_fn``, which maps
    a batch ``z`` (n, dims) to its n scores (<= 0: failure). Returns the estimate and
    one :class:`HistoryPoint` per estimation batch."""
    loop = EstimationLoop(dims, target_rhw, max_runs, rng, batch_size, **options)
    while (z := loop.ask()) is not None:
        loop.tell(z, _scores(score_fn, z))
    return loop.result(), loop.history


def _scores(score_fn: ScoreFn, z: np.ndarray) -> np.ndarray:
    scores = np.asarray(score_fn(z), dtype=float)
    if scores.shape != (z.shape[0],):
        raise ValueError(f"score_fn must return one score per row, shape ({z.shape[0]},), "
                         f"got {scores.shape}")
    return scores
