"""Failures grouped into distinct modes: by what was hit, and by parameter region.

Two failed runs share a mode when they failed the same way (``collision_with``,
or error / timeout for runs with no outcome), took the same value of every
discrete parameter (choice, int_range) and lie close on the continuous ones:
single linkage, so a chain of runs each within ``link_distance`` of the next
is one region. Distances are measured on each parameter's quantile scale
(:meth:`scenarios.sweep_spec.Param.quantile_of`, 0 to 1 across its
distribution), so metres and m/s weigh alike.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd
from scipy.cluster.hierarchy import fcluster, linkage

from scenarios.sweep_spec import Param

#: failures grouped at most (single linkage keeps n^2 / 2 distances); the rest are listed
MAX_GROUPED = 4000
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

    def to_plain(self) -> dict:
        return {"outcome": self.outcome, "runs": self.runs, "run_ids": list(self.run_ids),
                "discrete": self.discrete,
                "ranges": {k: list(v) for k, v in self.ranges.items()}}


def failed_runs(results: pd.DataFrame) -> pd.DataFrame:
    """The rows that collided or have no outcome (error, timeout), in run order."""
    failed = results[(results.status != "ok") | results.collision.fillna(False).astype(bool)]
    return failed.sort_values("run_index") if "run_index" in failed else failed


def _outcome(row: pd.Series) -> str:
    return str(row.collision_with) if row.status == "ok" else str(row.status)


def failure_modes(results: pd.DataFrame, params: Sequence[Param],
                  link_distance: float = 0.2) -> list[FailureMode]:
    """The failure modes among ``results`` (result rows with their ``p.<path>`` columns),
    the largest first."""
    failed = failed_runs(results).head(MAX_GROUPED)
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
    """A region label per row: single-linkage clusters on the quantile scale."""
    if len(group) < 2 or not continuous:
        return np.ones(len(group), dtype=int)
    points = np.column_stack([[p.quantile_of(v) for v in group[PARAM_PREFIX + p.path]]
                              for p in continuous])
    return fcluster(linkage(points, method="single"), t=link_distance, criterion="distance")


def _plain(value: Any) -> Any:
    return value.item() if hasattr(value, "item") else value
