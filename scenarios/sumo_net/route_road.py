"""A SUMO network as the ego's road: its route's lane as the road, the network's
drivable area for road edges.

Along the route (:mod:`scenarios.sumo_net.route_drawing`: drawn from the seed or
pinned), the ego's lane is the road of
:class:`~scenarios.scene.road_geometry.RoadGeometry` (one lane: ``s`` along the route, ``d``
from its centre), so lane sensing, positions and route end work as on the
built-in roads; road edges come from the whole network
(:class:`~scenarios.sumo_net.drivable_area.DrivableArea`).
"""

from __future__ import annotations

import bisect
import functools
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
from scenarios.sumo_net.net_xml import NetFile, NetLane
from scenarios.sumo_net.route_drawing import (
    ROUTE,
    _joined,
    draw_route,
    pinned_route,
    scenario_stream,
    takes_its_start,
)

#: the road edges kept in a trace for drawing: those within this of the route [m]
DRAW_MARGIN_M = 120.0
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

    def __init__(self, net: NetFile, route: list[NetLane], cache_dir: Path | None = None):
        super().__init__(_joined([lane.shape_xy for lane in route]), 1, route[0].width_m)
        self.net, self._cache_dir = net, cache_dir
        starts = np.concatenate([[0.0], np.cumsum([lane.length_m for lane in route])[:-1]])
        self.pieces = [RoutePiece(lane, float(s), lane.length_m)
                       for lane, s in zip(route, starts, strict=True)]
        self._piece_starts_m = [p.start_s_m for p in self.pieces]
        self._stops = _route_stops(net, self.pieces)
        self._beside = _lanes_beside(net, self.pieces)
        self._crossings = crossing_lanes(net, self.center_xy, {lane.id for lane in route})
        self._crosswalks = route_crosswalks(net, self)

    @functools.cached_property
    def area(self) -> DrivableArea:
        """The network's drivable area (:func:`network_area`), worked out when first
        asked: a warm-up, which drives no ego, never asks (nor imports scipy.spatial)."""
        return network_area(self.net, self._cache_dir)

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
    """The network's drivable area, worked out once per :class:`NetFile`; its road
    edges are cached by the file's hash."""
    if "area" not in net.derived:
        net.derived["area"] = _drivable_area(net, cache_dir)
    return net.derived["area"]


def _drivable_area(net: NetFile, cache_dir: Path | None) -> DrivableArea:
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
    road = NetworkRoad(net, route, cache_dir)
    for i, obstacle in enumerate(spec.obstacles):
        s_m = road.place_s_m(obstacle.position_m, obstacle.size_m[0])
        if road.off_road(road.xy_at(s_m, obstacle.lateral_offset_m)[None]).any():
            raise SpecError(f"obstacles[{i}].lateral_offset_m",
                            f"{obstacle.lateral_offset_m} puts the {obstacle.kind}'s centre "
                            "off the road")
    return road
