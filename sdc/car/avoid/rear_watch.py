"""Watching the lanes behind the car with a range image that covers the rear:
does a gap stay open long enough to move into a lane?

For each lane (left, right, own) it keeps a track of the nearest return behind
the car's rear bumper (a vehicle coming from behind; negative gaps: beside the
car), its closing speed measured over ``rear_track_s``, and how far back the
lane was seen at all: returns between the sensor and the lane (a car queued
behind in the own lane) cast shadows on it, and the lidar's range ends
somewhere. The rule (``AvoidParams``):

- a vehicle seen behind: open when its gap is at least ``rear_min_gap_m`` plus
  its closing speed times ``rear_gap_time_s``, or, when it stands (slower than
  ``pass_max_speed_mps``: queued, waiting to merge; what comes behind it must stop
  behind it), ``rear_standing_gap_m``; a vehicle seen for less than half of
  ``rear_track_s``, or lost for a moment, keeps the lane closed;
- nothing seen: open when the lane was seen empty so far back that a vehicle just
  out of sight, as fast as the fastest seen in that lane so far (at least
  ``rear_unseen_speed_mps``), would still leave that gap.

Positions are in the lane's frame (:class:`sdc.car.avoid.lane_frame.LaneFrame`); the
shadows are taken as straight lines in it.
"""

from __future__ import annotations

import math

import numpy as np


class RearWatch:
    """The lanes behind the car, step by step (see the module)."""

    def __init__(self, params):
        self.params = params
        self.tracks: dict[float, list[tuple[float, float]]] = {}  # side: [(t, gap)]
        self.fastest_mps: dict[float, float] = {}  # side: fastest vehicle seen coming
        self.seen_back_m: dict[float, float] = {}  # side: how far back seen, from the rear

    def update(self, frame, obs, bands, offset_m: float) -> None:
        """One step's returns (a ``LaneFrame``) for each ``(side, lo, hi)`` lane band."""
        p, v = self.params, obs.vehicle
        rear_m = -v.length_m / 2
        sensor_m = obs.lidar_ahead_m - v.center_ahead_of_rear_axle_m  # ahead of the centre
        for side, lo, hi in bands:
            behind = frame.within(lo, hi, -math.inf, v.length_m / 2)
            self.seen_back_m[side] = self._seen_back_m(frame, obs, lo, hi, offset_m, sensor_m,
                                                       rear_m)
            track = self.tracks.setdefault(side, [])
            if not behind.any():
                if track and obs.t_s - track[-1][0] > p.rear_track_s:
                    track.clear()
                continue
            gap_m = rear_m - float(frame.ahead_m[behind].max())
            if track and gap_m > track[-1][1] + p.rear_jump_m:
                track.clear()
            track.append((obs.t_s, gap_m))
            while obs.t_s - track[0][0] > p.rear_track_s + 1e-9:
                track.pop(0)
            closing = self._closing_mps(track)
            if closing is not None:
                speed = closing + obs.speed_mps
                self.fastest_mps[side] = max(self.fastest_mps.get(side, 0.0), speed)

    def _seen_back_m(self, frame, obs, lo: float, hi: float, offset_m: float,
                     sensor_m: float, rear_m: float) -> float:
        """How far behind the rear bumper the lane ``[lo, hi]`` was seen: up to the
        first shadow of a return between the sensor and the lane, and no further
        than the lidar's range reaches along the lane's near edge."""
        if lo <= offset_m <= hi:
            across_m = 0.0
            shadowing = np.zeros(len(frame.ahead_m), bool)
        else:
            near_m = lo if offset_m < lo else hi
            across_m = abs(near_m - offset_m)
            between = (frame.lateral_m - offset_m) * (near_m - frame.lateral_m) > 0
            shadowing = between & (frame.ahead_m < sensor_m)
        reach_m = obs.lidar_range_m
        back_m = (math.sqrt(reach_m**2 - across_m**2) if reach_m > across_m else 0.0)
        back_m -= sensor_m - rear_m  # from the rear bumper
        if shadowing.any():
            # a return at (back, across) shadows the lane from back * ratio on
            back = sensor_m - frame.ahead_m[shadowing]
            ratio = across_m / np.abs(frame.lateral_m[shadowing] - offset_m)
            back_m = min(back_m, float(np.min(back * ratio)) - (sensor_m - rear_m))
        return back_m

    @staticmethod
    def _closing_mps(track: list[tuple[float, float]]) -> float | None:
        """The closing speed over the track (None while it is a single sample)."""
        span_s = track[-1][0] - track[0][0]
        return (track[0][1] - track[-1][1]) / span_s if span_s > 0 else None

    def open(self, side: float, obs) -> bool:
        """May the car move into that lane now (the module's rule)?"""
        p = self.params
        track = self.tracks.get(side)
        if track:
            t_s, gap_m = track[-1]
            if t_s < obs.t_s or t_s - track[0][0] < p.rear_track_s / 2:
                return False  # lost for a moment, or its speed not known yet
            closing_mps = self._closing_mps(track)
            if closing_mps + obs.speed_mps < p.pass_max_speed_mps:  # it stands (a queue)
                return gap_m >= p.rear_standing_gap_m
            return gap_m >= p.rear_min_gap_m + max(closing_mps, 0.0) * p.rear_gap_time_s
        unseen_mps = max(self.fastest_mps.get(side, 0.0), p.rear_unseen_speed_mps)
        need_m = p.rear_min_gap_m + max(unseen_mps - obs.speed_mps, 0.0) * p.rear_gap_time_s
        return self.seen_back_m.get(side, 0.0) >= need_m
