"""Road geometry in plain numpy: a centre-line polyline with lanes on both sides.

Answers in road coordinates (``s`` metres along the centre line, ``d`` metres to
its left) and back in world x, y. Lane ``i`` (0 = rightmost) has its centre at
``d = (i - (lanes - 1) / 2) * lane_width_m``; the road edges are at
``d = +-lanes * lane_width_m / 2``.
"""

from __future__ import annotations

import bisect
import math
from typing import NamedTuple

import numpy as np

from scenarios.scene.polyline_frame import PolylineFrame
from scenarios.spec.scenario_tables import RoadSpec

#: largest gap between a curve's polyline chord and its arc [m]
CHORD_TOLERANCE_M = 0.001


class RouteStop(NamedTuple):
    """Where the route enters a junction that takes traffic from another road too
    (a crossing, a merge) or asks something of the car (a traffic light, a duty to
    give way): the stop line at the end of its lane."""

    s_m: float  # the stop line, along the road
    tl: str | None  # the traffic light controlling the car's link (None: none)
    link_index: int  # the link's index in that light's state string (-1: none)
    give_way: bool  # without a light, the car gives way there


NO_STOPS: tuple[RouteStop, ...] = ()


class RouteCrosswalk(NamedTuple):
    """A pedestrian crossing over the route, as a map gives it: where the route runs
    across it and how far it reaches either side of the route's centre line."""

    near_s_m: float  # where the route enters it, along the road
    far_s_m: float  # where it leaves it
    right_d_m: float  # its far end right of the route's centre line (negative) [m]
    left_d_m: float  # its far end left of it [m]


NO_CROSSWALKS: tuple[RouteCrosswalk, ...] = ()


class Crossings(NamedTuple):
    """Roads that cross the route without a junction: over or under it."""

    lanes: frozenset[str]  # their SUMO lanes
    points_xy: np.ndarray  # where their centre lines cross the route's (K, 2) [m]


NO_CROSSINGS = Crossings(frozenset(), np.empty((0, 2)))
#: no stretch of the road (an empty (0, 2) array of ``[from_s_m, to_s_m]`` rows)
NO_STRETCHES = np.empty((0, 2))


def merged_stretches(rows: np.ndarray, join_m: float = 1e-6) -> np.ndarray:
    """Stretches ``[from_s_m, to_s_m]`` (K, 2) in order, those that touch (within
    ``join_m``) joined into one."""
    out: list[list[float]] = []
    for lo, hi in rows:
        if out and lo <= out[-1][1] + join_m:
            out[-1][1] = max(out[-1][1], float(hi))
        else:
            out.append([float(lo), float(hi)])
    return np.array(out).reshape(-1, 2)


#: the SUMO edge of a built-in road (one edge, its lanes numbered from the right)
EDGE_ID = "road"


class RoadGeometry:
    """A one-way road along a polyline centre line (a built road's is of its shape:
    :class:`StraightRoad`, :class:`CurveRoad`; a network route's is its lane's)."""

    def __init__(self, center_xy: np.ndarray, lanes: int, lane_width_m: float,
                 curvature_1pm: float = 0.0):
        self.center_xy = np.asarray(center_xy, dtype=float)
        #: the centre line's curvature, positive turning left [1/m]: a lane at offset
        #: ``d`` is ``1 - curvature * d`` times as long as the centre line (0: straight,
        #: or a polyline whose lanes are measured on their own)
        self.curvature_1pm = curvature_1pm
        self.lanes = lanes
        self.lane_width_m = lane_width_m
        #: the centre line's frame: road coordinates (s along it, d to its left)
        self.frame = PolylineFrame(self.center_xy)
        self.length_m = float(self.frame.seg_len_m.sum())
        self._seg_heading_rad = np.arctan2(self.frame.seg_dir[:, 1], self.frame.seg_dir[:, 0])
        self._seg_heading_list = self._seg_heading_rad.tolist()

    def sumo_place(self, s_m: float, lane: int = 0) -> tuple[str, int, float]:
        """SUMO's edge, lane index and lane position of road position ``s_m`` in
        ``lane`` (SUMO gives every lane of a built curve the centre line's length)."""
        return EDGE_ID, lane, s_m

    def route_edges(self, s_m: float) -> list[str]:
        """The SUMO edges of the road from ``s_m`` on."""
        return [EDGE_ID]

    @property
    def half_width_m(self) -> float:
        return self.lanes * self.lane_width_m / 2

    def lane_center_d_m(self, lane: int) -> float:
        return (lane - (self.lanes - 1) / 2) * self.lane_width_m

    def lane_widths_m(self, s_m: float, lane: int) -> tuple[float, tuple[float | None,
                                                                     float | None]]:
        """The width of ``lane`` at ``s_m`` and of the lanes on its right and left
        (None: no lane there) [m]. On a built-in road every lane is ``lane_width_m``
        wide."""
        def beside(other: int) -> float | None:
            return self.lane_width_m if 0 <= other < self.lanes else None

        return self.lane_width_m, (beside(lane - 1), beside(lane + 1))

    def lane_at_d(self, d_m: float) -> int:
        """The lane holding offset ``d_m`` (the inverse of :meth:`lane_center_d_m`; below
        0 or from ``lanes`` on: off the road's lanes)."""
        return math.floor((d_m + self.half_width_m) / self.lane_width_m)

    def _project(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Road coordinates and edge gaps of (K, 2) points: a step asks this of a few
        points, on polylines of up to hundreds of segments."""
        return self.frame.project(xy, self.half_width_m, self.length_m)

    def to_frenet(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Road coordinates ``(s_m, d_m)`` of (K, 2) points.

        Each point projects on its nearest centre-line segment (the first of equals):
        ``s`` is that segment's start plus the point's distance along it, ``d`` its
        distance to the segment's left. Points before the start or past the end are
        projected on the extended first or last segment, so ``s`` is negative or
        above ``length_m`` there.
        """
        return self._project(xy)[:2]

    def locate(self, x_m: float, y_m: float) -> tuple[float, float]:
        """:meth:`to_frenet` of one point, in plain floats (a step's question)."""
        return self.frame.locate(x_m, y_m)

    def locate_near(self, x_m: float, y_m: float, near_s_m: float,
                    reach_m: float = 30.0) -> tuple[float, float]:
        """:meth:`locate` among the segments within ``reach_m`` of ``near_s_m`` along
        the road: where a route passes close to itself (a grid's parallel streets,
        its own end), a point that moved on from ``near_s_m`` stays on its part."""
        starts = self.frame.seg_start_s_list
        first = max(0, bisect.bisect_right(starts, near_s_m - reach_m) - 1)
        last = max(first + 1, bisect.bisect_right(starts, near_s_m + reach_m))
        if first == 0 and last == len(starts):
            return self.locate(x_m, y_m)
        return self.frame.locate_among(x_m, y_m, first, last)

    @property
    def polyline(self) -> tuple[np.ndarray, ...]:
        """The centre line as the compiled kernels take it: segment starts (S, 2), unit
        directions (S, 2), lengths (S,), ``s`` at their starts (S,) and headings (S,)."""
        frame = self.frame
        return (frame.seg_start_xy, frame.seg_dir, frame.seg_len_m, frame.seg_start_s_m,
                self._seg_heading_rad)

    def heading_at(self, s_m) -> np.ndarray:
        """Heading of the centre line at ``s_m`` [rad, CCW from +x]."""
        return self._seg_heading_rad[self.frame.segments(np.asarray(s_m, dtype=float))]

    def heading_at_s(self, s_m: float) -> float:
        """:meth:`heading_at` of one position, in plain floats (a step's question)."""
        return self._seg_heading_list[self.frame.segment(s_m)]

    def xy_at(self, s_m, d_m) -> np.ndarray:
        """World points at road coordinates (broadcast), shape (..., 2) [m]."""
        return self.frame.points_off(s_m, d_m)

    def place_s_m(self, s_m: float, length_m: float) -> float:
        """Where a body ``length_m`` long centred at ``s_m`` stands (anywhere here)."""
        return s_m

    def stops(self) -> tuple[RouteStop, ...]:
        """The stop lines along the road, in order (none on a road of its own)."""
        return NO_STOPS

    def crossings(self) -> Crossings:
        """Roads over or under this one (none on a road of its own)."""
        return NO_CROSSINGS

    def crosswalks(self) -> tuple[RouteCrosswalk, ...]:
        """The pedestrian crossings over the road, in order (none on a road of its own)."""
        return NO_CROSSWALKS

    def lanes_beside(self, lane: int) -> tuple[np.ndarray, np.ndarray]:
        """Where a lane of the road's own direction, open to cars, lies beside lane
        ``lane`` (left, right): each (K, 2) rows ``[from_s_m, to_s_m]`` along the
        road, in order. Here every lane runs the road's whole length."""
        whole = np.array([[0.0, self.length_m]])
        return (whole if lane + 1 < self.lanes else NO_STRETCHES,
                whole if lane > 0 else NO_STRETCHES)

    def edge_gaps_m(self, points: np.ndarray) -> np.ndarray:
        """Each point's distance to the nearer road edge [m]: negative beyond it,
        ``inf`` before the road's start or past its end."""
        return self._project(points)[2]

    def off_road(self, points: np.ndarray) -> np.ndarray:
        """Which points lie beyond a road edge, alongside the road (a bool mask)."""
        return self.edge_gaps_m(points) < 0

    def any_off_road(self, points: np.ndarray) -> bool:
        """Whether any of a few ``points`` lies beyond a road edge, alongside the road
        before its end (past a route's end there is no kerb): a step asks it of the
        ego's corners, so it reads them one by one, in plain floats."""
        for x_m, y_m in points.tolist():
            s_m, d_m = self.frame.locate(x_m, y_m)
            if 0.0 <= s_m < self.length_m and self.half_width_m - abs(d_m) < 0:
                return True
        return False

    def drawn_edge_segments(self) -> np.ndarray | None:
        """Road edges to draw as segments; ``None``: the two edges of this road."""
        return None

    def offset_polyline(self, d_m: float) -> np.ndarray:
        """The polyline at constant lateral offset ``d_m`` (vertices on the bisectors)."""
        normals = np.stack([-self.frame.seg_dir[:, 1], self.frame.seg_dir[:, 0]], axis=-1)
        vertex_normals = np.concatenate([normals[:1], normals[:-1] + normals[1:], normals[-1:]])
        vertex_normals[1:-1] /= np.sum(vertex_normals[1:-1] * normals[1:], axis=1)[:, None]
        return self.center_xy + d_m * vertex_normals

    def edge_segments(self) -> np.ndarray:
        """Both road edges as (S, 4) segments ``[x0, y0, x1, y1]`` [m]."""
        parts = []
        for d_m in (-self.half_width_m, self.half_width_m):
            line = self.offset_polyline(d_m)
            parts.append(np.hstack([line[:-1], line[1:]]))
        return np.vstack(parts)

    def to_plain(self) -> dict:
        """JSON-able description, enough to draw the road without SUMO."""
        return {
            "center_xy": self.center_xy.round(6).tolist(),
            "lanes": self.lanes,
            "lane_width_m": self.lane_width_m,
        }


class StraightRoad(RoadGeometry):
    """A built ``straight`` road: its centre line from the origin along +x."""

    @classmethod
    def from_spec(cls, road: RoadSpec) -> StraightRoad:
        return cls(np.array([[0.0, 0.0], [road.length_m, 0.0]]), road.lanes, road.lane_width_m)


class CurveRoad(RoadGeometry):
    """A built ``curve`` road: its centre line an arc of ``road.curve_radius_m``
    (signed: positive turns left) from the origin heading +x, a polyline within
    :data:`CHORD_TOLERANCE_M` of the arc across the road's whole width."""

    @classmethod
    def from_spec(cls, road: RoadSpec) -> CurveRoad:
        radius_m = road.curve_radius_m
        outer_m = abs(radius_m) + road.half_width_m
        step_rad = 2 * math.acos(1 - CHORD_TOLERANCE_M / outer_m)
        sweep_rad = road.length_m / abs(radius_m)
        theta = np.linspace(0.0, sweep_rad, max(2, math.ceil(sweep_rad / step_rad) + 1))
        # a left curve (radius > 0) turns around (0, radius); a right one around (0, -|radius|)
        x = abs(radius_m) * np.sin(theta)
        y = radius_m * (1 - np.cos(theta))
        return cls(np.column_stack([x, y]), road.lanes, road.lane_width_m, 1 / radius_m)
