"""Coordinates along a polyline: the one lane frame of the road and of the car's lane.

A point's *station* ``s`` [m] is how far along the polyline its projection lies, its
*offset* ``d`` [m] how far to the polyline's left (HighwayEnv's lanes answer the same
with ``local_coordinates`` / ``position`` / ``heading_at``). Each point projects on its
nearest segment (the first of equals); points before the start or past the end
project on the extended first or last segment. The projections run in
:mod:`scenarios.scene.road_kernels` (compiled where built). The road
(:class:`scenarios.scene.road_geometry.RoadGeometry`) and the lane a controller measures with
(:class:`sdc.car.lane_path.LanePath`) are each a frame and what they add to it.
"""

from __future__ import annotations

import bisect

import numpy as np

from scenarios.scene import road_kernels


class PolylineFrame:
    """The frame of the polyline ``xy`` (N, 2) [m]; ``s_m`` (N,): its points' stations
    (default: the distance along it from its first point). Segments no longer than
    ``min_segment_m`` are left out (a reading may repeat a point)."""

    def __init__(self, xy: np.ndarray, s_m: np.ndarray | None = None,
                 min_segment_m: float | None = None):
        xy = np.asarray(xy, dtype=float)
        delta = np.diff(xy, axis=0)
        lengths = np.hypot(delta[:, 0], delta[:, 1])
        if min_segment_m is not None:
            keep = lengths > min_segment_m
            xy_starts, delta, lengths = xy[:-1][keep], delta[keep], lengths[keep]
            starts_s = None if s_m is None else np.asarray(s_m, dtype=float)[:-1][keep]
        else:
            xy_starts = xy[:-1]
            starts_s = None if s_m is None else np.asarray(s_m, dtype=float)[:-1]
        #: segment starts (S, 2), lengths (S,), unit directions (S, 2), stations (S,)
        self.seg_start_xy = np.ascontiguousarray(xy_starts)
        self.seg_len_m = np.ascontiguousarray(lengths)
        self.seg_dir = np.ascontiguousarray(delta / lengths[:, None])
        self.seg_start_s_m = (np.concatenate([[0.0], np.cumsum(lengths)[:-1]])
                              if starts_s is None else np.ascontiguousarray(starts_s))
        self.seg_start_s_list = self.seg_start_s_m.tolist()  # for scalar look-ups

    def locate(self, x_m: float, y_m: float) -> tuple[float, float]:
        """``(s, d)`` of one point, in plain floats (a step's question)."""
        return road_kernels.locate(x_m, y_m, self.seg_start_xy, self.seg_dir, self.seg_len_m,
                                   self.seg_start_s_m)

    def locate_among(self, x_m: float, y_m: float, first: int,
                     last: int) -> tuple[float, float]:
        """:meth:`locate` on the segments ``first`` to ``last`` (excluded) only."""
        return road_kernels.locate(x_m, y_m, self.seg_start_xy[first:last],
                                   self.seg_dir[first:last], self.seg_len_m[first:last],
                                   self.seg_start_s_m[first:last])

    def project(self, xy: np.ndarray, half_width_m: float = 0.0,
                length_m: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(s, d, gap)`` of (K, 2) points, ``gap`` the distance to the nearer of the
        edges ``half_width_m`` to each side (``inf`` outside ``0 <= s <= length_m``)."""
        xy = np.ascontiguousarray(xy, dtype=np.float64).reshape(-1, 2)
        s_m, d_m, gaps_m = np.empty((3, len(xy)))
        road_kernels.frenet(xy, self.seg_start_xy, self.seg_dir, self.seg_len_m,
                            self.seg_start_s_m, s_m, d_m, half_width_m, length_m, gaps_m)
        return s_m, d_m, gaps_m

    def segment(self, s_m: float) -> int:
        """The segment holding station ``s_m`` (the first or last beyond the ends)."""
        index = bisect.bisect_right(self.seg_start_s_list, s_m) - 1
        return min(max(index, 0), len(self.seg_start_s_list) - 1)

    def segments(self, s_m: np.ndarray) -> np.ndarray:
        """:meth:`segment` of each station."""
        return np.clip(np.searchsorted(self.seg_start_s_m, s_m, side="right") - 1,
                       0, len(self.seg_len_m) - 1)

    def point(self, s_m: float, d_m: float) -> tuple[float, float]:
        """The point at ``(s_m, d_m)``, in plain floats."""
        seg = self.segment(s_m)
        along = s_m - self.seg_start_s_list[seg]
        (x0, y0), (dx, dy) = self.seg_start_xy[seg], self.seg_dir[seg]
        return float(x0 + along * dx - d_m * dy), float(y0 + along * dy + d_m * dx)

    def points(self, s_m: np.ndarray) -> np.ndarray:
        """The polyline's points at stations ``s_m`` (K,), shape (K, 2)."""
        seg = self.segments(s_m)
        along = s_m - self.seg_start_s_m[seg]
        return self.seg_start_xy[seg] + along[:, None] * self.seg_dir[seg]

    def points_off(self, s_m, d_m) -> np.ndarray:
        """The points at ``(s_m, d_m)`` (broadcast), shape (..., 2)."""
        s_m, d_m = np.broadcast_arrays(np.asarray(s_m, float), np.asarray(d_m, float))
        seg = self.segments(s_m)
        direction = self.seg_dir[seg]
        normal = np.stack([-direction[..., 1], direction[..., 0]], axis=-1)
        along = (s_m - self.seg_start_s_m[seg])[..., None]
        return self.seg_start_xy[seg] + along * direction + d_m[..., None] * normal
