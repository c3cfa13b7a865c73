"""A failure search that keeps looking after it has found one failure mode.

Each batch, in standard-normal space ``z``, has four parts with fixed run counts
(largest remainders), its rows shuffled:

* **the descent** (50 % once a mode is found, 80 % before): a weighted Gaussian-kernel
  mixture (:func:`~analysis.rare.proposals.kernel_mixture_fit`) on the elites, the
  lowest-scoring runs so far that did not fail and lie in no found mode's cone, as
  many as it takes for their weights to be worth ``elites`` runs (Kish ESS), each
  score divided by ``1 - k`` (``k``: its closeness to a found cone, clipped to [0, 1]);
* **revisits** (``revisit_share``): kernels on each found mode's heaviest failures,
  every mode the same share;
* **wide runs** (``explore_share``) from ``N(0, explore_scale^2 I)``;
* **nominal runs** (``nominal_share``), which keep every weight at most
  ``1 / nominal_share``.

A failure joins the mode whose cone it lies deepest in, or founds one. A mode's
direction ``u`` is the normalised sum of its failures' ``z / |z|``; its cone is
``cos(z, u) >= taboo_ratio * c``, ``c`` its failures' mean cosine to ``u``.
:meth:`ModeSearch.log_weights` is exactly ``log(nominal / q)`` for the runs drawn. A
search estimates nothing. The batches depend only on ``rng`` and the scores told, so
a killed search resumes by replaying its stored scores through a fresh object.

Why: an adaptive search settles round the first failure region it meets, so a
scenario that fails three ways shows one. The measurements behind each part are in
docs/rare_events_and_warm_up.md, reproduced by ``python benchmarks/failure_mode_counts.py``.
"""

from __future__ import annotations

import math

import numpy as np

from analysis.measures.failure_event import FAILURE
from analysis.rare.proposals import (
    KernelMixture,
    Proposal,
    kernel_mixture_fit,
    nominal_proposal,
    standard_normal,
    wide_normal,
)
from analysis.rare.sampler_checks import check_budget, check_dims, check_kernels, checked_batch

#: a run this close to the origin has no direction (it lies in no cone)
_TINY_NORM = 1e-12


def _unit_rows(z: np.ndarray) -> np.ndarray:
    """``z / |z|`` row by row; zero rows stay zero."""
    norms = np.linalg.norm(z, axis=1, keepdims=True)
    return np.where(norms > _TINY_NORM, z / np.maximum(norms, _TINY_NORM), 0.0)


def _split(total: int, shares: np.ndarray) -> np.ndarray:
    """``total`` runs split in proportion to ``shares`` by largest remainders (ties: first)."""
    exact = total * shares / shares.sum()
    counts = np.floor(exact).astype(int)
    order = np.argsort(-(exact - counts), kind="stable")
    counts[order[:total - counts.sum()]] += 1
    return counts


def _enough(log_weights: np.ndarray, ess: float) -> int:
    """The shortest head of ``log_weights`` whose Kish ESS reaches ``ess`` (all if none)."""
    w = np.exp(log_weights - log_weights.max())
    total, squares = np.cumsum(w), np.cumsum(w * w)
    reached = np.flatnonzero(total * total >= ess * squares)
    return int(reached[0]) + 1 if reached.size else w.size


def _lowest(scores: np.ndarray, count: int) -> np.ndarray:
    """Indices of the ``count`` lowest scores, in score order (ties: earliest run first)."""
    return np.argsort(scores, kind="stable")[:count]


class _Modes:
    """The failure modes found: each failure's mode, and each mode's direction and cone."""

    def __init__(self, dims: int, taboo_ratio: float) -> None:
        self.taboo_ratio = taboo_ratio
        self.unit_sums = np.empty((0, dims))  # per mode, the sum of its failures' z/|z|
        self.members: list[list[int]] = []  # per mode, its failures' run indices

    @property
    def count(self) -> int:
        return len(self.members)

    def cones(self) -> tuple[np.ndarray, np.ndarray]:
        """Per mode: its unit direction ``u`` (m, d) and the cosine its cone starts at,
        ``taboo_ratio`` times its failures' mean cosine to ``u`` (m,)."""
        sizes = np.array([len(m) for m in self.members], dtype=float)
        lengths = np.linalg.norm(self.unit_sums, axis=1)
        directions = self.unit_sums / np.maximum(lengths, _TINY_NORM)[:, None]
        return directions, self.taboo_ratio * lengths / sizes

    def closeness(self, unit_z: np.ndarray) -> np.ndarray:
        """(n, modes): each run's cosine to each mode's direction over the cosine its cone
        starts at (>= 1: inside the cone), for rows ``unit_z`` of unit vectors."""
        directions, starts = self.cones()
        return (unit_z @ directions.T) / np.maximum(starts, _TINY_NORM)

    def add(self, index: int, unit_z: np.ndarray) -> None:
        """File failure ``index`` (direction ``unit_z``) under the mode whose cone it lies
        deepest in, or under a new mode if it is in none."""
        if self.members:
            closeness = self.closeness(unit_z[None, :])[0]
            best = int(np.argmax(closeness))
            if closeness[best] >= 1.0:
                self.unit_sums[best] += unit_z
                self.members[best].append(index)
                return
        self.unit_sums = np.vstack([self.unit_sums, unit_z])
        self.members.append([index])


class ModeSearch:
    """Ask/tell search for failures (score <= 0) that finds one mode after another.

    ``ask()`` gives the next batch ``z`` (n, dims) in standard-normal space, or
    None once ``max_runs`` runs are drawn or ``stop_after`` failures found (after
    the batch that found them); the last batch is cut to what is left of the
    budget. ``log_weights(z)`` is ``log(nominal / q)`` for the batch just asked;
    ``tell(z, scores)`` hands its scores back (+inf for a run with no outcome:
    it is kept but never guides the descent).

    Options (defaults chosen on :mod:`analysis.rare.rare_bank` at batch 20, 200 seeds;
    every value below found every mode of three-regions, four-branch-k7,
    opposite-d6 and unequal-modes-d4 in all seeds within 1000 runs, so they were
    told apart by the seeds with every mode after 300 runs):

    * ``elite_fraction`` (0.1): the descent's elites are worth
      ``max(2, round(elite_fraction * batch_size))`` runs (2 at batch 20): few,
      so that it descends fast (median first failure on a linear 2-d problem at
      p = 5e-4: 51 runs with 2, 64 with 3); it is the option the cross-entropy
      search takes.
    * ``taboo_ratio`` (0.7): where a mode's cone starts, about 47 degrees round
      a tight mode. 0.5 (61 degrees) leaves less room between modes 90 degrees
      apart (every mode after 300 runs in 94-96 % of seeds against 98 %);
      0.6-0.8 alike.
    * ``revisit_share`` (0.3) and ``nominal_share`` (0.1): the parts of each
      batch drawn round the modes found and from the nominal; 0.2-0.4 and
      0.05-0.15 alike. 0.3 gives each of three modes some 55-75 failures in
      1000 runs.
    * ``explore_share`` (0.1) and ``explore_scale`` (2.0): the wide part, as
      the estimator's (:class:`~analysis.rare.multilevel_is.MultilevelIS`).
    * ``shrinkage`` (0.4), ``bandwidth_scale`` (1.0): the kernels', as in
      :func:`~analysis.rare.proposals.kernel_mixture_fit` (0.4 is the estimator's).
    * ``revisit_kernels`` (30): at most this many failures (the heaviest) per
      mode carry its revisit kernels, which bounds the cost of a large mode.

    :attr:`levels` holds, after each batch, the descent's level: the penalised
    score (score / (1 - closeness), the plain score until a mode is found) of
    its worst elite, inf when there is no candidate. It falls as the descent
    nears a region and jumps up when a new mode puts the runs near that region
    in a cone.
    :attr:`mode_failures` and :attr:`mode_directions` describe the modes found
    (a region may be split into several modes; :mod:`analysis.rare.failure_modes`
    groups the failures for the report).
    """

    def __init__(self, dims: int, max_runs: int, rng: np.random.Generator,
                 batch_size: int = 20, *, stop_after: int | None = None,
                 elite_fraction: float = 0.1, taboo_ratio: float = 0.7,
                 revisit_share: float = 0.3, nominal_share: float = 0.1,
                 explore_share: float = 0.1, explore_scale: float = 2.0,
                 shrinkage: float = 0.4, bandwidth_scale: float = 1.0,
                 revisit_kernels: int = 30) -> None:
        check_dims(dims)
        check_budget(batch_size, max_runs)
        if stop_after is not None and stop_after < 1:
            raise ValueError(f"stop_after must be at least 1, got {stop_after!r}")
        check_kernels(elite_fraction, shrinkage, bandwidth_scale, explore_scale)
        if not 0 <= taboo_ratio <= 1:
            raise ValueError(f"taboo_ratio must be in [0, 1], got {taboo_ratio!r}")
        side_shares = (revisit_share, nominal_share, explore_share)
        if not (all(0 <= share < 1 for share in side_shares) and sum(side_shares) < 1):
            raise ValueError(f"revisit_share ({revisit_share!r}), nominal_share "
                             f"({nominal_share!r}) and explore_share ({explore_share!r}) "
                             "must be >= 0 and leave the descent a share")
        if revisit_kernels < 1:
            raise ValueError(f"revisit_kernels must be at least 1, got {revisit_kernels!r}")
        self.dims, self.max_runs, self.rng = int(dims), int(max_runs), rng
        self.batch_size, self.stop_after = int(batch_size), stop_after
        self.elites = max(2, round(elite_fraction * batch_size))  # runs' worth of weight
        self.revisit_share, self.nominal_share = revisit_share, nominal_share
        self.explore_share, self._wide = explore_share, wide_normal(dims, explore_scale)
        self.shrinkage, self.bandwidth_scale = shrinkage, bandwidth_scale
        self.revisit_kernels = int(revisit_kernels)
        self.levels: list[float] = []
        self.failures = 0
        self.first_failure_run: int | None = None  # 1-based, in the order the runs were drawn
        self.adaptation_runs = 0  # runs told up to and with the batch of the first failure
        self.proposal: Proposal = nominal_proposal(self.dims)  # the last batch's density
        self._modes = _Modes(self.dims, taboo_ratio)
        self._z = np.empty((0, self.dims))
        self._unit = np.empty((0, self.dims))  # z / |z|
        self._scores = np.empty(0)
        self._log_w = np.empty(0)  # per run, log(nominal / the density it was drawn from)
        self._descent: KernelMixture = standard_normal(self.dims)

    # --- the public face --------------------------------------------------------------

    @property
    def runs(self) -> int:
        return self._scores.size

    @property
    def adapting(self) -> bool:
        """True until the first failure is found (the batches' "phase")."""
        return self.first_failure_run is None

    @property
    def found_enough(self) -> bool:
        return self.stop_after is not None and self.failures >= self.stop_after

    @property
    def mode_failures(self) -> list[int]:
        """Failures per mode found, in the order the modes were found."""
        return [len(m) for m in self._modes.members]

    @property
    def mode_directions(self) -> np.ndarray:
        """Each mode's unit direction in normal space, (modes, dims)."""
        return self._modes.cones()[0]

    @property
    def planned_runs(self) -> int:
        """The runs the search will take in all (a progress bar's total): its budget,
        or the runs it took once it found enough."""
        return self.runs if self.found_enough else self.max_runs

    def ask(self) -> np.ndarray | None:
        """The next batch (n, dims), or None when the search is finished."""
        left = self.max_runs - self.runs
        if left <= 0 or self.found_enough:
            return None
        count = min(self.batch_size, left)
        modes = self._revisits()
        revisit = self.revisit_share if modes else 0.0
        side = self.nominal_share + self.explore_share + revisit
        shares = np.array([self.nominal_share, self.explore_share, 1.0 - side, revisit])
        nominal, wide, descent, around = _split(count, shares)
        # the revisits go to the modes at random, each with the same chance
        per_mode = (self.rng.multinomial(around, np.full(len(modes), 1.0 / len(modes)))
                    if modes else np.zeros(0, dtype=int))
        parts = [(self._wide, wide / count), (self._descent, descent / count)]
        parts += [(m, around / (count * len(modes))) for m in modes]
        self.proposal = _proposal(self.dims, nominal / count, parts)
        drawn = [self.rng.standard_normal((nominal, self.dims)),
                 self._wide.sample(wide, self.rng), self._descent.sample(descent, self.rng)]
        drawn += [m.sample(int(n), self.rng) for m, n in zip(modes, per_mode, strict=True)]
        return np.concatenate(drawn)[self.rng.permutation(count)]

    def log_weights(self, z: np.ndarray) -> np.ndarray:
        """``log(nominal / q)`` of a batch from :meth:`ask` (before it is told)."""
        return self.proposal.log_weights(np.asarray(z, dtype=float))

    def tell(self, z: np.ndarray, scores: np.ndarray) -> None:
        """Hand back the scores of the batch from the last :meth:`ask` (<= 0: failure); the
        runs are weighted by that batch's density."""
        z, scores = checked_batch(z, scores, self.dims)
        before = self.runs
        self._pool(z, scores)
        failed = np.flatnonzero(FAILURE.fails(scores))
        for index in failed:
            self._modes.add(before + int(index), self._unit[before + index])
        if self.adapting:
            self.adaptation_runs = self.runs
        if self.first_failure_run is None and failed.size:
            self.first_failure_run = before + int(failed[0]) + 1
        self.failures += failed.size
        self._descent, level = self._descend()
        self.levels.append(level)

    # --- the steps --------------------------------------------------------------------

    def _pool(self, z: np.ndarray, scores: np.ndarray) -> None:
        """Add a batch drawn from :attr:`proposal` to the runs seen, with its weights."""
        self._z = np.concatenate([self._z, z])
        self._unit = np.concatenate([self._unit, _unit_rows(z)])
        self._scores = np.concatenate([self._scores, scores])
        self._log_w = np.concatenate([self._log_w, self.log_weights(z)])

    def _descend(self) -> tuple[KernelMixture, float]:
        """The descent's kernels: on the candidates of lowest penalised score, as many as
        it takes for their weights to be worth ``elites`` runs; and the worst elite's
        penalised score. The nominal and inf when there is no candidate."""
        ranked = self._penalised()
        index = np.flatnonzero(np.isfinite(ranked))
        if index.size == 0:
            return standard_normal(self.dims), math.inf
        index = index[_lowest(ranked[index], index.size)]
        elite = index[:_enough(self._log_w[index], self.elites)]
        fit = kernel_mixture_fit(self._z[elite], self._log_w[elite], self.shrinkage,
                                 self.bandwidth_scale)
        return fit, float(ranked[elite[-1]])

    def _penalised(self) -> np.ndarray:
        """Each run's score divided by ``1 - k``, ``k`` its largest closeness to a mode
        (:meth:`_Modes.closeness`) clipped to [0, 1]; inf for failures, runs in a cone
        and runs with no outcome, so that exactly the candidates are finite."""
        scores = np.where(self._scores > 0, self._scores, np.inf)
        if not self._modes.count:
            return scores
        closeness = np.clip(self._modes.closeness(self._unit).max(axis=1), 0.0, 1.0)
        with np.errstate(divide="ignore"):
            return np.where(closeness < 1.0, scores / (1.0 - closeness), np.inf)

    def _revisits(self) -> list[KernelMixture]:
        """Per mode found, kernels on its heaviest failures (weighted like the elites)."""
        fits = []
        for members in self._modes.members:
            index = np.array(members)
            log_ratio = self._log_w[index]
            keep = _lowest(-log_ratio, self.revisit_kernels)
            fits.append(kernel_mixture_fit(self._z[index[keep]], log_ratio[keep],
                                           self.shrinkage, self.bandwidth_scale))
        return fits


def _proposal(dims: int, nominal: float, parts: list[tuple[KernelMixture, float]]) -> Proposal:
    """The density of a batch drawn as a share ``nominal`` from N(0, I) and from each
    part the share given with it: the mixture with those shares."""
    used = [(part, share) for part, share in parts if share > 0]
    drawn = sum(share for _, share in used)
    if not used:
        return nominal_proposal(dims)
    return Proposal(tuple(p for p, _ in used), tuple(share / drawn for _, share in used),
                    nominal / (nominal + drawn))

