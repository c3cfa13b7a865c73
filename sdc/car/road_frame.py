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


def _wrap(angle_rad: np.ndarray) -> np.ndarray:
    return (angle_rad + np.pi) % (2 * np.pi) - np.pi


def velocities_mps(boxes: np.ndarray, speeds_mps: np.ndarray) -> np.ndarray:
    """(N, 2) world velocities of boxes moving along their headings [m/s]."""
    return np.column_stack([speeds_mps * np.cos(boxes[:, 2]), speeds_mps * np.sin(boxes[:, 2])])


class RoadFrame:
    """Places boxes in the road frame of one ego lane (see the module's docstring)."""

    def __init__(self, road: RoadGeometry, lane_d_m: float):
        self.road = road
        self.curvature_1pm = road.curvature_1pm
        self.lane_scale = 1 - road.curvature_1pm * lane_d_m  # ego lane m per centre-line m

    def place(self, boxes: np.ndarray,
              speeds_mps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Boxes ``(N, 5)`` moving at ``speeds_mps`` along their headings, as boxes and
        ``[vx, vy]`` velocities in the road frame."""
        s_m, d_m = self.road.to_frenet(boxes[:, :2])
        yaw_rad = _wrap(boxes[:, 2] - self.road.heading_at(s_m))
        along = speeds_mps * np.cos(yaw_rad)
        if self.curvature_1pm != 0.0:
            along = along * (self.lane_scale / (1 - self.curvature_1pm * d_m))
        placed = np.column_stack([s_m * self.lane_scale, d_m, yaw_rad, boxes[:, 3:5]])
        return placed, np.column_stack([along, speeds_mps * np.sin(yaw_rad)])

    def conflicts(self, ego_box: np.ndarray, ego_speed_mps: float, contacts: Contacts,
                  boxes: np.ndarray, speeds_mps: np.ndarray) -> Conflicts:
        """The ego's :class:`~sdc.car.geometry_kernels.Conflicts` with ``boxes``
        (obstacles at speed 0, traffic at its speeds), measured in the road frame."""
        if len(boxes) == 0:
            return Conflicts(np.inf, 0.0, np.inf)
        everything = np.vstack([ego_box[None, :], boxes])
        placed, velocity = self.place(everything, np.concatenate([[ego_speed_mps], speeds_mps]))
        measured = conflicts(placed[0], velocity[0], placed[1:], velocity[1:])
        if contacts.obstacle >= 0 or contacts.vehicle >= 0:
            return measured._replace(ttc_s=0.0)
        if measured.ttc_s == 0.0:  # unrolled they touch, in the world they do not
            world = velocities_mps(everything, np.concatenate([[ego_speed_mps], speeds_mps]))
            exact = conflicts(ego_box, world[0], boxes, world[1:])
            return measured._replace(ttc_s=exact.ttc_s)
        return measured
