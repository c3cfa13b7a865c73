"""Safety margins of a run: the closest approach to the road edge (the time to
collision is the car's, recorded in the trace: ``sdc.car.road_frame``),
and whether braking alone could have stopped the car before the obstacle ahead.

Plain numpy on boxes ``[cx_m, cy_m, yaw_rad, length_m, width_m]`` and the spec; no simulator.
"""

from __future__ import annotations

import numpy as np

from scenarios.scene.boxes import box_corners
from scenarios.scene.road_geometry import RoadGeometry
from scenarios.spec.bodies import VehicleModel
from scenarios.spec.scenario_spec import ScenarioSpec


def road_edge_gaps_m(body_boxes: np.ndarray, road: RoadGeometry) -> np.ndarray:
    """Per box, the distance from its outermost corner to the nearer road edge [m]
    (negative beyond it; ``nan`` while no corner is alongside the road)."""
    corners = box_corners(body_boxes)  # (N, 4, 2)
    gaps = road.edge_gaps_m(corners.reshape(-1, 2)).reshape(-1, 4).min(axis=1)
    return np.where(np.isposinf(gaps), np.nan, gaps)


def stop_gap_m(spec: ScenarioSpec, road: RoadGeometry, model: VehicleModel) -> float | None:
    """The gap at the run's start from the ego's front bumper to the rear of the
    nearest obstacle ahead in its path, along its lane [m]; None when there is none.

    The path is the band the ego's body covers driving straight along its lane's
    centre: an obstacle is in it when its box overlaps that band laterally, whatever
    its lane (an obstacle in the next lane whose ``lateral_offset_m`` reaches into
    the band counts; one in the ego's lane offset out of it does not). Positions are
    along the road (``start_m`` and ``position_m`` locate body centres; a
    ``sumo_net`` road is the route's lane, with an obstacle moved off a junction
    where the world puts it), so the gap is the centres' distance along the ego's
    lane minus the two half lengths. On a curve the ego's lane is longer or shorter
    than the centre line: its arc is ``1 - d / curve_radius_m`` times the centre
    line's, ``d`` the lane centre's offset.
    """
    ego, band_half_m = spec.ego, model.width_m / 2
    ego_d_m = road.lane_center_d_m(ego.lane)
    scale = lane_scale(spec, road)
    gaps_m = []
    for obstacle in spec.obstacles:
        length_m, width_m = obstacle.size_m
        d_m = road.lane_center_d_m(obstacle.lane) + obstacle.lateral_offset_m
        if abs(d_m - ego_d_m) >= band_half_m + width_m / 2:
            continue  # beside the path
        ahead_m = (road.place_s_m(obstacle.position_m, length_m) - ego.start_m) * scale
        if ahead_m > 0:  # its centre ahead of the ego's; 0 if touching (the spec refuses it)
            gaps_m.append(max(0.0, ahead_m - (model.length_m + length_m) / 2))
    return min(gaps_m, default=None)


def lane_scale(spec: ScenarioSpec, road: RoadGeometry) -> float:
    """Metres along the ego's lane per metre along the road's centre line:
    ``1 - curvature d``, ``d`` the lane centre's offset (left positive), as the car's
    road frame has it (``sdc.car.road_frame``); 1 where the centre line does not turn
    or its lanes are measured on their own (a ``sumo_net`` road is the route's own
    lane: :attr:`RoadGeometry.curvature_1pm`)."""
    return 1 - road.curvature_1pm * road.lane_center_d_m(spec.ego.lane)


#: the time between seeing the obstacle and full braking that ``stop_possible`` allows
#: for [s]: 0, the car brakes from its first step (the run's controllers decide at every
#: step; a human driver needs about 1 s)
REACTION_TIME_S = 0.0


def stopping_distance_m(speed_mps: float, decel_mps2: float,
                        reaction_s: float = REACTION_TIME_S) -> float:
    """How far the car travels from ``speed_mps`` to rest: ``reaction_s`` at that
    speed, then ``speed^2 / (2 decel)`` braking at ``decel_mps2`` [m]."""
    return speed_mps * reaction_s + speed_mps**2 / (2 * decel_mps2)


def stop_possible(speed_mps: float, decel_mps2: float, gap_m: float | None,
                  reaction_s: float = REACTION_TIME_S) -> bool | None:
    """Can braking alone stop the car within ``gap_m``: its
    :func:`stopping_distance_m` at ``decel_mps2`` (the deceleration it can reach on
    the road: ``VehicleModel.braking_decel_mps2`` of the scenario's friction) is at
    most the gap (None when there is no gap: nothing in the path)."""
    if gap_m is None:
        return None
    return stopping_distance_m(speed_mps, decel_mps2, reaction_s) <= gap_m
