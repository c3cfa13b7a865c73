"""Watching for foes before a line where the car gives way: what moves toward the
junction beyond it.

Motion is read from two range images ``foe_track_s`` apart. The car's pose then
is known from its lane (the same two stations of the route's centre line in both
frames give the rigid move between them), so each return now is placed in the
car's frame then. A return moved in when it lies where the beam then nearest it
and the beams either side passed ``foe_move_m`` or more beyond it: space seen
free, now taken. A standing car's face that comes into view, a kerb the beams
slide along (at a grazing angle one of three beams hits it short of the point),
were never seen free.
It approaches the line when the return then nearest to it was farther from the
line's middle; a foe is a body of such returns (at least ``FOE_RETURNS``
together) outside the car's own lane, ahead of its front and within
``give_way_reach_m`` of the line, that reach the line within ``give_way_gap_s`` at
that rate.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from sdc.car.lane_path import LanePath

#: a foe is at least this many returns within FOE_SPAN_M [m] of one of them (a car
#: 30 m away shows 3 or more to a 1-degree lidar)
FOE_RETURNS, FOE_SPAN_M = 3, 3.0


class Scan(NamedTuple):
    t_s: float
    path: LanePath  # the lane, in the car's frame then
    xy_m: np.ndarray  # the returns, in the car's frame then (from its body centre)
    ranges_m: np.ndarray  # every beam's range (inf: none)


def _rigid(now: LanePath, then: LanePath, s_m: float) -> tuple[np.ndarray, np.ndarray]:
    """The rotation and shift taking points of the car's frame now to its frame then,
    from the lane's centre at ``s_m`` and 5 m on in both."""
    a_now, b_now = np.array(now.point_at(s_m, 0.0)), np.array(now.point_at(s_m + 5.0, 0.0))
    a_then, b_then = np.array(then.point_at(s_m, 0.0)), np.array(then.point_at(s_m + 5.0, 0.0))
    turn = (np.arctan2(*(b_then - a_then)[::-1]) - np.arctan2(*(b_now - a_now)[::-1]))
    c, s = np.cos(turn), np.sin(turn)
    rotation = np.array([[c, -s], [s, c]])
    return rotation, a_then - rotation @ a_now


class FoeWatch:
    """Foes around the next line where the car gives way (see the module)."""

    def __init__(self, params):
        self.params = params
        self.scans: list[Scan] = []

    def clear(self) -> None:
        self.scans.clear()

    def foe_seen(self, obs, frame, path: LanePath, half_lane_m: float, line_s_m: float) -> bool:
        """One step: the observation, its returns (``LaneFrame``) on the lane ``path``,
        the own lane's half width and the line's station. Is a foe seen now?"""
        p, v = self.params, obs.vehicle
        self.scans.append(Scan(obs.t_s, path, frame.xy_m, obs.ranges_m))
        while obs.t_s - self.scans[0].t_s > p.foe_track_s + 1e-9:
            self.scans.pop(0)
        then = self.scans[0]
        span_s = obs.t_s - then.t_s
        if span_s < p.foe_track_s / 2 or not len(then.xy_m):
            return False
        front_m = v.length_m / 2
        watched = ((np.hypot(frame.s_m - line_s_m, frame.lateral_m) <= p.give_way_reach_m)
                   & (np.abs(frame.lateral_m) > half_lane_m) & (frame.ahead_m > front_m))
        if not watched.any():
            return False
        rotation, shift = _rigid(path, then.path, path.car_s_m)
        points = frame.xy_m[watched] @ rotation.T + shift  # in the frame then
        moved = self._seen_free(points, then, obs)
        if not moved.any():
            return False
        line = np.array(path.point_at(line_s_m, 0.0)) @ rotation.T + shift
        points = points[moved]
        gaps = np.hypot(points[:, None, 0] - then.xy_m[None, :, 0],
                        points[:, None, 1] - then.xy_m[None, :, 1])
        was = then.xy_m[np.argmin(gaps, axis=1)]
        dist_now = np.hypot(*(points - line).T)
        closing_mps = (np.hypot(*(was - line).T) - dist_now) / span_s
        arrives_s = dist_now / np.maximum(closing_mps, 1e-9)
        foe = points[(closing_mps > 0) & (arrives_s < p.give_way_gap_s)]
        if len(foe) < FOE_RETURNS:
            return False
        # a body: FOE_RETURNS such returns together (a kerb's end seen anew is one or two)
        apart = np.hypot(foe[:, None, 0] - foe[None, :, 0], foe[:, None, 1] - foe[None, :, 1])
        return bool(np.any((apart <= FOE_SPAN_M).sum(axis=1) >= FOE_RETURNS))

    def _seen_free(self, points: np.ndarray, then: Scan, obs) -> np.ndarray:
        """Which points (the car's frame then) lay where a beam then passed
        ``foe_move_m`` or more beyond them, within its beam's width."""
        sensor = np.array([obs.lidar_ahead_m - obs.vehicle.center_ahead_of_rear_axle_m, 0.0])
        rel = points - sensor
        reach = np.hypot(rel[:, 0], rel[:, 1])
        bearing = np.arctan2(rel[:, 1], rel[:, 0])
        angles = obs.beam_angles_rad  # index 0 leftmost: decreasing
        k = np.clip(np.searchsorted(-angles, -bearing), 0, len(angles) - 1)
        k_other = np.clip(k - 1, 0, len(angles) - 1)
        k = np.where(np.abs(angles[k_other] - bearing) < np.abs(angles[k] - bearing), k_other, k)
        spacing = np.abs(np.diff(angles)).max() if len(angles) > 1 else np.pi
        within = np.abs(angles[k] - bearing) <= spacing / 2 + 1e-9
        ranges = np.where(np.isfinite(then.ranges_m), then.ranges_m, obs.lidar_range_m)
        beyond = reach + self.params.foe_move_m
        last = len(angles) - 1
        # the beams either side too: a kerb the beams graze is hit short of it by one
        return (within & (ranges[k] >= beyond) & (ranges[np.maximum(k - 1, 0)] >= beyond)
                & (ranges[np.minimum(k + 1, last)] >= beyond))
