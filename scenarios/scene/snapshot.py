"""What one step of the world shows the car: plain numpy arrays, no simulator.

A box is a row ``[cx_m, cy_m, yaw_rad, length_m, width_m]`` (body centre,
heading counter-clockwise from +x, full length and width).
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType
from typing import NamedTuple

import numpy as np

from scenarios.scene.road_geometry import RoadGeometry
from scenarios.scene.traffic_model import TRAFFIC_DECEL_MPS2, TRAFFIC_MIN_GAP_M, TRAFFIC_TAU_S
from scenarios.spec.bodies import VEHICLE_MODELS
from scenarios.spec.scenario_spec import ScenarioSpec

NO_BOXES = np.zeros((0, 5))
NO_CLASSES = np.zeros(0, dtype=object)
#: traffic is reported within the lidar's range plus this, from the ego's body centre [m]
SENSING_MARGIN_M = 25.0
#: and at least this far, for the time to collision with traffic closing in from beyond
#: the lidar's range: 15 s at a closing speed of 10 m/s [m]
CONFLICT_REACH_M = 150.0
#: where an ego is pushed at a step: its body box and its speed [m/s]; None where a
#: world's own driver moves it (``scenarios.world_backends.WitnessWorld``)
Pose = tuple[np.ndarray, float]


def sensing_radius_m(spec: ScenarioSpec) -> float:
    """How far from the ego's centre a world reports traffic: nothing farther can be
    seen by the lidar or touched, and the safety measures (time to collision, DRAC,
    headway) count traffic up to :data:`CONFLICT_REACH_M` away."""
    return max(spec.lidar.max_range_m + SENSING_MARGIN_M, CONFLICT_REACH_M)


def within_m(boxes: np.ndarray, center_xy: np.ndarray, radius_m: float) -> np.ndarray:
    """Which box centres lie within ``radius_m`` of ``center_xy`` (a bool mask)."""
    d = boxes[:, :2] - center_xy
    return d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] <= radius_m * radius_m


class Snapshot(NamedTuple):
    t_s: float
    traffic_boxes: np.ndarray  # (N, 5) vehicles and persons on foot within the sensing radius
    obstacle_boxes: np.ndarray  # (K, 5) the spec's stationary obstacles, in spec order
    traffic_speeds_mps: np.ndarray  # (N,) speeds of the traffic boxes, along their headings
    #: (N,) their SUMO vehicle classes (vClass): passenger, truck, ..., pedestrian (a person)
    traffic_classes: np.ndarray
    #: the traffic lights along the ego's route: each one's state string (SUMO's
    #: link states, one character per link: r red, y yellow, G/g green, ...)
    signals: Mapping[str, str] = MappingProxyType({})
    #: (N,) which body each traffic box is of: a vehicle laid along its lane's bend
    #: is several boxes (``scenarios.scene.lane_bodies``), all of one body; None: each box
    #: is a body of its own
    traffic_bodies: np.ndarray | None = None
    #: (N,) whose each traffic box is: :data:`TRAFFIC` (SUMO's), :data:`OTHER_EGO` or
    #: :data:`OTHER_OBSTACLE` (another run's, in a shared world); None: all SUMO's
    traffic_owners: np.ndarray | None = None


#: whose a traffic box is: SUMO's traffic, or another run's ego or obstacle (a shared world)
TRAFFIC, OTHER_EGO, OTHER_OBSTACLE = "traffic", "other_ego", "other_obstacle"


#: the vehicle class of a car (SUMO's vClass), the only kind highway-env drives
PASSENGER = "passenger"


def passenger_classes(count: int) -> np.ndarray:
    """``count`` cars' vehicle classes."""
    return np.full(count, PASSENGER, dtype=object)


#: vehicles in the ego's lane or a neighbouring one (they may change into it as the ego
#: appears) whose body comes this far behind its rear / ahead of its front at least are
#: taken off at entry [m]
START_ZONE_BEHIND_M, START_ZONE_AHEAD_M = 30.0, 10.0


def stop_need_m(follower_mps, follower_decel_mps2: float, leader_mps,
                leader_decel_mps2: float, reaction_s: float) -> np.ndarray:
    """The gap [m] a follower at ``follower_mps`` needs behind its leader to stop short
    of it, reacting after ``reaction_s``, should the leader brake at once as hard as it
    can (each at its own deceleration), :data:`TRAFFIC_MIN_GAP_M` to spare."""
    follower_mps = np.asarray(follower_mps, float)
    brake_m = (follower_mps**2 / (2 * follower_decel_mps2)
               - np.asarray(leader_mps, float)**2 / (2 * leader_decel_mps2))
    return TRAFFIC_MIN_GAP_M + reaction_s * follower_mps + np.maximum(brake_m, 0.0)


def in_start_zone(spec: ScenarioSpec, road: RoadGeometry, centers_xy: np.ndarray,
                  lengths_m: np.ndarray, speeds_mps: np.ndarray | None = None) -> np.ndarray:
    """Which vehicles (body centres ``centers_xy``, ``lengths_m`` long) stand where the
    ego enters the road, in its lane or a neighbouring one (a bool mask): their body
    within :data:`START_ZONE_BEHIND_M` behind the ego's rear or
    :data:`START_ZONE_AHEAD_M` ahead of its front, or overlapping it; and with their
    ``speeds_mps``, any behind it too close to stop should it brake at once (SUMO's
    defaults: :func:`stop_need_m`) or ahead of it too close for it to stop, braking at
    once, should they brake."""
    if len(centers_xy) == 0:
        return np.zeros(0, bool)
    s_m, d_m = road.to_frenet(np.asarray(centers_xy, float).reshape(-1, 2))
    half_m = np.asarray(lengths_m, float) / 2
    ego, model = spec.ego, VEHICLE_MODELS[spec.vehicle.model]
    behind_m = np.full(len(s_m), START_ZONE_BEHIND_M)
    ahead_m = np.full(len(s_m), START_ZONE_AHEAD_M)
    if speeds_mps is not None:
        decel = model.braking_decel_mps2(spec.vehicle.friction_mu)
        behind_m = np.maximum(behind_m, stop_need_m(speeds_mps, TRAFFIC_DECEL_MPS2,
                                                    ego.speed_mps, decel, TRAFFIC_TAU_S))
        ahead_m = np.maximum(ahead_m, stop_need_m(ego.speed_mps, decel, speeds_mps,
                                                  TRAFFIC_DECEL_MPS2, 0.0))
    ego_rear_m, ego_front_m = ego.start_m - model.length_m / 2, ego.start_m + model.length_m / 2
    return ((np.abs(d_m - road.lane_center_d_m(ego.lane)) < 1.5 * road.lane_width_m)
            & (s_m + half_m >= ego_rear_m - behind_m)
            & (s_m - half_m <= ego_front_m + ahead_m))


#: after a warm-up, traffic in an obstacle's lane this far behind / ahead of its centre
#: is taken off as the obstacle appears (a car 50 m back at 14 m/s stops within it
#: braking at SUMO's default 4.5 m/s^2) [m]
OBSTACLE_ZONE_BEHIND_M, OBSTACLE_ZONE_AHEAD_M = 50.0, 10.0


def near_obstacles(spec: ScenarioSpec, road: RoadGeometry, centers_xy: np.ndarray) -> np.ndarray:
    """Which vehicle centres stand on or just behind an obstacle's spot, in its lane
    (a bool mask): where it would appear out of nothing in front of them."""
    near = np.zeros(len(centers_xy), bool)
    if len(centers_xy) == 0 or not spec.obstacles:
        return near
    s_m, d_m = road.to_frenet(np.asarray(centers_xy, float).reshape(-1, 2))
    for obstacle in spec.obstacles:
        at_m = road.place_s_m(obstacle.position_m, obstacle.size_m[0])
        lane_d_m = road.lane_center_d_m(obstacle.lane) + obstacle.lateral_offset_m
        near |= ((np.abs(d_m - lane_d_m) < road.lane_width_m)
                 & (s_m >= at_m - OBSTACLE_ZONE_BEHIND_M)
                 & (s_m <= at_m + OBSTACLE_ZONE_AHEAD_M))
    return near


def obstacle_boxes(spec: ScenarioSpec, road: RoadGeometry) -> np.ndarray:
    """The exact boxes of the spec's obstacles, lateral offsets included."""
    if not spec.obstacles:
        return NO_BOXES
    s_m = np.array([road.place_s_m(o.position_m, o.size_m[0]) for o in spec.obstacles])
    d_m = np.array([road.lane_center_d_m(o.lane) + o.lateral_offset_m for o in spec.obstacles])
    xy = road.xy_at(s_m, d_m)
    sizes = np.array([o.size_m for o in spec.obstacles])
    return np.column_stack([xy, road.heading_at(s_m), sizes])
