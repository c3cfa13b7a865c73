"""The ego's conflicts with what is around it, measured along the road.

SUMO's Surrogate Safety Measures device measures gaps along the lanes, so a car
ahead in the ego's lane on a curve is ahead, not off to one side. This does the
same for oriented boxes (:meth:`~scenarios.road_geometry.RoadGeometry.place_in_road_frame`):
each body is placed in the road frame, x its position along the ego's lane,
y its offset ``d`` from the centre line, its yaw relative to the road's heading
there, and its velocity split along and across the road. In that frame a curve
is unrolled into a straight road, and :func:`~sdc.car.geometry_kernels.conflicts`
measures:

- the time to collision: the lesser of the exact first contact of the boxes at
  constant velocities (swerves, crossings, traffic from behind) and SSM's time to
  reach a leader in the ego's path along the lane (a car ahead in the lane while
  the ego weaves in it);
- DRAC and the time headway to the leaders ahead.

On a straight road the frame is the world's, turned.

Contact is the world's: the time to collision is 0 exactly when the ego's body
overlaps another (``Contacts``). Where the unrolled boxes touch but the world's
do not (on a curve, rigid boxes unrolled differ by millimetres to centimetres)
the world frame's exact first contact is taken instead.
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
