"""Failures grouped into distinct modes: by what was hit, and by parameter region.

Two failed runs share a mode when they failed the same way (``collision_with``,
or error / timeout for runs with no outcome), took the same value of every
discrete parameter (choice, int_range) and lie close on the continuous ones:
single linkage, so a chain of runs each within ``link_distance`` of the next
is one region. Distances are measured in each parameter's normal score,
``Phi^-1`` of its quantile (:meth:`scenarios.sweep_spec.Param.quantile_of`):
the space the samplers of :mod:`analysis.rare_events` work in, where metres
and m/s weigh alike and one unit is one standard deviation of the nominal.
On the plain quantile scale the tails are squeezed against the cube's faces,
and two regions that both reach one corner (too fast, and an obstacle too
far left) would chain into one.

At most :data:`MAX_GROUPED` failures of one kind are linked; any further
failure joins the region of the nearest linked one, so every failure belongs
to exactly one mode (an estimate's split by mode adds up to its total).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd
from scipy import special
from scipy.cluster.hierarchy import fcluster, linkage

from scenarios.sweep_spec import Param

#: failures of one kind linked at most (single linkage keeps n^2 / 2 distances); the rest
#: join the region of their nearest linked failure
MAX_GROUPED = 4000
#: the largest normal score (Phi^-1 of the largest double below 1 is about 8.2)
_MAX_SCORE = 8.3
PARAM_PREFIX = "p."


@dataclasses.dataclass(frozen=True)
class FailureMode:
    outcome: str  # obstacle | vehicle | road_edge | error | timeout
    runs: int
    run_ids: tuple[str, ...]  # in the order they were drawn
    discrete: dict[str, Any]  # path -> the value all its runs took
    ranges: dict[str, tuple[float, float]]  # path -> (min, max) over its runs

    def describe(self) -> str:
        parts = [f"{path}={value!r}" for path, value in self.discrete.items()]
        parts += [f"{path} in [{lo:.4g}, {hi:.4g}]" for path, (lo, hi) in self.ranges.items()]
        return f"{self.outcome}: {self.runs} run(s)" + (f", {', '.join(parts)}" if parts else "")

    @property
    def example_run(self) -> str:
        """The first run of the mode, in draw order."""
        return self.run_ids[0]

    def to_plain(self) -> dict:
        return {"outcome": self.outcome, "runs": self.runs, "example_run": self.example_run,
                "run_ids": list(self.run_ids),
                "discrete": self.discrete,
                "ranges": {k: list(v) for k, v in self.ranges.items()}}


def failed_runs(results: pd.DataFrame) -> pd.DataFrame:
    """The rows that collided or have no outcome (error, timeout), in run order."""
    failed = results[(results.status != "ok") | results.collision.fillna(False).astype(bool)]
    return failed.sort_values("run_index") if "run_index" in failed else failed


def _outcome(row: pd.Series) -> str:
    return str(row.collision_with) if row.status == "ok" else str(row.status)


def failure_modes(results: pd.DataFrame, params: Sequence[Param],
                  link_distance: float = 1.0) -> list[FailureMode]:
    """The failure modes among ``results`` (result rows with their ``p.<path>`` columns),
    the largest first; ``link_distance`` in normal-score units."""
    failed = failed_runs(results)
    discrete = [p for p in params if not p.continuous and p.grid_size(2) > 1]  # not constants
    continuous = [p for p in params if p.continuous]
    modes = []
    keys = failed.apply(lambda r: (_outcome(r), *(r[PARAM_PREFIX + p.path] for p in discrete)),
                        axis=1) if len(failed) else pd.Series([], dtype=object)
    for key in dict.fromkeys(keys):
        group = failed[keys == key]
        labels = _regions(group, continuous, link_distance)
        for label in dict.fromkeys(labels):
            members = group[labels == label]
            ranges = {p.path: (float(members[PARAM_PREFIX + p.path].min()),
                               float(members[PARAM_PREFIX + p.path].max())) for p in continuous}
            modes.append(FailureMode(
                outcome=key[0], runs=len(members), run_ids=tuple(members.run_id),
                discrete={p.path: _plain(v) for p, v in zip(discrete, key[1:], strict=True)},
                ranges=ranges))
    return sorted(modes, key=lambda m: -m.runs)


def _regions(group: pd.DataFrame, continuous: Sequence[Param], link_distance: float) -> np.ndarray:
    """A region label per row: single-linkage clusters of normal scores."""
    if len(group) < 2 or not continuous:
        return np.ones(len(group), dtype=int)
    quantiles = np.column_stack([[p.quantile_of(v) for v in group[PARAM_PREFIX + p.path]]
                                 for p in continuous])
    points = np.clip(special.ndtri(quantiles), -_MAX_SCORE, _MAX_SCORE)
    linked = points[:MAX_GROUPED]
    labels = fcluster(linkage(linked, method="single"), t=link_distance, criterion="distance")
    if len(points) <= MAX_GROUPED:
        return labels
    rest = points[MAX_GROUPED:]
    nearest = [int(np.argmin(np.sum((linked - row) ** 2, axis=1))) for row in rest]
    return np.concatenate([labels, labels[nearest]])


def _plain(value: Any) -> Any:
    return value.item() if hasattr(value, "item") else value
