"""How a run ended, and how far it got: plain arrays of its trace, no simulator.

- ``completed``: no collision, and the ego's rear passed the front of every obstacle
  that stood ahead of its start (along the road; a run without such an obstacle
  completes unless it collided).
- ``collided``: the ego's body touched something.
- ``stuck``: neither, and it stood still (speed under :data:`STUCK_SPEED_MPS`) for at
  least :data:`STUCK_HOLD_S` before the run ended, but not at a red light, or in the
  queue before one, for less than the light's cycle
  (:func:`analysis.measures.stood_for.waited_for_light`).
- ``unfinished``: neither, and still moving when the run ended, or waiting at a red
  light for less than its cycle: the run was too short to tell.

Error and timeout rows have no outcome. Over a result table, :func:`collided` and
:func:`failed_or_collided` are the one home of "which runs failed".
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from analysis.measures.row_columns import RowCol
from analysis.measures.stood_for import QUEUE, RED_LIGHT, Standing, waited_for_light

if TYPE_CHECKING:  # the result tables' type; a run's own process never imports pandas
    import pandas as pd

#: the statuses a run ends with (as the sweep runner writes them); only ``ok`` has an outcome
STATUSES = ("ok", "error", "timeout")
COMPLETED, COLLIDED, STUCK, UNFINISHED = "completed", "collided", "stuck", "unfinished"
OUTCOMES = (COMPLETED, COLLIDED, STUCK, UNFINISHED)
#: under this speed [m/s] the car stands still
STUCK_SPEED_MPS = 0.1
#: standing still this long [s] at the end of a run that did not complete is ``stuck``
STUCK_HOLD_S = 3.0


def outcomes_text(outcomes) -> str:
    """``3 completed, 1 collided, 0 stuck, 0 unfinished``: runs by outcome (a mapping
    from :data:`OUTCOMES`; a missing one is 0)."""
    return ", ".join(f"{outcomes.get(o, 0)} {o}" for o in OUTCOMES)


def collided(rows: pd.DataFrame) -> pd.Series:
    """Per result row: True when the run collided (an error or timeout row did not)."""
    return rows[RowCol.collision].fillna(False).astype(bool)


def failed_or_collided(rows: pd.DataFrame) -> pd.Series:
    """Per result row: True when the run did not run ok (error, timeout) or collided;
    missing evidence is never safety."""
    return (rows[RowCol.status] != "ok") | collided(rows)


def too_short_at_light(rows: pd.DataFrame) -> pd.Series:
    """Per result row: True when the run ended waiting at a red light, or in the queue
    before one, for less than the light's cycle (unfinished: too short to tell)."""
    if RowCol.stood_for_cycle_s not in rows:  # results from before the column
        import pandas as pd  # here, not above: a run's own process never needs it

        return pd.Series(False, index=rows.index)
    return ((rows[RowCol.status] == "ok") & (rows[RowCol.outcome] == UNFINISHED)
            & rows[RowCol.stood_for].isin([RED_LIGHT, QUEUE])
            & rows[RowCol.stood_for_cycle_s].notna())


def duration_to_tell_s(rows: pd.DataFrame) -> float | None:
    """The shortest run duration [s] by which every run of ``rows`` that ended too
    short at a light (:func:`too_short_at_light`) would have waited a whole cycle
    there (where it stood since, plus the cycle), rounded up to 10 s; None: none did."""
    short = rows[too_short_at_light(rows)]
    if not len(short):
        return None
    need_s = (short[RowCol.sim_time_s] - short[RowCol.stood_at_end_s]
              + short[RowCol.stood_for_cycle_s]).max()
    return float(math.ceil(need_s / 10.0) * 10.0)


def rest_step(speed_mps: np.ndarray) -> int:
    """The step from which the car stood still (under :data:`STUCK_SPEED_MPS`) to the
    end of the trace; ``len(speed_mps)`` when it was moving at its last step."""
    moving = np.flatnonzero(np.asarray(speed_mps) >= STUCK_SPEED_MPS)
    return 0 if len(moving) == 0 else int(moving[-1]) + 1


def still_at_end_s(t_s: np.ndarray, speed_mps: np.ndarray) -> float:
    """How long [s] the car had stood still (under :data:`STUCK_SPEED_MPS`) when the
    trace ended; 0 when it was moving at its last step."""
    since = rest_step(speed_mps)
    return float(t_s[-1] - t_s[since]) if since < len(t_s) else 0.0


def passed_every_obstacle(s_m: np.ndarray, ego_length_m: float, obstacle_s_m: np.ndarray,
                          obstacle_length_m: np.ndarray) -> bool:
    """Did the ego's rear (body centre ``s_m`` per step, along the road; NaN where
    unknown) pass the front of every obstacle whose centre was ahead of its start?"""
    known = np.asarray(s_m, float)[np.isfinite(s_m)]
    if len(known) == 0:
        return len(obstacle_s_m) == 0
    start_m, farthest_m = known[0], known.max()
    obstacle_s_m, obstacle_length_m = np.asarray(obstacle_s_m), np.asarray(obstacle_length_m)
    ahead = obstacle_s_m > start_m
    need_m = obstacle_s_m[ahead] + (ego_length_m + obstacle_length_m[ahead]) / 2
    return bool(np.all(farthest_m >= need_m))


def run_outcome(collided: bool, passed: bool, t_s: np.ndarray, speed_mps: np.ndarray,
                standing: Standing | None = None) -> str:
    """One of :data:`OUTCOMES` (the module's docstring); ``standing``: what the car
    stood for at the end (None: nothing known, or it ended moving)."""
    if collided:
        return COLLIDED
    if passed:
        return COMPLETED
    stood_s = still_at_end_s(t_s, speed_mps)
    if stood_s >= STUCK_HOLD_S - 1e-9 and not waited_for_light(standing, stood_s):
        return STUCK
    return UNFINISHED


def progress_m(s_m: np.ndarray, lane_scale: float = 1.0) -> float:
    """Distance made along the route [m]: the body centre's last known ``s`` minus
    its first, times ``lane_scale`` (the ego lane's length per metre of the road's
    centre line: on a curve its lane is longer or shorter)."""
    known = np.asarray(s_m, float)[np.isfinite(s_m)]
    if len(known) == 0:
        return 0.0
    return float(known[-1] - known[0]) * lane_scale


def time_lost_s(sim_time_s: float, progress: float, start_speed_mps: float) -> float | None:
    """The run's time [s] minus the time driving ``progress`` metres at the start speed
    would take; None when the car started at rest (there is no such time)."""
    if start_speed_mps <= 0 or not math.isfinite(start_speed_mps):
        return None
    return round(sim_time_s - progress / start_speed_mps, 6)
