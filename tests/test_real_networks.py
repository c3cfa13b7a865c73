"""SUMO's own real scenarios (the OpenStreetMap and hand-built networks its package
ships in ``tools/game``) read as SUMO reads them: gzipped networks included, every
lane's shape, width, length and permissions as sumolib reads them."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import sumo
import sumolib

from scenarios.sumo_net.net_xml import read_net

GAME_DIR = Path(sumo.SUMO_HOME) / "tools" / "game"
#: motorway, city (plain and gzipped), ring, corridor, a grid
REAL_NETWORKS = ["A10KW/osm.net.xml", "bs3d/bs.net.xml", "fkk_in/ingolstadt.net.xml.gz",
                 "fokr_bs_demo/fokr_bs.net.xml.gz", "square/square.net.xml",
                 "corridor/corridor.net.xml", "grid6/grid6.net.xml"]


@pytest.mark.parametrize("name", REAL_NETWORKS)
def test_the_network_reader_agrees_with_sumolib(name):
    path = GAME_DIR / name
    ours = read_net(path)
    theirs = sumolib.net.readNet(str(path), withInternal=True)
    lanes = {lane.getID(): lane for edge in theirs.getEdges(withInternal=True)
             if edge.getFunction() in ("", "normal", "internal") for lane in edge.getLanes()}
    assert set(ours.lanes) == set(lanes)
    for lane_id, lane in ours.lanes.items():
        other = lanes[lane_id]
        assert np.allclose(lane.shape_xy, np.array(other.getShape())[:, :2], atol=1e-6), lane_id
        assert lane.width_m == pytest.approx(other.getWidth()), lane_id
        assert lane.sumo_length_m == pytest.approx(other.getLength()), lane_id
        assert lane.passenger == other.allows("passenger"), lane_id
        assert lane.internal == (other.getEdge().getFunction() == "internal")
        if not lane.internal:
            targets = {c.getToLane().getID() for c in other.getOutgoing()} & set(lanes)
            assert {turn.to for turn in ours.turns[lane_id]} == targets, lane_id


def test_a_gzipped_network_reads_as_the_plain_one(tmp_path):
    import gzip

    plain = GAME_DIR / "bs3d" / "bs.net.xml"
    packed = tmp_path / "bs.net.xml.gz"
    packed.write_bytes(gzip.compress(plain.read_bytes()))
    a, b = read_net(plain), read_net(packed)
    assert a.lanes.keys() == b.lanes.keys() and a.turns == b.turns
    assert all(np.array_equal(a.lanes[k].shape_xy, b.lanes[k].shape_xy) for k in a.lanes)


def real_net_spec(lesson_plain: dict, net: Path, **traffic) -> dict:
    """The seed lesson on a route through ``net``, with random-trip traffic."""
    plain = lesson_plain
    plain["road"] = {"kind": "sumo_net", "net_file": str(net), "length_m": 300.0}
    plain["traffic"] = {"vehicles": 100, "speed_dev": 0.1, **traffic}
    plain["obstacles"] = [{"kind": "car", "lane": 0, "position_m": 150.0}]
    plain["ego"].update(lane=0, start_m=10.0, speed_mps=8.0)
    plain["scenario"].update(duration_s=5.0)
    return plain


def test_a_run_on_a_gzipped_network(lesson_plain):
    from scenarios.spec.scenario_spec import ScenarioSpec
    from sdc.run.episode import run_episode

    spec = ScenarioSpec.from_plain(real_net_spec(lesson_plain,
                                                 GAME_DIR / "fkk_in" / "ingolstadt.net.xml.gz"))
    row = run_episode(spec).row
    assert row["status"] == "ok" and row["network_vehicles"] >= 90


def test_a_broken_gzipped_network_is_bad_input_naming_the_file(tmp_path):
    from scenarios.common.errors import FileError

    broken = tmp_path / "x.net.xml.gz"
    broken.write_bytes((GAME_DIR / "fkk_in" / "ingolstadt.net.xml.gz").read_bytes()[:500])
    with pytest.raises(FileError, match="x.net.xml.gz.*gzip-compressed but cannot be unpacked"):
        read_net(broken)


@pytest.mark.parametrize("radius_m", [3.0, 5.0, 12.0, 40.0])
def test_the_tightest_radius_of_an_arc_is_its_radius(radius_m):
    from scenarios.sumo_net.route_drawing import tightest_radius_m

    angle = np.linspace(0.0, np.pi / 2, 200)
    arc = np.column_stack([radius_m * np.sin(angle), radius_m * (1 - np.cos(angle))])
    lead_in = np.array([[-20.0, 0.0]])
    assert tightest_radius_m(np.vstack([lead_in, arc]), 3.2) == pytest.approx(radius_m, rel=0.03)


def test_a_kink_is_a_turn_as_tight_as_its_angle_over_the_window():
    from scenarios.sumo_net.route_drawing import tightest_radius_m

    corner = np.array([[0.0, 0.0], [50.0, 0.0], [50.0, 50.0]])
    assert tightest_radius_m(corner, 3.0) == pytest.approx(3.0 / (np.pi / 2), rel=0.01)
    assert tightest_radius_m(np.array([[0.0, 0.0], [10.0, 0.0], [30.0, 0.0]]), 3.0) == np.inf


def turn_radii(net, lane, min_radius_m):
    """Each turn out of ``lane`` onto passenger lanes (no U-turn) with its tightest
    radius, measured as the route drawing measures it."""
    from scenarios.sumo_net.net_xml import U_TURN
    from scenarios.sumo_net.route_drawing import (
        TURN_REACH_M,
        TURN_WINDOW_M,
        tightest_radius_m,
        turn_path,
    )

    window_m = max(min_radius_m, TURN_WINDOW_M)
    return [(turn, tightest_radius_m(turn_path(net, lane, turn, TURN_REACH_M), window_m))
            for turn in net.turns.get(lane.id, ()) if turn.direction != U_TURN
            and all(net.lanes[v].passenger for v in (*turn.via, turn.to))]


X5_TURN_RADIUS_M = 2.995 / np.tan(0.75)  # wheelbase over the tangent of full lock


@pytest.mark.parametrize("name", REAL_NETWORKS)
def test_routes_on_real_networks_take_only_turns_and_lanes_a_car_can(name):
    """Drawn routes use lanes open to passenger cars only, and every turn on them is
    no tighter than the X5's turning circle."""
    from scenarios.spec.bodies import VEHICLE_MODELS
    from scenarios.sumo_net.route_drawing import ROUTE, draw_route, scenario_stream

    net = read_net(GAME_DIR / name)
    min_radius_m = VEHICLE_MODELS["x5-road"].min_turn_radius_m
    assert min_radius_m == pytest.approx(X5_TURN_RADIUS_M)
    for seed in range(10):
        route = draw_route(net, scenario_stream(seed, ROUTE), 300.0, "any", min_radius_m)
        assert all(lane.passenger for lane in route)
        normal = [i for i, lane in enumerate(route) if not lane.internal]
        for a, b in zip(normal, normal[1:], strict=False):
            via = tuple(lane.id for lane in route[a + 1:b])
            (radius_m,) = [r for t, r in turn_radii(net, route[a], min_radius_m)
                           if t.to == route[b].id and t.via == via]
            assert radius_m >= min_radius_m


@pytest.mark.parametrize("name", ["A10KW/osm.net.xml", "bs3d/bs.net.xml"])
def test_turns_tighter_than_the_car_can_drive_are_left_out(name):
    """The OSM networks hold junction paths tighter than an X5's turning circle
    (hairpins, kinked junction lanes); the route drawing leaves out exactly those."""
    from scenarios.sumo_net.route_drawing import drivable_turns

    net = read_net(GAME_DIR / name)
    tight = 0
    for lane in net.normal_lanes():
        kept = drivable_turns(net, lane, X5_TURN_RADIUS_M)
        for turn, radius_m in turn_radii(net, lane, X5_TURN_RADIUS_M):
            assert (turn in kept) == (radius_m >= X5_TURN_RADIUS_M)
            tight += radius_m < X5_TURN_RADIUS_M
    assert tight >= 10


#: centre-line points this close to a lane's start or end sit where it meets a
#: junction, whose outline's corners come closer than a lane's half width [m]
LANE_END_M = 3.0


def centre_points(lane, step_m: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Points every ``step_m`` along a lane's centre line, and their distance to the
    nearer of its ends."""
    along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(lane.shape_xy, axis=0).T))])
    at = np.arange(0.0, along[-1], step_m)
    points = np.column_stack([np.interp(at, along, lane.shape_xy[:, 0]),
                              np.interp(at, along, lane.shape_xy[:, 1])])
    return points, np.minimum(at, along[-1] - at)


def crossed_by_another_road(net, lane, point: np.ndarray) -> bool:
    """Does a lane of another road (not this lane's edge, not a junction lane) pass
    within a lane's width of ``point``: a bridge over it, or a road beside it that
    overlaps (a slip road merging), whose kerb lies across this lane in the plane?"""
    for other in net.lanes.values():
        if other.internal or other.edge == lane.edge:
            continue
        seg = other.shape_xy
        a, b = seg[:-1], seg[1:]
        ab = b - a
        t = np.clip(np.einsum("ij,ij->i", point - a, ab) / np.maximum(
            np.einsum("ij,ij->i", ab, ab), 1e-12), 0.0, 1.0)
        if np.min(np.hypot(*(a + t[:, None] * ab - point).T)) < lane.width_m:
            return True
    return False


@pytest.mark.parametrize("name, allowed", [("A10KW/osm.net.xml", 0.005),
                                           ("bs3d/bs.net.xml", 0.01),
                                           ("fkk_in/ingolstadt.net.xml.gz", 0.005),
                                           ("square/square.net.xml", 0.0)])
def test_road_edges_lie_where_the_lanes_end(name, allowed):
    """Every point of a lane open to cars lies in the drivable area; on lanes outside
    junctions, each is at least half the lane's width less 5 cm from the nearest road
    edge, but within 3 m of the lane's ends (junction corners) or where another road
    crosses or overlaps it in the plane (a bridge, a merging slip road). Those
    exceptions are a small share of the points (``allowed``), and counted."""
    from scenarios.sumo_net.route_road import network_area

    net = read_net(GAME_DIR / name)
    area = network_area(net)
    points_in_all = too_close = at_ends = crossed = 0
    for lane in net.lanes.values():
        if not lane.passenger:
            continue
        points, to_end_m = centre_points(lane)
        assert area.contains(points).all(), lane.id
        if lane.internal:
            continue
        points_in_all += len(points)
        close = area.edge_gaps_m(points) < lane.width_m / 2 - 0.05
        too_close += int(close.sum())
        at_ends += int((close & (to_end_m <= LANE_END_M)).sum())
        for point in points[close & (to_end_m > LANE_END_M)]:
            assert crossed_by_another_road(net, lane, point), (lane.id, point)
            crossed += 1
    assert too_close == at_ends + crossed
    assert too_close <= allowed * points_in_all, (too_close, points_in_all)


def test_a_pinned_route_is_driven_as_given():
    """The edges of a drawn route, pinned, give the same lanes back."""
    from scenarios.sumo_net.route_drawing import ROUTE, draw_route, pinned_route, scenario_stream

    net = read_net(GAME_DIR / "A10KW" / "osm.net.xml")
    for seed in range(5):
        route = draw_route(net, scenario_stream(seed, ROUTE), 400.0, "any", X5_TURN_RADIUS_M)
        edges = []
        for lane in route:
            if not lane.internal and (not edges or edges[-1] != lane.edge):
                edges.append(lane.edge)
        pinned = pinned_route(net, tuple(edges), X5_TURN_RADIUS_M)
        assert [lane.edge for lane in pinned] == [lane.edge for lane in route]


@pytest.mark.parametrize("edges, message", [
    (("6272844#4", "5067107#1"), "every turn from edge '6272844#4' to edge '5067107#1' is "
                                 "tighter than the car's turning circle"),
    (("6272844#4", "nowhere"), "edge 'nowhere' is not in the network"),
    (("6272844#4", "151495018"), "edge '6272844#4' does not lead to edge '151495018'"),
])
def test_a_pinned_route_a_car_cannot_drive_is_bad_input_naming_the_edge(edges, message):
    from scenarios.common.errors import SpecError
    from scenarios.sumo_net.route_drawing import pinned_route

    net = read_net(GAME_DIR / "A10KW" / "osm.net.xml")
    with pytest.raises(SpecError, match=message.replace("(", r"\(")) as raised:
        pinned_route(net, edges, X5_TURN_RADIUS_M)
    assert raised.value.field == "road.route_edges"


def test_the_command_line_names_a_bad_pinned_route(tmp_path, lesson_plain):
    from click.testing import CliRunner

    from scenarios.spec.toml_io import dumps_plain
    from sdc.cli import main

    plain = real_net_spec(lesson_plain, GAME_DIR / "A10KW" / "osm.net.xml")
    plain["road"]["route_edges"] = ["6272844#4", "5067107#1"]
    path = tmp_path / "pinned.toml"
    path.write_text(dumps_plain(plain))
    result = CliRunner().invoke(main, ["run", str(path)])
    assert result.exit_code == 2 and "road.route_edges" in result.output
    assert "'6272844#4'" in result.output and "Traceback" not in result.output


def loop_route(radius_m: float):
    """A 20 m straight lane, then a lane turning a full circle of ``radius_m``."""
    from scenarios.sumo_net.net_xml import NetLane

    theta = np.linspace(0.0, 2 * np.pi, 200)
    circle = np.column_stack([20.0 + radius_m * np.sin(theta), radius_m * (1 - np.cos(theta))])
    straight = np.array([[0.0, 0.0], [20.0, 0.0]])
    return [NetLane(name, name, 0, shape, 3.2, 1.0, False, True)
            for name, shape in (("a_0", straight), ("b_0", circle))]


@pytest.mark.parametrize("speed_mps, takes", [(5.0, True), (12.0, True), (16.0, True),
                                              (18.0, False), (25.0, False)])
def test_a_route_whose_start_bends_are_too_tight_for_the_start_speed_is_not_drawn(
        speed_mps, takes):
    """A 15 m loop 10 m ahead of the start, grip 8.8 m/s^2 and brakes of 8 m/s^2: the
    car brakes to v^2 - 2 * 8 * 10 by the loop, which takes sqrt(8.8 * 15) = 11.5 m/s:
    from up to 17.1 m/s."""
    from scenarios.sumo_net.route_drawing import takes_its_start

    route = loop_route(15.0)
    arrives_mps = np.sqrt(max(speed_mps**2 - 2 * 8.0 * 10.0, 0.0))
    assert (arrives_mps <= np.sqrt(8.8 * 15.0)) == takes
    assert takes_its_start(route, 10.0, speed_mps, 8.8, 8.0) == takes


def test_routes_drawn_on_the_motorway_start_where_the_car_can_take_the_bends():
    """On the A10 at 25 m/s the drawn route never starts on a ramp's loop; at walking
    pace any route will do."""
    from scenarios import ScenarioSpec
    from scenarios.spec.toml_io import read_toml
    from scenarios.sumo_net.route_drawing import takes_its_start
    from scenarios.world_backends import make_road

    plain = read_toml(Path(__file__).parents[1] / "scenarios/catalog/real-scenarios.toml")
    plain["obstacles"] = []
    for seed in range(12):
        plain["scenario"]["seed"] = seed
        plain["ego"]["speed_mps"] = 25.0
        road = make_road(ScenarioSpec.from_plain(plain))
        assert takes_its_start([p.lane for p in road.pieces], 10.0, 25.0, 0.9 * 9.81, 8.0)
