"""The ego's route through a SUMO network: drawn from the seed, or pinned by its
edges; only turns and lanes a car can drive.

The route is drawn from the seed: a lane outside junctions open to passenger
cars, long enough to hold the ego where it starts (chance in proportion to its
length), then at every junction one of the
lane's turns (straight on where it can with ``road.route_turns = "straight"``),
through the junction's own lanes, until the route is ``road.length_m`` long.
Never a U-turn, a lane closed to passenger cars (rail, footway, bike or bus
lanes), or a turn tighter than the car's turning circle (its model's
``min_turn_radius_m``, measured on the turn's lanes over
:data:`TURN_WINDOW_M` stretches). The road it makes:
:mod:`scenarios.sumo_net.route_road`.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from scenarios.common.errors import SdcError, SpecError
from scenarios.sumo_net.net_xml import (
    STRAIGHT,
    U_TURN,
    NetFile,
    NetLane,
    Turn,
)

#: tries at drawing a route that long before giving up (dead ends cut walks short)
ROUTE_TRIES = 50
#: a turn's path: its junction lanes and this much of the lanes before and after [m]
TURN_REACH_M = 5.0
#: a turn's tightness is measured over stretches at least this long (a polyline's
#: kink spread over it) [m]
TURN_WINDOW_M = 3.0
#: ... on the polyline sampled this finely [m]
RADIUS_SAMPLE_M = 0.25
#: a bend the ego reaches from its start is measured over this much of the lane [m]
START_BEND_WINDOW_M = 6.0


ROUTE, DEMAND = 1, 2  # the random streams a seed gives a sumo_net scenario


def scenario_stream(seed: int, purpose: int) -> np.random.Generator:
    """A random stream of a sumo_net scenario (``ROUTE`` or ``DEMAND``), apart
    from the lidar's noise and SUMO's own, which the seed also drives."""
    return np.random.default_rng([seed, purpose])


def _stations_m(points: np.ndarray) -> np.ndarray:
    """Each vertex's distance along a polyline from its first [m]."""
    return np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(points, axis=0).T))])


def _headings_rad(points: np.ndarray, along_m: np.ndarray, at_m: np.ndarray) -> np.ndarray:
    """The polyline's heading between consecutive points sampled at stations ``at_m``
    (``along_m``: its vertices' stations), unwrapped [rad]."""
    x, y = np.interp(at_m, along_m, points[:, 0]), np.interp(at_m, along_m, points[:, 1])
    return np.unwrap(np.arctan2(np.diff(y), np.diff(x)))


def tightest_radius_m(points: np.ndarray, window_m: float) -> float:
    """The tightest turning radius along a polyline: the least arc length over heading
    change of any stretch ``window_m`` long (a kink counts as a turn spread over it;
    the whole line when it is shorter), the line sampled every
    :data:`RADIUS_SAMPLE_M` [m]; inf for a straight line."""
    along = _stations_m(points)
    if along[-1] <= RADIUS_SAMPLE_M:
        return math.inf
    heading = _headings_rad(points, along, np.arange(0.0, along[-1], RADIUS_SAMPLE_M))
    span = int(min(round(window_m / RADIUS_SAMPLE_M), len(heading) - 1))
    if span < 1:
        return math.inf
    turn = np.abs(heading[span:] - heading[:-span])
    most = float(turn.max())
    return span * RADIUS_SAMPLE_M / most if most > 1e-9 else math.inf


def turn_path(net: NetFile, lane: NetLane, turn: Turn, reach_m: float) -> np.ndarray:
    """The path of ``turn`` out of ``lane``: the last ``reach_m`` of the lane, the
    junction's lanes, the first ``reach_m`` of the lane it leads to."""
    before, after = lane.shape_xy, net.lanes[turn.to].shape_xy
    return _joined([_tail(before, reach_m), *(net.lanes[v].shape_xy for v in turn.via),
                    _tail(after[::-1], reach_m)[::-1]])


def _tail(points: np.ndarray, reach_m: float) -> np.ndarray:
    """The last ``reach_m`` of a polyline (its whole when shorter)."""
    back = _stations_m(points[::-1])
    return points[len(points) - 1 - int(np.searchsorted(back, reach_m)):]


def _open_to_cars(net: NetFile, turn: Turn) -> bool:
    """Are the junction's lanes of ``turn`` and the lane it leads to open to cars?"""
    return all(net.lanes[v].passenger for v in (*turn.via, turn.to))


def drivable_turns(net: NetFile, lane: NetLane, min_radius_m: float) -> list[Turn]:
    """The turns out of ``lane`` a car may take: no U-turn, onto lanes open to
    passenger cars, and none tighter than ``min_radius_m``, the car's turning radius."""
    turns = []
    for turn in net.turns.get(lane.id, ()):
        if turn.direction == U_TURN or not _open_to_cars(net, turn):
            continue
        path = turn_path(net, lane, turn, TURN_REACH_M)
        if tightest_radius_m(path, max(min_radius_m, TURN_WINDOW_M)) >= min_radius_m:
            turns.append(turn)
    return turns


def takes_its_start(route: list[NetLane], start_m: float, speed_mps: float,
                    lateral_mps2: float, decel_mps2: float) -> bool:
    """Can a car at ``speed_mps``, ``start_m`` along the route, take every bend it
    reaches before it could stop (braking at ``decel_mps2`` from the start) at no
    more than ``lateral_mps2``? A bend's curvature is its heading change over
    :data:`START_BEND_WINDOW_M` (a kink spread over that much of the lane)."""
    line = _joined([lane.shape_xy for lane in route])
    along = _stations_m(line)
    stop_m = speed_mps**2 / (2 * decel_mps2)
    at = np.arange(start_m, min(along[-1], start_m + stop_m + START_BEND_WINDOW_M),
                   RADIUS_SAMPLE_M)
    span = round(START_BEND_WINDOW_M / RADIUS_SAMPLE_M)
    if len(at) <= span + 1:
        return True
    heading = _headings_rad(line, along, at)
    curvature = np.abs(heading[span:] - heading[:-span]) / START_BEND_WINDOW_M
    reached_m = at[:len(curvature)] - start_m  # where each bend begins
    speed_sq = np.maximum(speed_mps**2 - 2 * decel_mps2 * reached_m, 0.0)
    return bool(np.all(curvature * speed_sq <= lateral_mps2))


def draw_route(net: NetFile, rng: np.random.Generator, length_m: float,
               turns: str = "straight", min_radius_m: float = 0.0,
               first_lane_m: float = 0.0,
               fits: Callable[[list[NetLane]], bool] | None = None) -> list[NetLane]:
    """Lanes (junction lanes included) of a route at least ``length_m`` long;
    ``turns`` is ``road.route_turns``; no turn on it is tighter than ``min_radius_m``
    (:func:`drivable_turns`); its first lane at least ``first_lane_m`` long where the
    network has such lanes (the ego starts on it, not inside the junction after it);
    and, with ``fits``, a route it accepts (the car takes its start's bends)."""
    starts = ([lane for lane in net.normal_lanes() if lane.length_m >= first_lane_m]
              or net.normal_lanes())
    weights = np.array([lane.length_m for lane in starts])
    too_fast = 0
    for _ in range(ROUTE_TRIES):
        lane = starts[rng.choice(len(starts), p=weights / weights.sum())]
        route, total_m = [lane], lane.length_m
        while total_m < length_m:
            options = drivable_turns(net, lane, min_radius_m)
            if turns == "straight":
                options = [t for t in options if t.direction == STRAIGHT] or options
            if not options:
                break
            turn = options[rng.integers(len(options))]
            lane = net.lanes[turn.to]
            route += [*(net.lanes[v] for v in turn.via), lane]
            total_m = sum(piece.length_m for piece in route)
        if total_m >= length_m and (fits is None or fits(route)):
            return route
        too_fast += total_m >= length_m
    if too_fast:
        raise SdcError(f"{net.path}: found no route of {length_m:g} m in {ROUTE_TRIES} tries "
                       f"whose bends the car takes from its start speed ({too_fast} too "
                       "tight); try a lower ego.speed_mps")
    raise SdcError(f"{net.path}: found no route of {length_m:g} m in {ROUTE_TRIES} tries "
                   "(dead ends everywhere?); try a shorter road.length_m")


ROUTE_FIELD = "road.route_edges"


def _why_not(net: NetFile, edge: str, to: str, min_radius_m: float) -> str:
    """Why no lane of ``edge`` leads on to ``to`` in a way a car can drive."""
    lanes = [lane for lane in net.lanes.values() if lane.edge == edge and not lane.internal]
    turns = [t for lane in lanes for t in net.turns.get(lane.id, ()) if net.lanes[t.to].edge == to]
    if not turns:
        return f"edge {edge!r} does not lead to edge {to!r}"
    if all(t.direction == U_TURN for t in turns):
        return f"edge {edge!r} leads to edge {to!r} by a U-turn only"
    if not any(_open_to_cars(net, t) for t in turns):
        return f"edge {edge!r} leads to edge {to!r} on lanes closed to passenger cars only"
    return (f"every turn from edge {edge!r} to edge {to!r} is tighter than the car's turning "
            f"circle ({min_radius_m:.1f} m)")


def pinned_route(net: NetFile, edges: tuple[str, ...], min_radius_m: float,
                 lane_index: int | None = None) -> list[NetLane]:
    """The lanes (junction lanes included) of the route through ``edges`` in order: from
    the rightmost lane of the first edge that leads through all of them (or its lane
    ``lane_index``, ``road.route_lane``), by turns a car can drive
    (:func:`drivable_turns`). One it cannot drive is a :class:`SpecError` naming
    ``road.route_edges`` (or ``road.route_lane``) and the edge."""
    known = {lane.edge for lane in net.lanes.values() if not lane.internal}
    for edge in edges:
        if edge not in known:
            raise SpecError(ROUTE_FIELD, f"edge {edge!r} is not in the network {net.path}")

    def onward(lane: NetLane, i: int) -> list[NetLane] | None:
        if i == len(edges) - 1:
            return [lane]
        for turn in drivable_turns(net, lane, min_radius_m):
            if net.lanes[turn.to].edge == edges[i + 1]:
                rest = onward(net.lanes[turn.to], i + 1)
                if rest is not None:
                    return [lane, *(net.lanes[v] for v in turn.via), *rest]
        return None

    starts = sorted((lane for lane in net.normal_lanes() if lane.edge == edges[0]),
                    key=lambda lane: lane.index)
    if not starts:
        raise SpecError(ROUTE_FIELD, f"edge {edges[0]!r} has no lane open to passenger cars")
    if lane_index is not None:
        chosen = [lane for lane in starts if lane.index == lane_index]
        route = onward(chosen[0], 0) if chosen else None
        if route is None:
            open_to = ", ".join(str(lane.index) for lane in starts
                                if onward(lane, 0) is not None) or "none"
            raise SpecError("road.route_lane", f"{lane_index}: no lane {lane_index} of edge "
                            f"{edges[0]!r} leads through every edge (lanes that do: {open_to})")
        return route
    for start in starts:
        route = onward(start, 0)
        if route is not None:
            return route
    reach = 0  # how far along the edges some lane gets: the first step no lane takes
    for i in range(1, len(edges)):
        lanes = [lane for lane in net.normal_lanes() if lane.edge == edges[i - 1]]
        if not any(net.lanes[t.to].edge == edges[i] for lane in lanes
                   for t in drivable_turns(net, lane, min_radius_m)):
            reach = i
            break
    if reach:
        raise SpecError(ROUTE_FIELD, _why_not(net, edges[reach - 1], edges[reach], min_radius_m))
    raise SpecError(ROUTE_FIELD, "no single lane leads through every edge in order (the route "
                    "would need a lane change on an edge)")


def _joined(shapes: list[np.ndarray]) -> np.ndarray:
    """One polyline through consecutive shapes, repeated points dropped."""
    points = np.vstack(shapes)
    step = np.hypot(*np.diff(points, axis=0).T)
    return points[np.concatenate([[True], step > 1e-6])]
