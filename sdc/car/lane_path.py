"""The car's own lane as a controller measures with it: points to lane
coordinates and back.

A :class:`LanePath` holds the lane reading's path (``LaneReading.path_xy_m``: the
lane's centre line around the car, in the car's frame from its body centre) and
answers in lane coordinates: ``s`` metres along the lane from the road's start
(the same for a point from step to step, so positions can be remembered) and
``d`` metres to the left of its centre. Along a curve the frame follows the arc;
through a junction it follows the route's lanes. A reading without a path (one
made by hand) gives the arc through its offset, heading error and preview
offset instead.
"""

from __future__ import annotations

import math

import numpy as np

from scenarios.scene.polyline_frame import PolylineFrame

#: the arc a reading without a path stands for: this many points ...
ARC_POINTS = 41
#: ... this far behind and ahead of the car [m]
ARC_REACH_M = 100.0
#: a bend's curvature is its turn over this length of lane [m]
TURN_WINDOW_M = 3.0
#: a kink of the lane is taken on the arc that cuts its corner by this much [m]
CORNER_CUT_M = 0.3


def arc_curvature_1pm(lane, look_ahead_m: float) -> float:
    """The lane's curvature [1/m, + left] from a reading's offset, heading error and
    the preview offset ``look_ahead_m`` ahead (0 without a usable preview)."""
    if not look_ahead_m:
        return 0.0
    straight_m = lane.offset_m + look_ahead_m * math.sin(lane.heading_error_rad)
    return 2.0 * (straight_m - lane.preview_offset_m) / look_ahead_m**2


def arc_path(lane, look_ahead_m: float) -> tuple[np.ndarray, np.ndarray]:
    """A path (car frame, stations) for a reading without one: the arc of the
    reading's curvature through the car's offset and heading error."""
    curvature = arc_curvature_1pm(lane, look_ahead_m)
    u = np.linspace(-ARC_REACH_M, ARC_REACH_M, ARC_POINTS)
    if abs(curvature) > 1e-9:
        along, left = np.sin(curvature * u) / curvature, (1 - np.cos(curvature * u)) / curvature
    else:
        along, left = u, np.zeros_like(u)
    c, s = math.cos(lane.heading_error_rad), math.sin(lane.heading_error_rad)
    left = left - lane.offset_m  # the lane frame, its origin under the car
    xy = np.column_stack([along * c + left * s, left * c - along * s])
    return xy, lane.s_m + u


class LanePath:
    """The lane around the car, from a lane reading (see the module): a frame of its
    centre line (:class:`scenarios.scene.polyline_frame.PolylineFrame`), in the car's frame."""

    def __init__(self, xy: np.ndarray, s_m: np.ndarray):
        self.frame = PolylineFrame(xy, s_m, min_segment_m=1e-9)
        #: the body centre's station along the lane and its offset from the centre
        self.car_s_m, self.offset_m = self.locate(0.0, 0.0)

    @classmethod
    def from_reading(cls, lane, look_ahead_m: float) -> LanePath:
        if len(lane.path_xy_m) >= 2:
            return cls(lane.path_xy_m, lane.path_s_m)
        return cls(*arc_path(lane, look_ahead_m))

    def locate(self, x_m: float, y_m: float) -> tuple[float, float]:
        """Lane coordinates ``(s, d)`` of one point in the car's frame."""
        return self.frame.locate(x_m, y_m)

    def to_lane(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Lane coordinates ``(s, d)`` of (K, 2) points in the car's frame (each on its
        nearest segment; the path's first and last segments extended)."""
        return self.frame.project(xy)[:2]

    def turn_speed_mps(self, lateral_accel_mps2: float, decel_mps2: float,
                       window_m: float = TURN_WINDOW_M,
                       corner_m: float = CORNER_CUT_M, behind_m: float = 0.0) -> float:
        """The highest speed from which the car, braking at ``decel_mps2``, takes
        every bend of the lane ahead at no more than ``lateral_accel_mps2`` (inf on
        a straight lane). At each vertex ahead the lane's curvature is its turn
        between the segments ``window_m`` / 2 before and after it over the distance
        between their middles (at least ``window_m``), or, where the lane kinks
        (long straight pieces meeting at an angle), that of the arc tangent to both
        that passes ``corner_m`` inside the corner, if tighter. Bends from
        ``behind_m`` behind the body centre on count (the rear axle's: the car is
        still turning through them)."""
        ahead = self.frame.seg_start_s_m > self.car_s_m - behind_m
        if not ahead.any():
            return math.inf
        starts_s, directions = self.frame.seg_start_s_m, self.frame.seg_dir
        heading = np.unwrap(np.arctan2(directions[:, 1], directions[:, 0]))
        stations = starts_s[ahead]
        last = len(starts_s) - 1
        before = np.clip(np.searchsorted(starts_s, stations - window_m / 2, "right") - 1,
                         0, last)
        after = np.clip(np.searchsorted(starts_s, stations + window_m / 2, "right") - 1,
                        0, last)
        middle = starts_s + self.frame.seg_len_m / 2
        turn = np.minimum(np.abs(heading[after] - heading[before]), 0.99 * math.pi)
        curvature = np.maximum(turn / np.maximum(window_m, middle[after] - middle[before]),
                               (1 / np.cos(turn / 2) - 1) / corner_m)
        bends = curvature > 1e-6
        if not bends.any():
            return math.inf
        limit_sq = lateral_accel_mps2 / curvature[bends]
        distance = np.maximum(stations[bends] - self.car_s_m, 0.0)
        return float(np.sqrt(np.min(limit_sq + 2 * decel_mps2 * distance)))

    def heading_rad(self, s_m: float) -> float:
        """The lane's direction at ``s_m`` in the car's frame (0: where the car
        points; minus the car's heading error there)."""
        dx, dy = self.frame.seg_dir[self.frame.segment(s_m)]
        return math.atan2(dy, dx)

    def curvature_1pm(self, from_s_m: float, to_s_m: float) -> float:
        """The lane's mean curvature [1/m, + left] between two stations: its turn
        over the distance."""
        turn = self.heading_rad(to_s_m) - self.heading_rad(from_s_m)
        turn = (turn + math.pi) % (2 * math.pi) - math.pi
        return turn / (to_s_m - from_s_m)

    def points_at(self, s_m: np.ndarray) -> np.ndarray:
        """The lane centre's points at stations ``s_m`` (K,) in the car's frame (K, 2)."""
        return self.frame.points(s_m)

    def point_at(self, s_m: float, d_m: float) -> tuple[float, float]:
        """The point of lane coordinates ``(s_m, d_m)`` in the car's frame."""
        return self.frame.point(s_m, d_m)
