"""The ego's conflicts with what is around it, measured along the road.

SUMO's Surrogate Safety Measures device measures gaps along the lanes, so a car
ahead in the ego's lane on a curve is ahead, not off to one side. This does the
same for oriented boxes: each body is placed in the road frame, x its position
along the ego's lane (``s`` along the centre line times the lane's length ratio,
:attr:`~scenarios.road_geometry.RoadGeometry.curvature_1pm`), y its offset ``d``
from the centre line, its yaw relative to the road's heading there, and its
velocity split along and across the road (a body moving along its own lane at
offset ``d`` covers ``(1 - curvature * ego lane's d) / (1 - curvature * d)``
metres of the ego's lane per metre). In that frame the curve is unrolled into a
straight road and :func:`~sdc.car.geometry_kernels.conflicts` measures the time
to collision (the exact first contact of the boxes at constant velocities in
the road frame, so swerves count), DRAC and headway. On a straight road the
frame is the world's, turned.

Contact is the world's: the time to collision is 0 exactly when the ego's body
overlaps another (``Contacts``). Where the unrolled boxes touch but the world's
do not (a rounding of a few millimetres on a curve) the world frame's exact time
is taken instead.
"""

from __future__ import annotations

import numpy as np

from scenarios.road_geometry import RoadGeometry
from sdc.car.geometry_kernels import Conflicts, Contacts, conflicts


def velocities_mps(boxes: np.ndarray, speeds_mps: np.ndarray) -> np.ndarray:
    """(N, 2) world velocities of boxes moving along their headings [m/s]."""
    return np.column_stack([speeds_mps * np.cos(boxes[:, 2]), speeds_mps * np.sin(boxes[:, 2])])


class RoadFrame:
    """Measures the ego's conflicts in the road frame of its lane (the module's docstring)."""

    def __init__(self, road: RoadGeometry, lane_d_m: float):
        self.road = road
        self.lane_scale = 1 - road.curvature_1pm * lane_d_m  # ego lane m per centre-line m

    def conflicts(self, ego_box: np.ndarray, ego_speed_mps: float, contacts: Contacts,
                  obstacle_boxes: np.ndarray, traffic_boxes: np.ndarray,
                  traffic_speeds_mps: np.ndarray) -> Conflicts:
        """The ego's :class:`~sdc.car.geometry_kernels.Conflicts` with the obstacles
        (standing still) and the traffic (at its speeds along its headings)."""
        if len(obstacle_boxes) + len(traffic_boxes) == 0:
            return NO_CONFLICTS
        placed, velocity = self.road.place_in_road_frame(
            ego_box, ego_speed_mps, obstacle_boxes, traffic_boxes, traffic_speeds_mps,
            self.lane_scale)
        measured = conflicts(placed[0], velocity[0], placed[1:], velocity[1:])
        if contacts.obstacle >= 0 or contacts.vehicle >= 0:
            return measured._replace(ttc_s=0.0)
        if measured.ttc_s == 0.0:  # unrolled they touch, in the world they do not
            boxes = np.vstack([obstacle_boxes, traffic_boxes])
            speeds = np.concatenate([np.zeros(len(obstacle_boxes)), traffic_speeds_mps])
            ego_velocity = velocities_mps(ego_box[None, :], np.array([ego_speed_mps]))[0]
            exact = conflicts(ego_box, ego_velocity, boxes, velocities_mps(boxes, speeds))
            return measured._replace(ttc_s=exact.ttc_s)
        return measured


NO_CONFLICTS = Conflicts(np.inf, 0.0, np.inf)
