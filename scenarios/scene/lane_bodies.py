"""A vehicle's body as SUMO's own lanes hold it, whatever angle SUMO reports for it.

Without the sublane model SUMO knows a vehicle by its lane, its lane position (the
front bumper), its lateral offset from the lane's centre (during a continuous lane
change) and its length: its car following, its lane changes and its junctions work
on that body, laid back from the front along the lane. The angle it reports is
drawn from the back to the front, plus a lane-change angle that grows without bound
at a crawl and fades only as the vehicle drives on after the change
(``MSAbstractLaneChangeModel::calcAngleOffset``, SUMO 1.2x): a rigid box
at that angle spins about its front bumper, which no vehicle can, and a long one
through a junction's curve is one chord across it.

:class:`LanePath` lays a body along its lane's shape (and the lanes before it, where
it reaches back into them), as SUMO holds it: shifted sideways by its lateral offset,
never turned by it, and in as many boxes as its path bends under it. The world draws its
traffic so (:meth:`scenarios.sumo.traffic_reading.TrafficReader.read`, one box in compiled
code); the witness of whose an overlap is (:mod:`sdc.run.world_witness`) lays them in
:data:`BODY_PIECES` boxes.
"""

from __future__ import annotations

import bisect
import math

import numpy as np

#: boxes the witness lays a body in along its lane (a 16.5 m truck: 4 m each)
BODY_PIECES = 4
#: a body is laid in as few boxes as keep its centre line and its corners within this
#: of where its path has them [m]
PIECE_TOLERANCE_M = 0.15
#: no box of a body laid in several is shorter than this: SUMO's lane shapes may kink
#: where two lanes join (on the A10 a junction's lane jogs 47 degrees over 4.4 m), and
#: a sliver of body turned there would stick out of it [m]
STRETCH_MIN_M = 1.0


class LanePath:
    """The path of a vehicle's lane and the lanes it came by: ``lanes``, each its shape
    (N, 2) and the length SUMO measures positions on along it (which may differ from
    the shape's length), in driving order, its own lane last. In plain floats: a step
    lays a few bodies, where numpy's calls cost more than the arithmetic."""

    __slots__ = ("_x", "_y", "_ux", "_uy", "_starts", "_lanes", "segments")

    def __init__(self, lanes: list[tuple[np.ndarray, float]]):
        shapes = [np.asarray(shape, float).reshape(-1, 2) for shape, _ in lanes]
        points = np.vstack(shapes)
        delta = np.diff(points, axis=0)
        lengths = np.hypot(delta[:, 0], delta[:, 1])
        at_point = np.concatenate([[0.0], np.cumsum(lengths)])  # each point's station
        keep = lengths > 1e-9  # a shape may repeat a point
        starts, delta, kept = points[:-1][keep], delta[keep], lengths[keep]
        self.segments = len(kept)  # none: a lane of one point, no path to lay along
        self._x, self._y = starts[:, 0].tolist(), starts[:, 1].tolist()
        self._ux, self._uy = (delta[:, 0] / kept).tolist(), (delta[:, 1] / kept).tolist()
        self._starts = at_point[:-1][keep].tolist()
        #: each lane's (station of its first point, shape metres per lane metre, its
        #: SUMO length), in driving order
        self._lanes = []
        first = 0
        for shape, (_, lane_length_m) in zip(shapes, lanes, strict=True):
            last = first + len(shape) - 1
            shape_m = float(at_point[last] - at_point[first])
            scale = shape_m / lane_length_m if lane_length_m > 0 else 1.0
            self._lanes.append((float(at_point[first]), scale, float(lane_length_m)))
            first = last + 1

    def station_m(self, lane_pos_m: float, back_m: float = 0.0) -> float:
        """Where along the path lies the point ``back_m`` behind SUMO's lane position
        ``lane_pos_m`` on the vehicle's own lane, measured as SUMO measures, in each
        lane's own metres (before the first lane: along its first segment, extended)."""
        pos_m, k = lane_pos_m - back_m, len(self._lanes) - 1
        while pos_m < 0.0 and k > 0:
            k -= 1
            pos_m += self._lanes[k][2]
        start_m, scale, _ = self._lanes[k]
        return start_m + pos_m * scale

    def _segment(self, station_m: float) -> int:
        """The segment a station lies on (the first and last extended)."""
        return min(max(bisect.bisect_right(self._starts, station_m) - 1, 0), len(self._x) - 1)

    def point(self, station_m: float, lateral_m: float) -> tuple[float, float]:
        """The point ``lateral_m`` left of the path at ``station_m`` along it."""
        k = self._segment(station_m)
        t, ux, uy = station_m - self._starts[k], self._ux[k], self._uy[k]
        return self._x[k] + t * ux - lateral_m * uy, self._y[k] + t * uy + lateral_m * ux

    def body(self, lane_pos_m: float, lateral_m: float, length_m: float, width_m: float,
             pieces: int | None = None, tolerance_m: float = PIECE_TOLERANCE_M,
             stretch_min_m: float = STRETCH_MIN_M
             ) -> list[tuple[float, float, float, float, float]]:
        """The boxes ``(cx, cy, yaw, length, width)`` of a body ``length_m`` x
        ``width_m`` whose front is at lane position ``lane_pos_m``, ``lateral_m`` left
        of the lane's centre line, laid back along the path from the rear to the
        front: the chords between ``pieces`` + 1 equally spaced stations, or by default
        between as few of the path's own points under it as keep the body's centre
        line and corners within ``tolerance_m`` of the path's (one box where the path
        is straight under it; :func:`_fewest`). Its front and back are where SUMO has
        them, so on a bend the chords add up to a little less than its length. One
        box is computed as ``scenarios/scene/_road_kernels.c`` computes it (``lay_one_box``),
        to the last bit."""
        front_m, back_m = self.station_m(lane_pos_m), self.station_m(lane_pos_m, length_m)
        if pieces is None:
            first, last = self._segment(back_m), self._segment(front_m)
            stations = [back_m, *self._starts[first + 1:last + 1], front_m]
        else:
            stations = [back_m + (front_m - back_m) * k / pieces for k in range(pieces)]
            stations.append(front_m)
        points = [self.point(s, lateral_m) for s in stations]
        if pieces is None:
            points = _fewest(points, tolerance_m, width_m / 2, stretch_min_m)
        boxes = []
        for (bx, by), (fx, fy) in zip(points[:-1], points[1:], strict=True):
            dx, dy = fx - bx, fy - by
            boxes.append(((bx + fx) / 2, (by + fy) / 2, math.atan2(dy, dx),
                          math.sqrt(dx * dx + dy * dy), width_m))
        return boxes

    @property
    def flat(self) -> np.ndarray:
        """The path of one lane as the compiled read of the traffic takes it
        (``scenarios/scene/_road_kernels.c``): its shape metres per lane metre, its segment
        count, then per segment its start (x, y), unit direction and station."""
        segments = np.column_stack([self._x, self._y, self._ux, self._uy, self._starts])
        return np.concatenate([[self._lanes[-1][1], self.segments], segments.ravel()])

    @classmethod
    def from_flat(cls, flat) -> LanePath:
        """The path of one lane from its :attr:`flat` form."""
        path = cls.__new__(cls)
        segments = np.asarray(flat[2:], float).reshape(-1, 5)
        path.segments = len(segments)
        path._x, path._y, path._ux, path._uy, path._starts = (c.tolist() for c in segments.T)
        path._lanes = [(0.0, float(flat[0]), 0.0)]
        return path


def _fewest(points: list[tuple[float, float]], tolerance_m: float, half_width_m: float,
            stretch_min_m: float) -> list[tuple[float, float]]:
    """The first and last of ``points`` and as few between as keep every one within
    ``tolerance_m`` of the chords between those kept, and every chord's corners
    (``half_width_m`` beside it) within ``tolerance_m`` of the path's sides: each
    stretch between two points turned from its chord by at most ``tolerance_m /
    half_width_m`` (split where the farthest point lies, until none is farther:
    Douglas and Peucker's simplification, with the corners). No box is made shorter
    than ``stretch_min_m``: a point nearer an end is not split at, and a stretch that
    short is not turned to (a sliver turned there would stick out of the body)."""
    if len(points) <= 2:
        return points
    (ax, ay), (bx, by) = points[0], points[-1]
    dx, dy = bx - ax, by - ay
    chord_m = math.sqrt(dx * dx + dy * dy)
    least = stretch_min_m * stretch_min_m
    farthest, at = -1.0, 0
    for k in range(1, len(points) - 1):
        px, py = points[k][0] - ax, points[k][1] - ay
        qx, qy = points[k][0] - bx, points[k][1] - by
        if px * px + py * py < least or qx * qx + qy * qy < least:
            continue
        off_m = (abs(dx * py - dy * px) / chord_m if chord_m > 0
                 else math.sqrt(px * px + py * py))
        if off_m > farthest:
            farthest, at = off_m, k
    turned = 0.0
    for (px, py), (qx, qy) in zip(points[:-1], points[1:], strict=True):
        ex, ey = qx - px, qy - py
        if ex * ex + ey * ey >= least:
            turned = max(turned, abs(math.atan2(dx * ey - dy * ex, dx * ex + dy * ey)))
    if at == 0 or (farthest <= tolerance_m and turned * half_width_m <= tolerance_m):
        return [points[0], points[-1]]
    return (_fewest(points[:at + 1], tolerance_m, half_width_m, stretch_min_m)[:-1]
            + _fewest(points[at:], tolerance_m, half_width_m, stretch_min_m))


class LanePaths:
    """The paths of SUMO's lanes, each read once (``lane``: libsumo's or traci's lane
    domain); a body reaching back off its lane lies along the lanes
    ``lanes_behind(vehicle id, lane id, reach_m)`` names too, as far back as it reaches
    (kept for that vehicle on that lane)."""

    def __init__(self, lane, lanes_behind):
        self._lane, self._lanes_behind = lane, lanes_behind
        self._own: dict[str, LanePath] = {}
        #: lane id -> its path's flat form, for the compiled read of the traffic
        self.flat: dict[str, np.ndarray] = {}
        self._joined: dict[tuple[str, str], LanePath] = {}

    def _lane_of(self, lane_id: str) -> tuple[np.ndarray, float]:
        return (np.array(self._lane.getShape(lane_id), float).reshape(-1, 2),
                self._lane.getLength(lane_id))

    def path(self, vehicle_id: str, lane_id: str, reach_m: float) -> LanePath:
        """The path a vehicle on ``lane_id`` lies along (with the lanes it came by
        where it reaches back ``reach_m`` > 0 beyond the lane's start)."""
        if reach_m <= 0:
            if lane_id not in self._own:
                path = self._own[lane_id] = LanePath([self._lane_of(lane_id)])
                self.flat[lane_id] = path.flat
            return self._own[lane_id]
        key = (vehicle_id, lane_id)
        if key not in self._joined:
            lanes = [*self._lanes_behind(vehicle_id, lane_id, reach_m), lane_id]
            self._joined[key] = LanePath([self._lane_of(k) for k in lanes])
        return self._joined[key]
