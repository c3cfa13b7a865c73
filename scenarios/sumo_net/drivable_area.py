"""The drivable area of a road network and its edges, for any lane layout.

The area is the union of the lanes (a centre-line polyline swept by half the
lane's width) and the junction outlines. A road edge is a piece of a lane's
border or of a junction's outline whose outside is not drivable: the border
between two lanes, or between a road and its opposite direction, is not an
edge; a kerb, a median and a junction corner are.
"""

from __future__ import annotations

import math

import numpy as np

#: cached road edges carry this number: change it when the search for edges changes
EDGE_SEARCH_VERSION = 3
#: lane and edge polylines are cut into pieces no longer than this for the spatial index [m]
INDEX_PIECE_M = 5.0
#: a border is probed this far outside itself, every PROBE_STEP_M along it [m]
PROBE_OUT_M, PROBE_STEP_M = 0.25, 1.0
#: ... and the probe is drivable within this of a lane: the seam between two lanes
#: side by side (their shapes rounded to 0.01 m, or a few cm apart) is no road edge
SEAM_SLACK_M = 0.1
#: a point outside the area is off the road when it lies within this of a road edge
#: (it crossed one) or this far from every lane and junction: a gap between lanes
#: too narrow to hold an edge (the probe lands in the next lane) is no kerb [m]
OFF_ROAD_M = PROBE_OUT_M + SEAM_SLACK_M
#: road edges farther than this from a point do not count for its gap [m]
GAP_HORIZON_M = 30.0
#: index pieces looked up per point at once; a point with more within reach gets all
NEAREST_PIECES = 16


def _pieces(starts: np.ndarray, ends: np.ndarray, max_len_m: float):
    """Cut segments into pieces of at most ``max_len_m``: (starts, ends, source index)."""
    length = np.hypot(*(ends - starts).T)
    n = np.maximum(1, np.ceil(length / max_len_m)).astype(int)
    source = np.repeat(np.arange(len(starts)), n)
    k = np.arange(len(source)) - np.repeat(np.cumsum(n) - n, n)
    step = (ends - starts)[source] / n[source, None]
    a = starts[source] + k[:, None] * step
    return a, a + step, source


def segment_distance_m(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance from each point to the matching segment a-b (row-wise) [m]."""
    ab = b - a
    t = np.einsum("ij,ij->i", points - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-12)
    foot = a + np.clip(t, 0.0, 1.0)[:, None] * ab
    return np.hypot(*(points - foot).T)


def polyline_segments(lines: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """All segments of several polylines: (starts, ends, polyline index)."""
    starts = np.vstack([line[:-1] for line in lines])
    ends = np.vstack([line[1:] for line in lines])
    owner = np.repeat(np.arange(len(lines)), [len(line) - 1 for line in lines])
    return starts, ends, owner


def offset_line(line: np.ndarray, d_m: float) -> np.ndarray:
    """A polyline moved ``d_m`` to its left (vertices on the bisectors)."""
    direction = np.diff(line, axis=0)
    direction /= np.maximum(np.hypot(*direction.T), 1e-12)[:, None]
    normal = np.column_stack([-direction[:, 1], direction[:, 0]])
    vertex = np.vstack([normal[:1], normal[:-1] + normal[1:], normal[-1:]])
    if len(normal) > 1:
        dot = np.einsum("ij,ij->i", vertex[1:-1], normal[1:])
        vertex[1:-1] /= np.maximum(dot, 0.2)[:, None]  # no spikes at hairpins
    return line + d_m * vertex


class DrivableArea:
    """Lanes and junctions of a network: what is drivable, and where its edges are."""

    def __init__(self, lane_shapes: list[np.ndarray], lane_widths_m: list[float],
                 border_lanes: list[int], junction_shapes: list[np.ndarray],
                 edges: np.ndarray | None = None):
        """``border_lanes`` are the indices of the lanes whose borders may be road
        edges (those outside junctions); every lane counts as drivable. ``edges``
        are the road edges found earlier for the same lanes and junctions (their
        search takes a moment on a big network)."""
        from scipy.spatial import cKDTree  # here: a process that builds no area skips 0.3 s

        starts, ends, owner = polyline_segments(lane_shapes)
        keep = np.hypot(*(ends - starts).T) > 1e-9
        a, b, source = _pieces(starts[keep], ends[keep], INDEX_PIECE_M)
        self._lane_a, self._lane_b = a, b
        self._lane_half_w = (np.asarray(lane_widths_m) / 2)[owner[keep][source]]
        self._lane_tree = cKDTree((a + b) / 2)
        self._lane_reach_m = float(np.max(np.hypot(*(b - a).T) / 2 + self._lane_half_w))
        self._junctions = [np.asarray(j, float) for j in junction_shapes]
        self._junction_box = np.array(
            [[*j.min(axis=0), *j.max(axis=0)] for j in self._junctions]).reshape(-1, 4)
        if edges is None:
            edges = self._find_edges([lane_shapes[i] for i in border_lanes],
                                     [lane_widths_m[i] for i in border_lanes])
        self.edges = edges
        ea, eb, _ = _pieces(self.edges[:, :2], self.edges[:, 2:], INDEX_PIECE_M)
        self._edge_a, self._edge_b = ea, eb
        self._edge_tree = cKDTree((ea + eb) / 2) if len(ea) else None

    def contains(self, points: np.ndarray, slack_m: float = 0.0) -> np.ndarray:
        """Which points lie on a lane (or within ``slack_m`` of one) or inside a
        junction (a bool mask)."""
        points = np.asarray(points, float).reshape(-1, 2)
        inside = np.zeros(len(points), bool)
        if len(points) == 0:
            return inside
        which, seg = _pieces_near(self._lane_tree, points, self._lane_reach_m)
        near = segment_distance_m(points[which], self._lane_a[seg], self._lane_b[seg])
        inside[which[near <= self._lane_half_w[seg] + slack_m + 1e-9]] = True
        rest = np.flatnonzero(~inside)
        if len(rest) and len(self._junctions):
            p = points[rest]
            box = self._junction_box
            candidates = ((p[:, None, 0] >= box[:, 0]) & (p[:, None, 0] <= box[:, 2])
                          & (p[:, None, 1] >= box[:, 1]) & (p[:, None, 1] <= box[:, 3]))
            for i, j in zip(*np.nonzero(candidates), strict=True):
                if not inside[rest[i]] and in_polygon(p[i], self._junctions[j]):
                    inside[rest[i]] = True
        return inside

    def _find_edges(self, lanes: list[np.ndarray], widths_m: list[float]) -> np.ndarray:
        """The pieces of lane borders and junction outlines with nothing drivable outside."""
        lines, outward = [], []
        for line, width in zip(lanes, widths_m, strict=True):
            lines += [offset_line(line, width / 2), offset_line(line, -width / 2)]
            outward += [1.0, -1.0]  # the left border looks left, the right one right
        for shape in self._junctions:
            closed = np.vstack([shape, shape[:1]])
            lines.append(closed)
            outward.append(-1.0 if _signed_area(closed) > 0 else 1.0)  # CCW: outside is right
        if not lines:
            return np.zeros((0, 4))
        starts, ends, owner = polyline_segments(lines)
        keep = np.hypot(*(ends - starts).T) > 1e-9
        starts, ends, owner = starts[keep], ends[keep], owner[keep]
        a, b, source = _pieces(starts, ends, PROBE_STEP_M)
        direction = (b - a) / np.hypot(*(b - a).T)[:, None]
        side = np.asarray(outward)[owner[source]][:, None]
        probe = (a + b) / 2 + PROBE_OUT_M * side * np.column_stack([-direction[:, 1],
                                                                     direction[:, 0]])
        is_edge = ~self.contains(probe, SEAM_SLACK_M)
        # each segment's consecutive edge pieces become one segment again
        same = source[1:] == source[:-1]
        first = is_edge & np.concatenate([[True], ~is_edge[:-1] | ~same])
        last = is_edge & np.concatenate([~is_edge[1:] | ~same, [True]])
        return np.hstack([a[first], b[last]])

    def off_road(self, points: np.ndarray) -> np.ndarray:
        """Which points lie off the road: outside the area, and beyond a road edge
        or ``OFF_ROAD_M`` from anything drivable (a bool mask)."""
        outside = ~self.contains(points)
        if outside.any():
            crossed = np.abs(self.edge_gaps_m(points)) <= OFF_ROAD_M
            outside &= crossed | ~self.contains(points, OFF_ROAD_M)
        return outside

    def edge_gaps_m(self, points: np.ndarray) -> np.ndarray:
        """Each point's distance to the nearest road edge [m]: negative off the
        drivable area, ``inf`` with no edge within ``GAP_HORIZON_M``."""
        points = np.asarray(points, float).reshape(-1, 2)
        gaps = np.full(len(points), math.inf)
        if self._edge_tree is None or len(points) == 0:
            return gaps
        which, seg = _pieces_near(self._edge_tree, points, GAP_HORIZON_M + INDEX_PIECE_M / 2)
        d = segment_distance_m(points[which], self._edge_a[seg], self._edge_b[seg])
        np.minimum.at(gaps, which, d)
        gaps[gaps > GAP_HORIZON_M] = math.inf
        return np.where(self.contains(points), gaps, -np.abs(gaps))


def _pieces_near(tree, points: np.ndarray, reach_m: float):
    """Every (point index, piece index) pair with the piece's midpoint within
    ``reach_m`` of the point: the ``NEAREST_PIECES`` nearest at once, and the
    whole neighbourhood of a point where that many are all within reach."""
    dist, seg = tree.query(points, k=NEAREST_PIECES, distance_upper_bound=reach_m)
    full = np.isfinite(dist[:, -1])  # maybe more within reach than were asked for
    found = np.isfinite(dist) & ~full[:, None]  # a missing neighbour comes back as inf
    which = np.broadcast_to(np.arange(len(points))[:, None], seg.shape)[found]
    seg = seg[found]
    crowded = np.flatnonzero(full)
    if len(crowded):
        more = tree.query_ball_point(points[crowded], reach_m)
        which = np.concatenate([which, np.repeat(crowded, [len(m) for m in more])])
        seg = np.concatenate([seg, np.concatenate(more).astype(int)])
    return which, seg


def _signed_area(closed: np.ndarray) -> float:
    x, y = closed[:, 0], closed[:, 1]
    return 0.5 * float(np.sum(x[:-1] * y[1:] - x[1:] * y[:-1]))


def in_polygon(point: np.ndarray, shape: np.ndarray) -> bool:
    """Even-odd rule: a ray from ``point`` crosses the outline an odd number of times."""
    x, y = point
    xa, ya = shape[:, 0], shape[:, 1]
    xb, yb = np.roll(xa, -1), np.roll(ya, -1)
    straddles = (ya > y) != (yb > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        x_cross = xa + (y - ya) * (xb - xa) / (yb - ya)
    return bool(np.count_nonzero(straddles & (x < x_cross)) % 2)
