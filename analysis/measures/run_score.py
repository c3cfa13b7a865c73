"""A run's score: how far from a collision it stayed, for search and estimate.

The adaptive samplers (:mod:`analysis.rare.rare_events`) move toward low scores and
count a run as failed when its score is <= 0. A score must therefore be 0 for
a collision and positive otherwise, and shrink as a run comes closer to one, so
near misses lead the search before any collision has been seen.

A run with no outcome (status error or timeout) scores 0: it counts as a
failure, the conservative reading (its row says why; the estimate reports how
many there were). A sample that made no valid scenario scores None: there was
no run, and it counts as no failure.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, Literal

from analysis.measures.row_columns import RowCol

ScoreKind = Literal["gap", "ttc"]
#: what each kind reads from the row, and its unit
SCORE_COLUMNS: dict[ScoreKind, tuple[str, ...]] = {
    "gap": (RowCol.min_gap_obstacle_m, RowCol.min_road_edge_gap_m),
    "ttc": (RowCol.min_ttc_s,),
}
#: the score of a run that did not collide but whose measure is 0 or below
#: (a grazing contact the collision check did not count): positive, so not a failure
_CLEAR = 1e-9


def run_score(row: Mapping[str, Any], kind: ScoreKind = "gap") -> float:
    """The score of a result row (a dict with the result columns).

    ``gap``: the smallest of the ego's closest approach to an obstacle and a body
    corner's to a road edge [m]. ``ttc``: the run's ``min_ttc_s``, the smallest time
    to collision with an obstacle or a vehicle measured along the road
    (``sdc.car.road_frame``) [s]. Infinite when the run never came near anything
    measurable.
    """
    if row[RowCol.status] != "ok" or row[RowCol.collision]:
        return 0.0
    values = [row[c] for c in SCORE_COLUMNS[kind]]
    values = [float(v) for v in values if v is not None and not math.isnan(v)]
    return max(min(values, default=math.inf), _CLEAR)
