"""The ego's senses: a planar lidar ray-cast against boxes and road edges, and
its offset from the lane centre. Both see plain arrays, never a simulator.
"""

from __future__ import annotations

import bisect
import math
from typing import NamedTuple

import numpy as np

from scenarios.scene.road_geometry import RoadGeometry
from scenarios.scene.snapshot import NO_BOXES
from scenarios.spec.scenario_tables import LidarSpec, beam_angles_rad
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


#: the lane path is the lane's centre line to within this [m] (a polyline with
#: vertices only where the line bends more)
PATH_TOLERANCE_M = 0.01
NO_PATH = np.zeros((0, 2))
NO_PATH.flags.writeable = False
NO_STATIONS = np.zeros(0)
NO_STATIONS.flags.writeable = False


class LaneReading(NamedTuple):
    """The car's own lane, seen from the car (as a lane camera and a map would).

    ``path_xy_m`` is the lane's centre line around the car, the route's lanes
    through junctions: a polyline within ``PATH_TOLERANCE_M`` of it, in the car's
    frame with its origin at the body centre (x ahead, y left), from the lidar's
    range behind the car to its range ahead (cut at the road's ends);
    ``path_s_m`` each vertex's distance along the lane from the road's start. A
    reading made by hand may leave both empty: controllers then take the lane as
    an arc through the offset, heading error and preview offset.
    """

    offset_m: float  # body centre's signed offset from the lane centre, + = left
    heading_error_rad: float  # car yaw minus lane heading, + = pointing left of the lane
    preview_offset_m: float  # offset of the point look_ahead_m ahead of the body centre
    s_m: float  # body centre's position along the road
    path_xy_m: np.ndarray = NO_PATH
    path_s_m: np.ndarray = NO_STATIONS


def simplified_polyline(xy: np.ndarray, tolerance_m: float) -> np.ndarray:
    """Which vertices of a polyline to keep so that it stays within ``tolerance_m``
    of the original (Douglas-Peucker): a bool mask, both ends kept."""
    keep = np.zeros(len(xy), bool)
    keep[[0, -1]] = True
    spans = [(0, len(xy) - 1)]
    while spans:
        i, j = spans.pop()
        if j - i < 2:
            continue
        chord = xy[j] - xy[i]
        length = math.hypot(chord[0], chord[1])
        rel = xy[i + 1:j] - xy[i]
        if length > 0:
            dist = np.abs(rel[:, 0] * chord[1] - rel[:, 1] * chord[0]) / length
        else:
            dist = np.hypot(rel[:, 0], rel[:, 1])
        k = int(np.argmax(dist))
        if dist[k] > tolerance_m:
            keep[i + 1 + k] = True
            spans += [(i, i + 1 + k), (i + 1 + k, j)]
    return keep


class LaneSensor:
    """Where the car is relative to its own lane (the spec's ``ego.lane``), and the
    lane's path ``path_range_m`` behind and ahead of it. One sensor follows one
    car: each reading is looked for near the last one along the road."""

    def __init__(self, road: RoadGeometry, lane: int, path_range_m: float = 0.0):
        self.road = road
        self.lane_d_m = road.lane_center_d_m(lane)
        line = road.offset_polyline(self.lane_d_m)
        line = line[simplified_polyline(line, PATH_TOLERANCE_M)]
        self.path_xy_m = line
        self._path_rows = np.column_stack([line, np.ones(len(line))])
        steps = np.hypot(*np.diff(line, axis=0).T)
        self.path_s_m = np.concatenate([[0.0], np.cumsum(steps)])
        self.path_s_m.flags.writeable = False
        self._path_s_list = self.path_s_m.tolist()
        self.lane_scale = self.path_s_m[-1] / road.length_m  # lane m per road m
        self.path_range_m = path_range_m
        #: where the car was along the road at the last reading: the next one looks
        #: for it near there (a route may pass close to itself)
        self.s_m: float | None = None

    def measure(self, center_xy: np.ndarray, yaw_rad: float,
                look_ahead_m: float) -> LaneReading | None:
        """The reading for a body centre and heading; ``None`` past either end of the road."""
        cx, cy = float(center_xy[0]), float(center_xy[1])
        road = self.road
        if self.s_m is None:
            s_m, d_m = road.locate(cx, cy)
        else:
            s_m, d_m = road.locate_near(cx, cy, self.s_m)
        self.s_m = s_m
        if not 0.0 <= s_m <= road.length_m:
            return None
        _, preview_d_m = road.locate_near(cx + look_ahead_m * math.cos(yaw_rad),
                                          cy + look_ahead_m * math.sin(yaw_rad),
                                          s_m + look_ahead_m)
        heading_error = yaw_rad - self.road.heading_at_s(s_m)
        heading_error = (heading_error + math.pi) % (2 * math.pi) - math.pi
        path_xy, path_s = self._path(cx, cy, yaw_rad, s_m * self.lane_scale)
        return LaneReading(d_m - self.lane_d_m, heading_error, preview_d_m - self.lane_d_m, s_m,
                           path_xy, path_s)

    def _path(self, cx: float, cy: float, yaw_rad: float,
              lane_s_m: float) -> tuple[np.ndarray, np.ndarray]:
        """The path's vertices from ``path_range_m`` behind ``lane_s_m`` to as far
        ahead (and the one beyond each end), in the frame of a car at ``(cx, cy)``
        heading ``yaw_rad``."""
        if not self.path_range_m:
            return NO_PATH, NO_STATIONS
        stations = self._path_s_list
        first = max(0, bisect.bisect_right(stations, lane_s_m - self.path_range_m) - 1)
        last = min(len(stations), bisect.bisect_left(stations, lane_s_m + self.path_range_m) + 1)
        c, s = math.cos(yaw_rad), math.sin(yaw_rad)
        # (x - cx, y - cy) turned by -yaw, as one product of the rows (x, y, 1)
        to_car = np.array([[c, -s], [s, c], [-cx * c - cy * s, cx * s - cy * c]])
        xy = self._path_rows[first:last] @ to_car
        xy.flags.writeable = False
        return xy, self.path_s_m[first:last]
