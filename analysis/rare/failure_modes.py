"""Failed runs grouped into modes: one mode per connected region of one outcome kind.

Why: a search or an estimate draws its runs toward failure, and a user wants
the causes, not a list of runs. Two failures share a mode when they failed the
same way (``collision_with``; error or timeout for a run with no outcome; or
``stuck``), took the same value of every ``choice`` parameter, and lie in one
connected failure region of the other parameters.

The space is the samplers' (:mod:`analysis.rare.rare_events`): each parameter at
``Phi^-1`` of its quantile (:meth:`scenarios.spec.sweep_params.Param.quantile_of`),
where the nominal density is ``N(0, I)`` and one unit is one standard
deviation of the nominal, whatever the parameter's unit.

* **Links.** A failure's *clearance* is the distance to the nearest run that
  did not fail its way: the region reaches at least about that far round it.
  Two failures (of its :data:`MAX_LINKS` nearest) are linked when their balls,
  widened by :data:`LINK_SLACK`, overlap. The scale comes from the runs
  themselves, so a region sampled sparsely in ten dimensions holds together
  while two regions in two dimensions with runs between them stay apart.
* **Persistence.** Two causes can meet far out in the tails (too fast and
  the obstacle too far left fails both ways), where a sampler's wide share
  may land a run that links them. Groups are built from the likeliest
  failure down (ToMATo: Chazal, Guibas, Oudot, Skraba 2013, with the nominal
  density as height); where a failure links two groups, the less likely
  joins the other only when its likeliest run is less than
  :data:`PERSISTENCE_NATS` of log-density above that failure.

The two constants were chosen on :mod:`analysis.rare.rare_bank` and an emulator of
the seed-modes family (``benchmarks/failure_mode_counts.py`` prints the
counts; ``tests/test_failure_modes.py`` holds them): the modes listed equal
the regions found in 37-40 of 40 seeds of 1000-run searches and 30 of 30
estimates on every problem; the single linkage at a fixed distance used
before split one region into up to 246 modes in ten dimensions, and three
regions into 4 to 11 in two.

Modes that carry less than :data:`OTHER_SHARE` of the weighted failures
(a run's importance weight ``nominal / proposal``: for an estimate, its part
of P) are folded into one mode, ``other``, listed last, so every failure
belongs to exactly one mode and the parts add up to the whole.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd
from scipy import sparse, special
from scipy.spatial import cKDTree

from analysis.measures.numbers import number_text
from analysis.measures.row_columns import RowCol
from analysis.measures.run_outcome import collided
from scenarios.common.plain_json import json_plain
from scenarios.spec.sweep_params import Param
from scenarios.spec.sweep_spec import PARAM_PREFIX

#: linked when the distance is at most this times the sum of the two clearances
LINK_SLACK = 1.25
#: log-density [nats] a group must stand above where it meets a likelier one to stay apart
PERSISTENCE_NATS = 4.0
#: the nearest failures each failure may be linked to
MAX_LINKS = 32
#: modes under this share of the weighted failures are folded into ``other``
OTHER_SHARE = 0.01
OTHER = "other"
#: the largest normal score (Phi^-1 of the largest double below 1 is about 8.2)
_MAX_SCORE = 8.3


@dataclasses.dataclass(frozen=True)
class FailureMode:
    outcome: str  # obstacle | vehicle | road_edge | error | timeout | stuck | other
    runs: int
    run_ids: tuple[str, ...]  # in the order they were drawn
    discrete: dict[str, Any]  # choice path -> the value all its runs took
    ranges: dict[str, tuple[float, float]]  # path -> (min, max) over its runs
    share: float | None = None  # of the weighted failures; None without weights
    outcomes: dict[str, int] = dataclasses.field(default_factory=dict)  # other: per kind

    @property
    def example_run(self) -> str:
        """The first run of the mode, in draw order."""
        return self.run_ids[0]

    def to_plain(self) -> dict:
        return {"outcome": self.outcome, "runs": self.runs, "example_run": self.example_run,
                "run_ids": list(self.run_ids), "share": self.share,
                "discrete": self.discrete, "outcomes": self.outcomes,
                "ranges": {k: list(v) for k, v in self.ranges.items()}}


def region_words(mode: dict) -> str:
    """Where a plain mode's (:meth:`FailureMode.to_plain`) runs lie: each choice value,
    and the span of each other parameter over its runs (a value they all share is said
    once, not as a range from it to itself); for ``other``, what it holds."""
    if mode["outcome"] == OTHER:
        kinds = ", ".join(f"{k} {n}" for k, n in mode["outcomes"].items())
        return f"modes each under {100 * OTHER_SHARE:g}% of the weighted failures ({kinds})"
    parts = [f"{path} = {value!r}" for path, value in mode["discrete"].items()]
    parts += [f"{path} in [{number_text(lo)}, {number_text(hi)}]" if lo < hi
              else f"{path} = {number_text(lo)}"
              for path, (lo, hi) in mode["ranges"].items()]
    return "; ".join(parts) or "every run"


def mode_line(mode: dict) -> str:
    """A plain mode in one line: what failed, runs, share, where, an example run."""
    runs = f"{mode['runs']} run" + ("" if mode["runs"] == 1 else "s")
    share = "" if mode.get("share") is None else f" ({100 * mode['share']:.0f}% of the weight)"
    return f"{mode['outcome']}: {runs}{share}; {region_words(mode)}; e.g. {mode['example_run']}"


def weighed_rows(results: pd.DataFrame) -> pd.Series | None:
    """The rows of a search or estimate whose weights measure the modes' shares: an
    estimate's estimation rows (its P), else every row (a search's: a rough share; it
    estimates nothing)."""
    estimation = results[RowCol.phase] == "estimate"
    return estimation if estimation.any() else None


def mode_lines(modes: list[dict], shown: int, rest: str) -> list[str]:
    """The first ``shown`` plain modes, numbered, a :func:`mode_line` each; then how
    many more there are and ``rest``, where to read them."""
    lines = [f"  {i}. {mode_line(m)}" for i, m in enumerate(modes[:shown], start=1)]
    if len(modes) > shown:
        lines.append(f"  ... {len(modes) - shown} more modes: {rest}")
    return lines


def run_kinds(results: pd.DataFrame, failed: pd.Series) -> pd.Series:
    """How each failed run failed: ``collision_with``, else its status, else its
    outcome (``stuck``); empty for the rest."""
    status = results[RowCol.status]
    kind = np.where(status != "ok", status.astype(str),
                    np.where(collided(results),
                             results[RowCol.collision_with].astype(str),
                             results.get(RowCol.outcome, pd.Series("", index=results.index))
                             .fillna("").astype(str)))
    return pd.Series(np.where(failed, kind, ""), index=results.index)


def failure_modes(results: pd.DataFrame, params: Sequence[Param], failed: pd.Series,
                  weighed: pd.Series | None = None) -> list[FailureMode]:
    """The modes of the ``failed`` rows of ``results`` (result rows with their
    ``p.<path>`` columns; the other rows are the runs that did not fail that way),
    the heaviest first and ``other`` last. ``weighed``: the rows whose ``weight``
    counts toward the shares (default all; without a ``weight`` column, none)."""
    results = (results.sort_values(RowCol.run_index) if RowCol.run_index in results
               else results)
    failed = failed.reindex(results.index).fillna(False).astype(bool)
    if not failed.any():
        return []
    choices = [p for p in params if p.kind == "choice" and len(p.args) > 1]
    ordinal = [p for p in params if p.kind != "choice"]
    kinds = run_kinds(results, failed)
    slices = pd.Series("", index=results.index)
    for p in choices:
        slices = slices + "\x00" + results[PARAM_PREFIX + p.path].astype(str)
    labels = pd.Series(_regions(_points(results, ordinal), kinds.to_numpy(), slices.to_numpy()),
                       index=results.index)
    shares = _shares(results, failed, labels, weighed)
    modes = []
    for label in dict.fromkeys(labels[failed]):
        members = results[labels == label]
        first = members.iloc[0]
        modes.append(FailureMode(
            outcome=kinds[members.index[0]], runs=len(members),
            run_ids=tuple(members[RowCol.run_id]),
            discrete={p.path: json_plain(first[PARAM_PREFIX + p.path]) for p in choices},
            ranges={p.path: (float(members[PARAM_PREFIX + p.path].min()),
                             float(members[PARAM_PREFIX + p.path].max())) for p in ordinal},
            share=None if shares is None else shares[label]))
    return _fold_light(sorted(modes, key=lambda m: (-(m.share or 0.0), -m.runs)), results)


def _points(results: pd.DataFrame, params: Sequence[Param]) -> np.ndarray:
    """Each row's normal scores over ``params`` (n, len(params))."""
    if not params:
        return np.zeros((len(results), 1))
    quantiles = np.column_stack([[p.quantile_of(v) for v in results[PARAM_PREFIX + p.path]]
                                 for p in params])
    return np.clip(special.ndtri(quantiles), -_MAX_SCORE, _MAX_SCORE)


def _shares(results: pd.DataFrame, failed: pd.Series, labels: pd.Series,
            weighed: pd.Series | None) -> dict | None:
    """Each label's share of the weighted failures; None when nothing is weighed."""
    if RowCol.weight not in results:
        return None
    counted = pd.Series(True, index=results.index) if weighed is None else weighed
    weights = results[RowCol.weight].astype(float).where(counted & failed, 0.0)
    total = float(weights.sum())
    if not total > 0:
        return None
    return (weights.groupby(labels).sum() / total).to_dict()


def _fold_light(modes: list[FailureMode], results: pd.DataFrame) -> list[FailureMode]:
    """The modes under :data:`OTHER_SHARE` folded into one ``other`` mode, last."""
    light = [m for m in modes if m.share is not None and m.share < OTHER_SHARE]
    if not light:
        return modes
    heavy = [m for m in modes if m not in light]
    ids = set().union(*(m.run_ids for m in light))
    run_ids = tuple(r for r in results[RowCol.run_id] if r in ids)
    outcomes: dict[str, int] = {}
    for m in light:
        outcomes[m.outcome] = outcomes.get(m.outcome, 0) + m.runs
    other = FailureMode(OTHER, len(run_ids), run_ids, {}, {},
                        sum(m.share for m in light), dict(sorted(outcomes.items())))
    return [*heavy, other]


def _regions(points: np.ndarray, kinds: np.ndarray, slices: np.ndarray) -> np.ndarray:
    """A label per row: "" for the rows of no kind, else its slice (the choice values),
    kind and region. A failure's clearance is measured within its slice: a run with
    other choice values says nothing about this one's region."""
    labels = np.full(len(points), "", dtype=object)
    for key in dict.fromkeys(slices):
        in_slice = slices == key
        for kind in dict.fromkeys(k for k in kinds[in_slice] if k):
            mine = in_slice & (kinds == kind)
            clearance = _clearances(points[mine], points[in_slice & ~mine])
            groups = (_persistent_groups(points[mine], clearance)
                      if np.isfinite(clearance).all() else np.zeros(int(mine.sum()), int))
            labels[mine] = [f"{key}\x00{kind}\x00{g}" for g in groups]
    return labels


def _clearances(failures: np.ndarray, others: np.ndarray) -> np.ndarray:
    """Each failure's distance to the nearest other run (inf when there is none)."""
    if len(others) == 0:
        return np.full(len(failures), np.inf)
    return cKDTree(others).query(failures)[0]


def _links(points: np.ndarray, clearance: np.ndarray) -> sparse.csr_matrix:
    """Each failure linked to those of its :data:`MAX_LINKS` nearest failures whose widened
    balls overlap its own, as a symmetric adjacency matrix (the nearest bound the work
    where clearances are wide: a region few passing runs came near)."""
    n = len(points)
    count = min(MAX_LINKS + 1, n)
    distance, j = cKDTree(points).query(points, k=count)
    distance, j = distance.reshape(n, count), j.reshape(n, count)
    i = np.repeat(np.arange(n)[:, None], count, axis=1)
    keep = (i != j) & (distance <= LINK_SLACK * (clearance[i] + clearance[j]))
    adjacency = sparse.coo_matrix((np.ones(int(keep.sum())), (i[keep], j[keep])), shape=(n, n))
    return (adjacency + adjacency.T).tocsr()


def _persistent_groups(points: np.ndarray, clearance: np.ndarray) -> np.ndarray:
    """A group index per failure (ToMATo on the links, height ``|z|^2 / 2``)."""
    n = len(points)
    height = 0.5 * np.sum(points * points, axis=1)
    adjacency = _links(points, clearance)
    root = np.arange(n)

    def find(a: int) -> int:
        while root[a] != a:
            root[a] = root[root[a]]
            a = root[a]
        return a

    done = np.zeros(n, dtype=bool)
    for i in np.argsort(height, kind="stable"):
        neighbours = adjacency.indices[adjacency.indptr[i]:adjacency.indptr[i + 1]]
        neighbours = neighbours[done[neighbours]]
        done[i] = True
        if neighbours.size == 0:
            continue  # a peak: a group of its own so far
        main = find(int(neighbours[np.argmin(height[neighbours])]))  # the steepest way up
        root[i] = main
        for parent in np.unique(root[neighbours]):  # few: most already point at a root
            other = find(int(parent))
            if other == main:
                continue
            older, younger = sorted((main, other), key=lambda r: (height[r], r))
            if height[i] - height[younger] < PERSISTENCE_NATS:
                root[younger] = older
                main = older
    groups = np.array([find(a) for a in range(n)])
    return np.unique(groups, return_inverse=True)[1]
