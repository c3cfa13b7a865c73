"""A SUMO network as the ego's road: its route's lane as the road, the network's
drivable area for road edges.

The route is drawn from the seed: a lane outside junctions open to passenger
cars, long enough to hold the ego where it starts (chance in proportion to its
length), then at every junction one of the
lane's turns (straight on where it can with ``road.route_turns = "straight"``),
through the junction's own lanes, until the route is ``road.length_m`` long.
Never a U-turn, a lane closed to passenger cars (rail, footway, bike or bus
lanes), or a turn tighter than the car's turning circle (its model's
``min_turn_radius_m``, measured on the turn's lanes over
:data:`TURN_WINDOW_M` stretches). Along it, the ego's lane is the road of
:class:`~scenarios.scene.road_geometry.RoadGeometry` (one lane: ``s`` along the route, ``d``
from its centre), so lane sensing, positions and route end work as on the
built-in roads; road edges come from the whole network
(:class:`~scenarios.sumo_net.drivable_area.DrivableArea`).
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from scenarios.common.atomic_write import write_atomic
from scenarios.common.cache_dir import network_cache_dir
from scenarios.common.errors import SdcError, SpecError
from scenarios.scene.road_geometry import (
    Crossings,
    RoadGeometry,
    RouteCrosswalk,
    RouteStop,
    merged_stretches,
)
from scenarios.spec.bodies import GRAVITY_MPS2, VEHICLE_MODELS
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.sumo_net.crosswalks import route_crosswalks
from scenarios.sumo_net.drivable_area import EDGE_SEARCH_VERSION, DrivableArea
from scenarios.sumo_net.grade_separation import crossing_lanes
from scenarios.sumo_net.net_xml import (
    STRAIGHT,
    U_TURN,
    NetFile,
    NetLane,
    Turn,
)

#: tries at drawing a route that long before giving up (dead ends cut walks short)
ROUTE_TRIES = 50
#: the road edges kept in a trace for drawing: those within this of the route [m]
DRAW_MARGIN_M = 120.0
#: a turn's path: its junction lanes and this much of the lanes before and after [m]
TURN_REACH_M = 5.0
#: a turn's tightness is measured over stretches at least this long (a polyline's
#: kink spread over it) [m]
TURN_WINDOW_M = 3.0
#: ... on the polyline sampled this finely [m]
RADIUS_SAMPLE_M = 0.25
#: a bend the ego reaches from its start is measured over this much of the lane [m]
START_BEND_WINDOW_M = 6.0
#: an obstacle moved off a junction stands this far from it [m]
JUNCTION_CLEARANCE_M = 0.5


@dataclass(frozen=True)
class RoutePiece:
    lane: NetLane
    start_s_m: float  # where the lane starts along the route
    length_m: float  # its shape's length

    def sumo_pos_m(self, s_m: float) -> float:
        """SUMO's lane position of route position ``s_m`` on this lane."""
        return (s_m - self.start_s_m) * self.lane.sumo_length_m / self.length_m


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


def _route_stops(net: NetFile, pieces: list[RoutePiece]) -> tuple[RouteStop, ...]:
    """The stop lines where the route leaves a lane into a junction that takes
    traffic from another road too, or through a link under a traffic light or one
    where the car gives way."""
    normal = [p for p in pieces if not p.lane.internal]
    stops = []
    for piece, following in zip(normal, normal[1:], strict=False):
        turn = next((t for t in net.turns.get(piece.lane.id, ()) if t.to == following.lane.id),
                    None)
        if turn is not None and (turn.tl is not None or turn.give_way or turn.shared):
            stops.append(RouteStop(piece.start_s_m + piece.length_m, turn.tl, turn.link_index,
                                   turn.tl is None and turn.give_way))
    return tuple(stops)


def _lanes_beside(net: NetFile, pieces: list[RoutePiece]) -> tuple[np.ndarray, np.ndarray]:
    """Where a lane of the same edge, open to cars, lies left and right of the route's
    lane (its index one up or one down): merged stretches along the route."""
    by_place = {(lane.edge, lane.index): lane for lane in net.lanes.values()}

    def beside(step: int) -> np.ndarray:
        rows = []
        for piece in pieces:
            lane = by_place.get((piece.lane.edge, piece.lane.index + step))
            if lane is not None and lane.passenger:
                rows.append((piece.start_s_m, piece.start_s_m + piece.length_m))
        return merged_stretches(np.array(rows).reshape(-1, 2))

    return beside(1), beside(-1)


class NetworkRoad(RoadGeometry):
    """The ego's route through a SUMO network, one lane wide, with the network's
    road edges (``edge_segments``, ``edge_gaps_m``)."""

    def __init__(self, net: NetFile, route: list[NetLane], area: DrivableArea):
        super().__init__(_joined([lane.shape_xy for lane in route]), 1, route[0].width_m)
        self.net, self.area = net, area
        starts = np.concatenate([[0.0], np.cumsum([lane.length_m for lane in route])[:-1]])
        self.pieces = [RoutePiece(lane, float(s), lane.length_m)
                       for lane, s in zip(route, starts, strict=True)]
        self._piece_starts_m = [p.start_s_m for p in self.pieces]
        self._stops = _route_stops(net, self.pieces)
        self._beside = _lanes_beside(net, self.pieces)
        self._crossings = crossing_lanes(net, self.center_xy, {lane.id for lane in route})
        self._crosswalks = route_crosswalks(net, self)

    def piece_at(self, s_m: float) -> RoutePiece:
        """The route lane holding route position ``s_m``."""
        index = bisect.bisect_right(self._piece_starts_m, s_m) - 1
        return self.pieces[min(max(index, 0), len(self.pieces) - 1)]

    def place_s_m(self, s_m: float, length_m: float) -> float:
        """Where a body ``length_m`` long centred at ``s_m`` can stand: moved ahead
        off a junction onto the next lane, back off the junction its front would
        reach into, and ahead off the one its back would reach back into (SUMO holds
        stops on lanes only, shows nobody the part of a body in a junction, and never
        inserts a stopped vehicle reaching back into one: traffic would wait, cross or
        drive inside it), its ends :data:`JUNCTION_CLEARANCE_M` off the junction (at its
        lane's middle on a lane too short for that)."""
        piece, half_m = self.piece_at(s_m), length_m / 2 + JUNCTION_CLEARANCE_M
        if piece.lane.internal:
            following = self._lane_after(s_m)
            if following is None:
                return s_m
            return following.start_s_m + min(half_m, following.length_m / 2)
        start_m, end_m = piece.start_s_m, piece.start_s_m + piece.length_m
        if s_m + length_m / 2 >= end_m and self.piece_at(end_m).lane.internal:
            return end_m - min(half_m, piece.length_m / 2)
        if (s_m - length_m / 2 <= start_m and start_m > 0
                and self.piece_at(start_m - 1e-6).lane.internal):
            return start_m + min(half_m, piece.length_m / 2)
        return s_m

    def _lane_after(self, s_m: float) -> RoutePiece | None:
        """The first route lane outside a junction that starts after ``s_m``."""
        return next((p for p in self.pieces if p.start_s_m > s_m and not p.lane.internal), None)

    def sumo_place(self, s_m: float, lane: int = 0) -> tuple[str, int, float]:
        """SUMO's edge, lane index and lane position of route position ``s_m``
        (the start of the next lane when ``s_m`` is inside a junction; the route is
        its own lane 0)."""
        piece = self.piece_at(s_m)
        if piece.lane.internal:
            piece = self._lane_after(s_m) or piece
            s_m = piece.start_s_m
        pos_m = float(np.clip(piece.sumo_pos_m(s_m), 0.0, piece.lane.sumo_length_m))
        return piece.lane.edge, piece.lane.index, pos_m

    def lane_widths_m(self, s_m: float, lane: int) -> tuple[float, tuple[float | None,
                                                                     float | None]]:
        """The width at ``s_m`` of the route's lane (``lane`` 0), or of its edge's lane
        ``lane`` places left of it (negative: right), and of that edge's lanes on its
        right and left (None: the edge has none there) [m]."""
        own = self.piece_at(s_m).lane

        def width(step: int) -> float | None:
            other = self.net.lanes.get(f"{own.edge}_{own.index + step}")
            return None if other is None else other.width_m

        return width(lane), (width(lane - 1), width(lane + 1))

    def route_edges(self, s_m: float) -> list[str]:
        """The route's SUMO edges from the lane at ``s_m`` on (junctions aside)."""
        edges = [p.lane.edge for p in self.pieces
                 if not p.lane.internal and p.start_s_m + p.length_m > s_m]
        return [e for i, e in enumerate(edges) if i == 0 or edges[i - 1] != e]

    def stops(self) -> tuple[RouteStop, ...]:
        return self._stops

    def crossings(self) -> Crossings:
        return self._crossings

    def crosswalks(self) -> tuple[RouteCrosswalk, ...]:
        return self._crosswalks

    def lanes_beside(self, lane: int) -> tuple[np.ndarray, np.ndarray]:
        """Where the network has a lane of the route's direction beside it (its own
        edge's next lane left or right; ``lane`` is the route's, 0)."""
        return self._beside

    def edge_segments(self) -> np.ndarray:
        return self.area.edges

    def edge_gaps_m(self, points: np.ndarray) -> np.ndarray:
        return self.area.edge_gaps_m(points)

    def off_road(self, points: np.ndarray) -> np.ndarray:
        return self.area.off_road(points)

    def any_off_road(self, points: np.ndarray) -> bool:
        off = points[self.area.off_road(points)]
        return bool(len(off)) and bool((self.to_frenet(off)[0] < self.length_m).any())

    def drawn_edge_segments(self) -> np.ndarray:
        """The network's road edges within ``DRAW_MARGIN_M`` of the route."""
        lo = self.center_xy.min(axis=0) - DRAW_MARGIN_M
        hi = self.center_xy.max(axis=0) + DRAW_MARGIN_M
        edges = self.area.edges
        return edges[np.all((edges[:, :2] >= lo) & (edges[:, :2] <= hi), axis=1)]

    def to_plain(self) -> dict:
        return {
            **super().to_plain(),
            "net_file": str(self.net.path),
            "net_sha256": self.net.sha256,
            "route_lanes": [p.lane.id for p in self.pieces],
            "edge_segments": self.drawn_edge_segments().round(3).tolist(),
            # the stop lines, in order (the trace's signals have one state per line)
            "stops": [[round(stop.s_m, 6), stop.tl, stop.link_index, stop.give_way]
                      for stop in self._stops],
        }


def edges_cache_path(net_sha256: str, cache_dir: Path | None = None) -> Path:
    """Where the road edges of the network file with this sha256 are cached."""
    name = f"{net_sha256[:20]}.edges-v{EDGE_SEARCH_VERSION}.npy"
    return Path(cache_dir or network_cache_dir()) / name


def network_area(net: NetFile, cache_dir: Path | None = None) -> DrivableArea:
    """The network's drivable area; its road edges are cached by the file's hash."""
    lanes = list(net.lanes.values())
    cached = edges_cache_path(net.sha256, cache_dir)
    edges = np.load(cached) if cached.exists() else None
    area = DrivableArea([lane.shape_xy for lane in lanes], [lane.width_m for lane in lanes],
                        [i for i, lane in enumerate(lanes) if not lane.internal],
                        list(net.junction_shapes), edges)
    if edges is None:
        cached.parent.mkdir(parents=True, exist_ok=True)
        write_atomic(cached, lambda tmp: _save(tmp, area.edges))
    return area


def _save(path: Path, array: np.ndarray) -> None:
    with path.open("wb") as f:
        np.save(f, array)


def network_road(spec: ScenarioSpec, net: NetFile, cache_dir: Path | None = None
                 ) -> NetworkRoad:
    """The road of a scenario on a network (``net``: the road's, as its source reads
    it: :meth:`scenarios.sumo_net.road_source.NetworkFileRoad.network`): its route drawn
    from ``scenario.seed``, its drivable area's edges cached in ``cache_dir``.

    Raises :class:`SpecError` naming the field when the network cannot hold the
    scenario (no lane for cars, a pinned route too short, an obstacle off the
    drivable area).
    """
    if not net.normal_lanes():
        field = spec.road.network_field
        raise SpecError(field, f"{getattr(spec.road, field.removeprefix('road.'))}: its "
                        "network has no lane open to passenger cars (a rail or footway "
                        "network?)")
    model = VEHICLE_MODELS[spec.vehicle.model]
    min_radius_m = model.min_turn_radius_m
    if spec.road.route_edges is not None:
        route = pinned_route(net, spec.road.route_edges, min_radius_m, spec.road.route_lane)
        route_m = sum(lane.length_m for lane in route)
        if route_m < spec.road.length_m:
            raise SpecError("road.length_m", f"{spec.road.length_m} is longer than the pinned "
                            f"route (road.route_edges: {route_m:.1f} m)")
    else:
        try:
            first_lane_m = spec.ego.start_m + model.length_m / 2
            mu = spec.vehicle.friction_mu

            def fits(route: list[NetLane]) -> bool:
                return takes_its_start(route, spec.ego.start_m, spec.ego.speed_mps,
                                       mu * GRAVITY_MPS2, model.braking_decel_mps2(mu))

            route = draw_route(net, scenario_stream(spec.scenario.seed, ROUTE),
                               spec.road.length_m, spec.road.route_turns, min_radius_m,
                               first_lane_m, fits)
        except SdcError as e:
            raise SpecError("road.length_m", str(e)) from None
    road = NetworkRoad(net, route, network_area(net, cache_dir))
    for i, obstacle in enumerate(spec.obstacles):
        s_m = road.place_s_m(obstacle.position_m, obstacle.size_m[0])
        if road.off_road(road.xy_at(s_m, obstacle.lateral_offset_m)[None]).any():
            raise SpecError(f"obstacles[{i}].lateral_offset_m",
                            f"{obstacle.lateral_offset_m} puts the {obstacle.kind}'s centre "
                            "off the road")
    return road
