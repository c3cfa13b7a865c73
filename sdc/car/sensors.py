"""The ego's senses: a planar lidar ray-cast against boxes and road edges, and
its offset from the lane centre. Both see plain arrays, never a simulator.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from scenarios.road_geometry import RoadGeometry
from scenarios.scenario_spec import LidarSpec, beam_angles_rad
from scenarios.snapshot import NO_BOXES
from sdc.car.geometry_kernels import lidar_ranges_m


class Lidar:
    """A single-layer scanning lidar (the lesson's SICK LMS 291 semantics)."""

    def __init__(self, spec: LidarSpec, edge_segments: np.ndarray, rng: np.random.Generator):
        self.spec = spec
        self.angles_rad = beam_angles_rad(spec.beams, spec.fov_deg)
        self.edge_segments = np.ascontiguousarray(edge_segments, dtype=np.float64)
        self._rng = rng

    def scan(self, origin_xy: np.ndarray, yaw_rad: float, boxes: np.ndarray,
             more_boxes: np.ndarray = NO_BOXES) -> np.ndarray:
        """Range image [m] from a sensor at ``origin_xy`` heading ``yaw_rad`` against
        the boxes (of one or two sets) and the road edges: ``beams`` floats, ``inf``
        where nothing is hit within ``max_range_m``."""
        ranges = lidar_ranges_m(origin_xy, yaw_rad, self.angles_rad, boxes,
                                self.edge_segments, self.spec.max_range_m, more_boxes)
        if self.spec.noise_std_m > 0:
            noise = self._rng.normal(0.0, self.spec.noise_std_m, size=ranges.shape)
            ranges = np.where(np.isfinite(ranges), np.maximum(ranges + noise, 0.0), ranges)
        return ranges

    def points(self, ranges: np.ndarray) -> np.ndarray:
        """The returns as an (n, 2) point cloud in the ego frame: origin at the rear
        axle, x ahead, y left [m] (the sensor sits ``mount_ahead_m`` ahead of it)."""
        hit = np.isfinite(ranges)
        a = self.angles_rad[hit]
        return np.column_stack([self.spec.mount_ahead_m + ranges[hit] * np.cos(a),
                                ranges[hit] * np.sin(a)])


class LaneReading(NamedTuple):
    offset_m: float  # body centre's signed offset from the lane centre, + = left
    heading_error_rad: float  # car yaw minus lane heading, + = pointing left of the lane
    preview_offset_m: float  # offset of the point look_ahead_m ahead of the body centre
    s_m: float  # body centre's position along the road


class LaneSensor:
    """Where the car is relative to its own lane (the spec's ``ego.lane``)."""

    def __init__(self, road: RoadGeometry, lane: int):
        self.road = road
        self.lane_d_m = road.lane_center_d_m(lane)

    def measure(self, center_xy: np.ndarray, yaw_rad: float,
                look_ahead_m: float) -> LaneReading | None:
        """The reading for a body centre and heading; ``None`` past either end of the road."""
        cx, cy = float(center_xy[0]), float(center_xy[1])
        s_m, d_m = self.road.locate(cx, cy)
        if not 0.0 <= s_m <= self.road.length_m:
            return None
        _, preview_d_m = self.road.locate(cx + look_ahead_m * math.cos(yaw_rad),
                                          cy + look_ahead_m * math.sin(yaw_rad))
        heading_error = yaw_rad - self.road.heading_at_s(s_m)
        heading_error = (heading_error + math.pi) % (2 * math.pi) - math.pi
        return LaneReading(d_m - self.lane_d_m, heading_error, preview_d_m - self.lane_d_m, s_m)
