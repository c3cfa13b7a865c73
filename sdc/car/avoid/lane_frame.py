"""The range image's returns in the lane's own frame, at one step.

Each return becomes a point along the car's lane and across it
(:class:`~sdc.car.lane_path.LanePath`: along the arc of a curve, through the
route's lanes at a junction), so road edges along the lane stay at their offsets
on curves and through junction turns, outside the lane. The questions the
controller asks of one step's returns are here: which lie in a band, which belong
to the obstacle nearest in the path, is any a small body (a person, a bicycle),
which is nearest.
"""

from __future__ import annotations

import math

import numpy as np

from sdc.car.controller_api import Observation
from sdc.car.lane_path import LanePath

#: an obstacle's face is what the lidar sees of it within this beyond its nearest
#: return [m], laterally joined by gaps under FACE_JOIN_M [m] (the beams' spacing at
#: a few tens of metres)
FACE_DEPTH_M, FACE_JOIN_M = 1.0, 0.6


class LaneFrame:
    """The range image's returns in lane coordinates at one step (:class:`LanePath`).

    ``s_m``: along the lane (the same for a point from step to step), ``ahead_m``:
    along the lane from the car's body centre, ``lateral_m``: from the centre of
    the car's own lane (+ left); ``xy_m``: the returns in the car's frame, from its
    body centre. ``cos_sin``: each beam's direction's cosine and sine (2, beams).
    """

    def __init__(self, obs: Observation, cos_sin: np.ndarray, path: LanePath):
        hit = np.isfinite(obs.ranges_m)
        r = obs.ranges_m[hit]
        x = (obs.lidar_ahead_m - obs.vehicle.center_ahead_of_rear_axle_m) + r * cos_sin[0, hit]
        y = r * cos_sin[1, hit]
        self.xy_m = np.column_stack([x, y])  # in the car's frame, from its body centre
        self.s_m, self.lateral_m = path.to_lane(self.xy_m)
        self.ahead_m = self.s_m - path.car_s_m

    def within(self, lo_m: float, hi_m: float, behind_m: float, ahead_m: float) -> np.ndarray:
        """Which returns lie laterally in ``[lo_m, hi_m]`` and along the lane in
        ``[behind_m, ahead_m]`` (both from the body centre)."""
        lat, along = self.lateral_m, self.ahead_m
        return (lat >= lo_m) & (lat <= hi_m) & (along >= behind_m) & (along <= ahead_m)

    def obstacle(self, in_path: np.ndarray, depth_m: float) -> np.ndarray:
        """The returns of the obstacle whose nearest return is the nearest of
        ``in_path``: its face (the returns within ``FACE_DEPTH_M`` beyond that one,
        laterally joined to those in the path by gaps under ``FACE_JOIN_M``: a body
        reaching out of the lane, not a kerb beside it) and everything laterally
        within the face up to ``depth_m`` beyond it."""
        nearest_m = float(self.ahead_m[in_path].min())
        face = self.within(-math.inf, math.inf, nearest_m, nearest_m + FACE_DEPTH_M)
        core = self.lateral_m[in_path & face]
        lo, hi = float(core.min()), float(core.max())
        outside = np.sort(self.lateral_m[face])
        for lat in outside[outside > hi]:
            if lat - hi > FACE_JOIN_M:
                break
            hi = float(lat)
        for lat in outside[outside < lo][::-1]:
            if lo - lat > FACE_JOIN_M:
                break
            lo = float(lat)
        return self.within(lo, hi, nearest_m, nearest_m + depth_m)

    def ahead(self, lo_m: float, hi_m: float, front_m: float) -> np.ndarray:
        """Which returns lie laterally in ``[lo_m, hi_m]`` and ahead of the front
        bumper, ``front_m`` ahead of the body centre (0.5 m of slack behind it)."""
        return self.within(lo_m, hi_m, front_m - 0.5, math.inf)

    def small_bodies(self, among: np.ndarray, size_m: float) -> bool:
        """Is any of the returns ``among`` these part of a body no bigger than ``size_m``
        across and along the lane (a person, a bicycle; not a car, nor a kerb or an
        island's edge running on)? A body's returns: neighbours in beam order less than
        ``FACE_JOIN_M`` apart."""
        if not among.any():
            return False
        gaps = np.hypot(*np.diff(self.xy_m, axis=0).T)
        starts = np.concatenate([[0], np.flatnonzero(gaps > FACE_JOIN_M) + 1])
        body = np.repeat(np.arange(len(starts)), np.diff(np.append(starts, len(gaps) + 1)))
        span = np.maximum(
            np.maximum.reduceat(self.s_m, starts) - np.minimum.reduceat(self.s_m, starts),
            np.maximum.reduceat(self.lateral_m, starts)
            - np.minimum.reduceat(self.lateral_m, starts))
        return bool((span[body[among]] <= size_m).any())

    def nearest(self, among: np.ndarray, front_m: float) -> tuple[float, float | None]:
        """The nearest return ``among`` these: its gap along the lane from the front
        bumper ``front_m`` ahead of the body centre, and its station (inf, None: none)."""
        if not among.any():
            return math.inf, None
        i = int(np.argmin(np.where(among, self.ahead_m, math.inf)))
        return float(self.ahead_m[i]) - front_m, float(self.s_m[i])
