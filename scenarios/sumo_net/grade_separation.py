"""Roads that cross the ego's route without a junction: a bridge or a tunnel.

A SUMO network is flat, but where two roads cross outside every junction they
are on different levels (OpenStreetMap's layers): SUMO's vehicles on one never
meet those on the other. The ego's route must not meet them either, nor see
them (a single-layer lidar under a bridge sees neither the deck's traffic nor,
from the deck, the road below). :func:`crossing_lanes` finds the network's lanes
whose centre line crosses the route's outside the junctions' outlines, and where.
"""

from __future__ import annotations

import numpy as np

from scenarios.scene.road_geometry import NO_CROSSINGS, Crossings
from scenarios.sumo_net.drivable_area import in_polygon, polyline_segments, segment_distance_m
from scenarios.sumo_net.net_xml import NetFile

#: a crossing this close to a junction's outline is taken as the junction's [m]
JUNCTION_SLACK_M = 2.0
#: a vehicle on a road that crosses the route without a junction is on another level
#: (a bridge, a tunnel, their ramps) within this of the crossing [m]
LEVEL_REACH_M = 100.0
#: lanes' segments are tested against the route's in blocks of this many
BLOCK = 4096


def intersections(a0, a1, b0, b1):
    """Where segments a (N) cross segments b (M): (index in a, index in b, point)."""
    da, db = a1 - a0, b1 - b0
    cross = da[:, None, 0] * db[None, :, 1] - da[:, None, 1] * db[None, :, 0]
    rel = b0[None, :, :] - a0[:, None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (rel[..., 0] * db[None, :, 1] - rel[..., 1] * db[None, :, 0]) / cross
        u = (rel[..., 0] * da[:, None, 1] - rel[..., 1] * da[:, None, 0]) / cross
    hit = (np.abs(cross) > 1e-9) & (t >= 0) & (t <= 1) & (u >= 0) & (u <= 1)
    i, j = np.nonzero(hit)
    return i, j, a0[i] + t[i, j][:, None] * da[i]


def _near_junction(point: np.ndarray, shapes: tuple[np.ndarray, ...]) -> bool:
    for shape in shapes:
        lo, hi = shape.min(axis=0) - JUNCTION_SLACK_M, shape.max(axis=0) + JUNCTION_SLACK_M
        if np.any(point < lo) or np.any(point > hi):
            continue
        if in_polygon(point, shape):
            return True
        closed = np.vstack([shape, shape[:1]])
        a, b = closed[:-1], closed[1:]
        if segment_distance_m(np.broadcast_to(point, a.shape), a, b).min() <= JUNCTION_SLACK_M:
            return True
    return False


def crossing_lanes(net: NetFile, route_xy: np.ndarray, route_lane_ids: set[str]) -> Crossings:
    """The lanes of ``net`` (not the route's own) whose centre line crosses the
    route's centre line ``route_xy`` outside every junction (farther than
    ``JUNCTION_SLACK_M`` from its outline), with the lanes of their road near the
    crossing (:func:`_whole_roads`), and the crossing points."""
    others = [lane for lane in net.lanes.values()
              if lane.id not in route_lane_ids and len(lane.shape_xy) >= 2]
    if not others or len(route_xy) < 2:
        return NO_CROSSINGS
    r0, r1 = route_xy[:-1], route_xy[1:]
    lo, hi = np.minimum(r0, r1).min(axis=0), np.maximum(r0, r1).max(axis=0)
    s0, s1, owner = polyline_segments([lane.shape_xy for lane in others])
    inside = np.all((np.maximum(s0, s1) >= lo) & (np.minimum(s0, s1) <= hi), axis=1)
    s0, s1, owner = s0[inside], s1[inside], owner[inside]
    lanes, points = set(), []
    for start in range(0, len(s0), BLOCK):
        block = slice(start, start + BLOCK)
        _, j, xy = intersections(r0, r1, s0[block], s1[block])
        for k, point in zip(j, xy, strict=True):
            if not _near_junction(point, net.junction_shapes):
                lanes.add(others[owner[block][k]].id)
                points.append(point)
    if not lanes:
        return NO_CROSSINGS
    points_xy = np.array(points)
    return Crossings(frozenset(_whole_roads(net, lanes, points_xy, route_lane_ids)), points_xy)


def _whole_roads(net: NetFile, crossing: set[str], points_xy: np.ndarray,
                 route_lane_ids: set[str]) -> set[str]:
    """The crossing lanes and the lanes they run on from or to (through junctions,
    both ways) within ``LEVEL_REACH_M`` of a crossing: the bridge's or tunnel's
    road, not where it meets the route (lanes joined to the route's are at grade)."""
    joined: dict[str, set[str]] = {}
    for lane_id, turns in net.turns.items():
        for turn in turns:
            chain = [lane_id, *turn.via, turn.to]
            for a, b in zip(chain[:-1], chain[1:], strict=True):
                joined.setdefault(a, set()).add(b)
                joined.setdefault(b, set()).add(a)
    at_grade = set(route_lane_ids).union(*(joined.get(r, set()) for r in route_lane_ids))

    def near(lane_id: str) -> bool:
        shape = net.lanes[lane_id].shape_xy
        a, b = shape[:-1], shape[1:]
        return any(segment_distance_m(np.broadcast_to(p, a.shape), a, b).min() <= LEVEL_REACH_M
                   for p in points_xy)

    road, frontier = set(crossing), list(crossing)
    while frontier:
        for other in joined.get(frontier.pop(), ()):
            if other not in road and other not in at_grade and other in net.lanes and near(other):
                road.add(other)
                frontier.append(other)
    return road
