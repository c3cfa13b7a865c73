"""Per-run metrics computed from a trace (plain arrays; no simulator here)."""

from __future__ import annotations

import numpy as np

from analysis.measures.row_columns import RowCol
from analysis.measures.trace_columns import TraceCol
from scenarios.common.plain_json import json_scalar

#: |lane offset| [m] under which the car counts as back in its lane
RETURN_OFFSET_M = 0.5
#: how long [s] it must stay there
RETURN_HOLD_S = 2.0
#: a controller's phases named avoid_* are its maneuver
AVOID_PREFIX = "avoid_"


def _avoiding(phase: list[str]) -> np.ndarray:
    return np.fromiter((p.startswith(AVOID_PREFIX) for p in phase), bool, len(phase))


def central_range_m(lidar: np.ndarray, beams: int) -> float:
    """The shortest range among the ``beams`` central beams [m]."""
    center, half = len(lidar) // 2, beams // 2
    return float(np.min(lidar[max(0, center - half): center - half + beams]))


def return_to_lane(t_s: np.ndarray, offset_m: np.ndarray, phase: list[str]):
    """``(returned, return_time_s)``: after the last ``avoid_*`` phase, did the body centre
    stay within ``RETURN_OFFSET_M`` of its lane's centre for ``RETURN_HOLD_S``?
    ``return_time_s`` runs from the maneuver's first step to the start of that hold."""
    avoiding = _avoiding(phase)
    if not avoiding.any():
        return False, None
    start = int(np.argmax(avoiding))
    end = len(avoiding) - int(np.argmax(avoiding[::-1]))  # first step after the maneuver
    inside = np.abs(offset_m) < RETURN_OFFSET_M  # NaN (lane not sensed) is outside
    hold_from = None
    for i in range(end, len(t_s)):
        if not inside[i]:
            hold_from = None
            continue
        if hold_from is None:
            hold_from = i
        if t_s[i] - t_s[hold_from] >= RETURN_HOLD_S - 1e-9:
            return True, float(t_s[hold_from] - t_s[start])
    return False, None


def trace_metrics(floats: dict[str, np.ndarray], phase: list[str], lidar: list[np.ndarray],
                  detect_beams: int) -> dict:
    """Result-row metrics of one run (``None`` where a metric does not apply).

    - ``maneuver_started``: the controller entered a phase named ``avoid_*``.
    - ``detection_range_m``: the shortest of the ``detect_beams`` central lidar
      ranges at the maneuver's first step (the range at which it started).
    - ``returned_to_lane``, ``return_time_s``: see :func:`return_to_lane`.
    - ``max_abs_lane_offset_m``: the largest |offset| of the body centre from its
      own lane's centre (steps where the lane was sensed).
    - ``min_gap_obstacle_m``: the smallest distance between the ego's body box and
      any obstacle box (0 when they touch).
    - ``min_ttc_s``: the smallest time to collision with an obstacle or a vehicle,
      measured in the road frame (``sdc.car.road_frame``); ``None`` when nothing was
      ever on a course to touch the ego.
    - ``max_drac_mps2``: the largest deceleration the ego needed to avoid running into
      a leader ahead of it in the road frame (0 when it never closed in on one).
    - ``min_headway_s``: the smallest time headway to a leader; ``None`` without one.
    """
    avoiding = _avoiding(phase)
    started = bool(avoiding.any())
    detection = None
    if started:
        detection = central_range_m(lidar[int(np.argmax(avoiding))], detect_beams)
    returned, return_time = return_to_lane(floats[TraceCol.t_s], floats[TraceCol.lane_offset_m],
                                           phase)
    offsets = np.abs(floats[TraceCol.lane_offset_m])
    gaps = floats[TraceCol.obstacle_gap_m]
    return {
        RowCol.maneuver_started: started,
        RowCol.detection_range_m: json_scalar(detection) if started else None,
        RowCol.returned_to_lane: returned,
        RowCol.return_time_s: return_time,
        RowCol.max_abs_lane_offset_m: json_scalar(np.max(offsets, initial=-np.inf,
                                                          where=np.isfinite(offsets))),
        RowCol.min_gap_obstacle_m: json_scalar(np.min(gaps)) if gaps.size else None,
        RowCol.min_ttc_s: json_scalar(np.min(floats[TraceCol.ttc_s], initial=np.inf)),
        RowCol.max_drac_mps2: float(np.max(floats[TraceCol.drac_mps2], initial=0.0)),
        RowCol.min_headway_s: json_scalar(np.min(floats[TraceCol.headway_s], initial=np.inf)),
    }
