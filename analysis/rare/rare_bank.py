"""Reliability problems with exactly known failure probabilities, to check estimators on.

Each :class:`Problem` lives in standard-normal space ``z`` (the space of
:mod:`analysis.rare.rare_events`) and fails where its vectorised score ``g(z) <= 0``
(the failure event, :mod:`analysis.measures.failure_event`).
The bank holds the standard cases where a sampler that adapts to one failure
region goes wrong: several regions of equal or unequal mass, regions on
opposite sides, curved boundaries, and one region in ten dimensions.

The truths are exact (normal tails) except the four-branch series system,
whose values are the literature's (Waarts 2000; Au and Beck 1999), checked
here by 10^8 plain Monte Carlo draws (``tests/test_rare_bank.py`` redoes a
smaller check).

:data:`EMULATED` holds emulators of the catalog's rare families (seed-rare,
seed-modes), built from their truth files, each with its own exact P: the families'
statistics are tested on these in seconds, and one real SUMO seed of each tests the
wiring.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np
import pandas as pd
from scipy import special

from analysis.measures.failure_event import FAILURE
from analysis.measures.row_columns import RowCol
from scenarios import CATALOG_DIR
from scenarios.common.file_read import read_json
from scenarios.spec.sweep_params import Param
from scenarios.spec.sweep_spec import PARAM_PREFIX

ScoreFn = Callable[[np.ndarray], np.ndarray]
RegionFn = Callable[[np.ndarray], np.ndarray]
KindFn = Callable[[np.ndarray], np.ndarray]
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
    regions: int  # separate failure regions (causes)
    about: str
    in_regions: RegionFn  # z (n, dims) -> (n, regions): whether each run lies in each
    kinds: KindFn | None = None  # z -> how each failure failed (default: all alike)

    def regions_hit(self, z: np.ndarray) -> int:
        """How many of the regions hold at least one failure among the runs ``z``."""
        failed = FAILURE.fails(self.score(z))
        return int(np.sum(np.any(self.in_regions(z) & failed[:, None], axis=0)))


def _three_regions(z: np.ndarray) -> np.ndarray:
    return np.minimum(3.66 - z[:, 0], 3.6775 - np.abs(z[:, 1]))


def _blind_three_regions(z: np.ndarray) -> np.ndarray:
    offset = np.abs(z[:, 1]) > 3.6775
    return np.where(offset, 0.0, np.maximum(3.66 - z[:, 0], 0.0))


def _three_region_parts(z: np.ndarray) -> np.ndarray:
    return np.stack([z[:, 0] >= 3.66, z[:, 1] >= 3.6775, z[:, 1] <= -3.6775], axis=1)


def _four_branches(z: np.ndarray, k: float) -> list[np.ndarray]:
    """The four branch scores of the series system; it fails where one is <= 0."""
    a, b = z[:, 0], z[:, 1]
    bent = 3.0 + 0.1 * (a - b) ** 2
    return [bent - (a + b) / _ROOT2, bent + (a + b) / _ROOT2,
            (a - b) + k / _ROOT2, (b - a) + k / _ROOT2]


def _four_branch(k: float) -> ScoreFn:
    def score(z: np.ndarray) -> np.ndarray:
        return np.minimum.reduce(_four_branches(z, k))
    return score


def _four_branch_parts(k: float) -> RegionFn:
    def parts(z: np.ndarray) -> np.ndarray:
        return FAILURE.fails(np.stack(_four_branches(z, k), axis=1))
    return parts


def _whole(z: np.ndarray) -> np.ndarray:
    return np.ones((z.shape[0], 1), dtype=bool)


def _sides(z: np.ndarray) -> np.ndarray:
    total = z.sum(axis=1)
    return np.stack([total > 0, total < 0], axis=1)


def _first_sides(z: np.ndarray) -> np.ndarray:
    return np.stack([z[:, 0] > 0, z[:, 0] < 0], axis=1)


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
            "min(3.66 - z0, 3.6775 - |z1|): too fast, or an offset to either side",
            _three_region_parts),
    Problem("blind-three-regions", 2, _blind_three_regions,
            1.0 - (1.0 - _tail(3.66)) * (1.0 - 2.0 * _tail(3.6775)), 3,
            "three-regions where the score warns of one region only: |z1| > 3.6775 fails "
            "with no near miss before it (a detection that misses, like seed-modes' barrel)",
            _three_region_parts),
    Problem("four-branch-k6", 2, _four_branch(6.0), 4.4573e-3, 4,
            "the four-branch series system, k = 6: four regions of similar mass",
            _four_branch_parts(6.0)),
    Problem("four-branch-k7", 2, _four_branch(7.0), 2.2228e-3, 4,
            "the four-branch series system, k = 7: two regions dominate",
            _four_branch_parts(7.0)),
    Problem("linear-d2", 2, _linear(3.71902), _tail(3.71902), 1,
            "3.71902 - sum(z) / sqrt(2): one half-space", _whole),
    Problem("linear-d10", 10, _linear(3.71902), _tail(3.71902), 1,
            "3.71902 - sum(z) / sqrt(10): one half-space in ten dimensions", _whole),
    Problem("opposite-d6", 6, _opposite(3.89059), 2.0 * _tail(3.89059), 2,
            "3.89059 - |sum(z)| / sqrt(6): two half-spaces on opposite sides", _sides),
    Problem("unequal-modes-d4", 4, _unequal_modes, _tail(3.74555) + _tail(4.26489), 2,
            "min(3.74555 - z0, 4.26489 + z0): modes holding 90 % and 10 %", _first_sides),
)


def _seed_modes_score(z: np.ndarray) -> np.ndarray:
    """The gap score of seed-modes as its sweep file measures it: 2.21 m at the nominal,
    about 2.4 m less per m/s toward the speed boundary, no warning of the offsets (about
    2 m up to the detection's edge), 0 in a failure region."""
    speed, offset = _SEED_MODES_SPEED(z[:, 0]), _SEED_MODES_OFFSET(z[:, 1])
    far = np.abs(offset) >= _SEED_MODES_FAR_M
    gap = np.where(far, np.abs(offset) - 1.265,
                   np.clip(2.21 - 2.4 * (speed - 3.6), 1e-9, 2.87 - offset))
    return np.where(_seed_modes_kinds(z) != "", 0.0, gap)


def _seed_modes_kinds(z: np.ndarray) -> np.ndarray:
    speed, offset = _SEED_MODES_SPEED(z[:, 0]), np.abs(_SEED_MODES_OFFSET(z[:, 1]))
    seen = offset <= _SEED_MODES_SEEN_M
    unseen = ~seen & (offset < _SEED_MODES_FAR_M)
    slow = seen & (speed < 2.15 + 0.5 * _SEED_MODES_OFFSET(z[:, 1]))
    return np.select([unseen | slow, seen & (speed > _SEED_MODES_EDGE_MPS)],
                     ["obstacle", "road_edge"], "")


def _seed_modes_parts(z: np.ndarray) -> np.ndarray:
    kinds, offset = _seed_modes_kinds(z), _SEED_MODES_OFFSET(z[:, 1])
    seen = np.abs(offset) <= _SEED_MODES_SEEN_M
    return np.stack([kinds == "road_edge", (kinds == "obstacle") & (offset > 0) & ~seen,
                     (kinds == "obstacle") & (offset < 0) & ~seen], axis=1)


#: seed-modes' boundaries (scenarios/catalog/sweeps/seed-modes.truth.json) and nominal:
#: speed N(3.6, 0.25) m/s, the barrel's offset N(0, 0.2) m
_SEED_MODES_EDGE_MPS, _SEED_MODES_SEEN_M, _SEED_MODES_FAR_M = 4.51506, 0.73578, 1.267
_SEED_MODES_SPEED = np.poly1d([0.25, 3.6])
_SEED_MODES_OFFSET = np.poly1d([0.2, 0.0])
def _seed_modes_truth() -> float:
    """The emulator's own P: the fast box with the barrel seen, the two unseen bands,
    and the slow sliver (a 1-d integral over the seen offsets)."""
    seen = _ndtr_between(-_SEED_MODES_SEEN_M / 0.2, _SEED_MODES_SEEN_M / 0.2)
    fast = _tail((_SEED_MODES_EDGE_MPS - 3.6) / 0.25) * seen
    bands = 2.0 * _ndtr_between(_SEED_MODES_SEEN_M / 0.2, _SEED_MODES_FAR_M / 0.2)
    z1 = np.linspace(-_SEED_MODES_SEEN_M / 0.2, _SEED_MODES_SEEN_M / 0.2, 20_001)
    slow_z0 = (2.15 + 0.5 * _SEED_MODES_OFFSET(z1) - 3.6) / 0.25
    slow = float(np.trapezoid(special.ndtr(slow_z0) * _density(z1), z1))
    return fast + bands + slow


def _ndtr_between(a: float, b: float) -> float:
    return float(special.ndtr(b) - special.ndtr(a))


def _density(z: np.ndarray) -> np.ndarray:
    return np.exp(-0.5 * z * z) / math.sqrt(2.0 * math.pi)


#: an emulator of the catalog's seed-modes family built from its truth boundaries: road
#: edge when fast with the barrel seen, obstacle when the barrel stands unseen to either
#: side (and in the negligible slow region, which joins them); the three regions of
#: more than 1 % of P. Its truth is its own, exact (the family's, 3.6028e-4, within
#: 0.02 %).
SEED_MODES_EMULATED = Problem(
    "seed-modes-emulated", 2, _seed_modes_score, _seed_modes_truth(), 3,
    "seed-modes from its truth boundaries: fast (road edge), unseen left, unseen right",
    _seed_modes_parts, _seed_modes_kinds)


def _seed_rare_emulated() -> Problem:
    """The catalog's seed-rare family from its truth file: the left corners' gap to the
    road edge is ``2.5 w - C(v)`` [m] (lane width ``w``, the swing ``C`` at speed ``v``,
    interpolated between the truth scan's speeds), a collision with the road edge where
    it is <= 0. Its truth is its own, exact: the 1-d integral of
    ``Phi((C(v) / 2.5 - mean_w) / sd_w)`` over the nominal speed."""
    truth = read_json(CATALOG_DIR / "sweeps" / "seed-rare.truth.json", "the seed-rare truth")
    scan = truth["truth_scan"]
    speeds, swing_m = np.linspace(*scan["speed_grid"]), np.array(scan["swing_m"])
    (v_mean, v_sd), (w_mean, w_sd) = (truth["nominal"][name]["normal"]
                                      for name in ("ego.speed_mps", "road.lane_width_m"))

    def gap_m(z: np.ndarray) -> np.ndarray:
        swing = np.interp(v_mean + v_sd * z[:, 0], speeds, swing_m)
        return 2.5 * (w_mean + w_sd * z[:, 1]) - swing

    z0 = np.linspace(-9.0, 9.0, 200_001)
    swing = np.interp(v_mean + v_sd * z0, speeds, swing_m)
    p = float(np.trapezoid(special.ndtr((swing / 2.5 - w_mean) / w_sd) * _density(z0), z0))
    return Problem("seed-rare-emulated", 2, gap_m, p, 1,
                   "seed-rare from its truth scan: fast on narrow lanes (the road edge)",
                   lambda z: FAILURE.fails(gap_m(z))[:, None],
                   lambda z: np.where(FAILURE.fails(gap_m(z)), "road_edge", ""))


SEED_RARE_EMULATED = _seed_rare_emulated()
#: the catalog families' emulators: their statistics are checked on these, a real SUMO
#: seed of each checks the wiring
EMULATED = (SEED_RARE_EMULATED, SEED_MODES_EMULATED)


def problem(name: str) -> Problem:
    """The bank's problem, or an emulator, by name."""
    for candidate in (*BANK, *EMULATED):
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
    """:func:`analysis.rare.rare_events.estimate` on ``case`` once per seed (``options`` go to
    it), summed up against the truth."""
    from analysis.rare.failure_estimate import Z_95
    from analysis.rare.rare_events import estimate

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


def sampled_runs(case: Problem, mode: str, seed: int, max_runs: int) -> pd.DataFrame:
    """Every run of an estimate (target RHW 0.3, batches of 500) or a search (batches
    of 20) on ``case``, as a search or estimate directory's rows: ``run_id``,
    ``run_index``, ``status``, ``collision``, ``collision_with``, ``phase``, ``weight``,
    ``score`` and one ``p.z<k>`` column per dimension (standard normal parameters)."""
    from analysis.rare.mode_search import ModeSearch
    from analysis.rare.rare_events import EstimationLoop

    rng = np.random.default_rng(seed)
    loop = (EstimationLoop(case.dims, 0.3, max_runs, rng, 500) if mode == "estimate"
            else ModeSearch(case.dims, max_runs, rng))
    parts = []
    while (z := loop.ask()) is not None:
        phase = "estimate" if mode == "estimate" and not loop.adapting else "adapt"
        weights, scores = np.exp(loop.log_weights(z)), case.score(z)
        loop.tell(z, scores)
        parts.append(pd.DataFrame({RowCol.phase: phase, RowCol.weight: weights,
                                   RowCol.score: scores,
                                   **{PARAM_PREFIX + p.path: z[:, k]
                                      for k, p in enumerate(normal_params(case.dims))}}))
    runs = pd.concat(parts, ignore_index=True)
    failed = FAILURE.failed_rows(runs)
    kinds = (case.kinds(normal_scores(runs, case.dims)) if case.kinds is not None
             else np.full(len(runs), "failure"))
    return runs.assign(**{RowCol.run_id: [f"r{i}" for i in range(len(runs))],
                          RowCol.run_index: runs.index, RowCol.status: "ok",
                          RowCol.collision: failed,
                          RowCol.collision_with: np.where(failed, kinds, None)})


def normal_params(dims: int) -> list[Param]:
    """``dims`` standard normal sweep parameters ``z0, z1, ...``."""
    return [Param(f"z{k}", "normal", (0.0, 1.0)) for k in range(dims)]


def normal_scores(runs: pd.DataFrame, dims: int) -> np.ndarray:
    """The runs' z (n, dims), from their :func:`normal_params` columns."""
    return runs[[PARAM_PREFIX + p.path for p in normal_params(dims)]].to_numpy()


def mode_count(case: Problem, mode: str, seed: int, max_runs: int) -> tuple[int, int]:
    """(the failure modes listed, ``other`` aside; the regions of ``case`` that hold a
    failure) for one seed's estimate or search (:func:`sampled_runs`)."""
    from analysis.rare.failure_modes import OTHER, failure_modes, weighed_rows

    runs = sampled_runs(case, mode, seed, max_runs)
    modes = failure_modes(runs, normal_params(case.dims), FAILURE.failed_rows(runs),
                          weighed_rows(runs))
    return (sum(m.outcome != OTHER for m in modes),
            case.regions_hit(normal_scores(runs, case.dims)))
