"""The ego's conflicts with what is around it, measured along the road.

SUMO's Surrogate Safety Measures device measures gaps along the lanes, so a car
ahead in the ego's lane on a curve is ahead, not off to one side. This does the
same for oriented boxes (``place_numpy`` of :mod:`scenarios.scene.road_kernels`): each
body is placed in the road frame, x its position along the ego's lane,
y its offset ``d`` from the centre line, its yaw relative to the road's heading
there, and its velocity split along and across the road. In that frame a curve
is unrolled into a straight road, and ``conflicts_numpy`` of
:mod:`sdc.car.geometry_kernels` measures:

- the time to collision: the lesser of the exact first contact of the boxes at
  constant velocities (swerves, crossings, traffic from behind) and SSM's time to
  reach a leader in the ego's path along the lane (a car ahead in the lane while
  the ego weaves in it);
- DRAC and the time headway to the leaders ahead.

On a straight road the frame is the world's, turned.

Contact is the world's: the time to collision is 0 exactly when the ego's body
overlaps another (``Contacts``). Where the unrolled boxes touch but the world's
do not (on a curve, rigid boxes unrolled differ by millimetres to centimetres)
the world frame's exact first contact is taken instead. One compiled call a step
does all of it (:func:`~sdc.car.geometry_kernels.step`).
"""

from __future__ import annotations

import numpy as np

from scenarios.scene.road_geometry import RoadGeometry
from scenarios.scene.snapshot import Snapshot
from sdc.car.geometry_kernels import Conflicts, Contacts, step


class RoadFrame:
    """Measures the ego's contacts and conflicts in the road frame of its lane."""

    def __init__(self, road: RoadGeometry, lane_d_m: float):
        self.road = road
        self.lane_scale = 1 - road.curvature_1pm * lane_d_m  # ego lane m per centre-line m

    def measure(self, ego_box: np.ndarray, ego_speed_mps: float,
                snapshot: Snapshot) -> tuple[Contacts, Conflicts]:
        """What the ego's box touches, and its conflicts with the obstacles (standing
        still) and the traffic (at its speeds along its headings)."""
        return step(ego_box, ego_speed_mps, snapshot.obstacle_boxes, snapshot.traffic_boxes,
                    snapshot.traffic_speeds_mps, self.road, self.lane_scale)
