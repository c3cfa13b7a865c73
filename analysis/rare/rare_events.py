"""Rare failure probabilities by multilevel, non-parametric importance sampling.

Runs live in standard-normal space ``z = Phi^-1(u)``, where the nominal density is
``N(0, I)``; :func:`~analysis.rare.proposals.unit_points` maps a batch back to the
sweep's unit cube (the space and the proposals: :mod:`analysis.rare.proposals`). A run's
score is continuous and it fails when ``score <= 0`` (the failure event,
:mod:`analysis.measures.failure_event`). :class:`~analysis.rare.multilevel_is.MultilevelIS`
is ask/tell (a caller evaluates each batch anywhere); here, :class:`EstimationLoop` is it
with its stopping rule and :func:`estimate` the loop for a batch score function;
:func:`~analysis.rare.failure_estimate.estimate_from_rows` recomputes an estimate from
the weights stored in the rows.

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

import numpy as np

from analysis.rare.failure_estimate import Estimate, Stopped
from analysis.rare.multilevel_is import MultilevelIS
from analysis.rare.sampler_checks import check_budget, check_dims

#: estimation runs before :func:`estimate` judges the RHW (see there)
MIN_ESTIMATION_RUNS = 1500


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
