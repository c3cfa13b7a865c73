"""SUMO network files as roads: reading, drivable area and road edges, routes.
netconvert builds small networks; one whole run (marked slow) drives off the
network's end."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from scenarios import CATALOG_DIR, RoadSpec, ScenarioSpec, SpecError
from scenarios.scene.boxes import box_corners
from scenarios.scene.road_geometry import StraightRoad
from scenarios.spec.toml_io import load_spec
from scenarios.sumo_net.drivable_area import DrivableArea
from scenarios.sumo_net.net_xml import STRAIGHT, U_TURN, read_net
from scenarios.sumo_net.road_source import road_source
from scenarios.sumo_net.route_drawing import ROUTE, draw_route, scenario_stream
from scenarios.sumo_net.route_road import network_area
from scenarios.world_backends import make_road
from sdc.car.collision import ROAD_EDGE, collision_with
from sdc.car.geometry_kernels import Contacts

GRID_TOWN = CATALOG_DIR / "grid-town.toml"


@pytest.fixture(scope="module")
def town():
    spec = load_spec(GRID_TOWN)
    net = read_net(spec.road.net_file)
    return spec, net, network_area(net)


def test_the_catalog_grid_has_ten_by_ten_junctions_with_two_lanes_each_way(town):
    _, net, _ = town
    assert len(net.junction_shapes) == 100
    normal = net.normal_lanes()
    assert len({lane.edge for lane in normal}) == 2 * 2 * 10 * 9  # both ways, both axes
    assert {lane.index for lane in normal} == {0, 1}
    assert all(turn.via for turns in net.turns.values() for turn in turns)  # through a junction


def test_a_process_reads_a_network_once_and_no_run_can_change_it(town, tmp_path):
    spec, net, area = town
    again = read_net(spec.road.net_file)
    assert again is net and network_area(again) is area  # a worker's runs share them
    with pytest.raises(ValueError, match="read-only"):
        next(iter(net.lanes.values())).shape_xy[0, 0] = 0.0
    copy = tmp_path / "grid.net.xml"
    data = Path(spec.road.net_file).read_bytes()
    copy.write_bytes(data)
    first = read_net(copy)
    copy.write_bytes(data.replace(b"<net ", b"<!-- changed --><net ", 1))
    changed = read_net(copy)  # the same path, other bytes: read anew
    assert changed is not first and changed.sha256 != first.sha256


def test_our_own_straight_network_has_exactly_the_built_in_roads_edges(tmp_path):
    road_spec = RoadSpec(length_m=200.0, lanes=3, lane_width_m=3.5)
    area = network_area(read_net(road_source(road_spec).network_file(tmp_path)), tmp_path)
    road = StraightRoad.from_spec(road_spec)
    points = np.random.default_rng(0).uniform([20.0, -10.0], [180.0, 10.0], size=(2000, 2))
    np.testing.assert_allclose(area.edge_gaps_m(points), road.edge_gaps_m(points), atol=1e-6)
    np.testing.assert_array_equal(area.contains(points), ~road.off_road(points))
    np.testing.assert_array_equal(area.off_road(points), road.off_road(points))


def test_a_gap_between_lanes_too_narrow_for_an_edge_is_no_kerb():
    # two 3.2 m lanes side by side whose borders are 0.2 m apart (SUMO's shapes leave
    # such slivers): no edge between them, and a body corner in the gap is on the road
    lanes = [np.array([[0.0, 0.0], [100.0, 0.0]]), np.array([[0.0, 3.4], [100.0, 3.4]])]
    area = DrivableArea(lanes, [3.2, 3.2], [0, 1], [])
    between = np.array([[50.0, 1.7]])
    assert not area.contains(between).any() and not area.off_road(between).any()
    assert not np.any((area.edges[:, [1, 3]] > 1.0) & (area.edges[:, [1, 3]] < 2.4))
    beyond_kerb = np.array([[50.0, -1.65], [50.0, 5.05], [50.0, -3.0]])
    assert area.off_road(beyond_kerb).all()


def test_the_line_between_the_two_directions_is_not_a_road_edge(town):
    _, _, area = town
    # the street x = 0..1350 at y = 150: two lanes each way, 3.2 m wide, between junctions
    between_directions = np.array([[75.0, 150.0]])
    assert area.contains(between_directions).all()
    assert area.edge_gaps_m(between_directions)[0] == pytest.approx(6.4)
    kerb_side = np.array([[75.0, 150.0 + 6.3], [75.0, 150.0 + 6.5]])
    np.testing.assert_allclose(area.edge_gaps_m(kerb_side), [0.1, -0.1], atol=1e-9)


def test_collision_finds_a_kerb_but_not_the_opposite_lanes_or_a_junction(town):
    _, _, area = town
    spec = load_spec(GRID_TOWN)
    road = make_road(spec)

    def hit(cx, cy, yaw):
        return collision_with(np.array([cx, cy, yaw, 4.85, 1.93]),
                              Contacts(-1, -1, math.inf), road)

    assert hit(75.0, 150.0 - 1.6, 0.0) is None  # in a lane
    assert hit(75.0, 150.0, 0.0) is None  # astride the two directions
    assert hit(150.0, 150.0, 0.7) is None  # diagonally in a junction
    assert hit(75.0, 150.0 - 6.0, 0.0) == ROAD_EDGE  # over the kerb
    assert hit(75.0, 75.0, 0.0) == ROAD_EDGE  # inside a block
    rng = np.random.default_rng(1)
    centres = road.xy_at(rng.uniform(-10.0, road.length_m + 10.0, 500),
                         rng.uniform(-8.0, 8.0, 500))
    corners = box_corners(np.column_stack([centres, rng.uniform(-math.pi, math.pi, 500),
                                           np.full(500, 4.85), np.full(500, 1.93)]))
    answers = set()
    for points in corners:  # the step's question, against the area's mask
        s_m, _ = road.to_frenet(points)
        expected = bool((road.off_road(points) & (s_m < road.length_m)).any())
        assert road.any_off_road(points) is expected
        answers.add(expected)
    assert answers == {True, False}


def test_routes_are_connected_long_enough_seeded_and_without_u_turns(town):
    _, net, _ = town
    routes = {}
    for seed in range(8):
        route = draw_route(net, scenario_stream(seed, ROUTE), 400.0, "any")
        assert sum(lane.length_m for lane in route) >= 400.0
        for a, b in zip(route, route[1:], strict=False):
            assert np.hypot(*(a.shape_xy[-1] - b.shape_xy[0])) < 0.01  # end meets start
        normal = [lane for lane in route if not lane.internal]
        for a, b in zip(normal, normal[1:], strict=False):
            (turn,) = [t for t in net.turns[a.id] if t.to == b.id]
            assert turn.direction != U_TURN
        routes[seed] = [lane.id for lane in route]
        again = draw_route(net, scenario_stream(seed, ROUTE), 400.0, "any")
        assert [lane.id for lane in again] == routes[seed]
    assert len({tuple(r) for r in routes.values()}) == len(routes)


def test_straight_routes_turn_only_where_they_must(town):
    _, net, _ = town
    turned = 0
    for seed in range(20):
        route = draw_route(net, scenario_stream(seed, ROUTE), 600.0, "straight")
        normal = [lane for lane in route if not lane.internal]
        for a, b in zip(normal, normal[1:], strict=False):
            (turn,) = [t for t in net.turns[a.id] if t.to == b.id]
            if turn.direction != STRAIGHT:
                turned += 1
                assert not any(t.direction == STRAIGHT for t in net.turns[a.id])
    assert turned > 0  # some routes meet the town's edge


def test_an_obstacle_on_a_junction_moves_onto_the_next_lane(town):
    spec = load_spec(GRID_TOWN)
    road = make_road(spec)
    junction = next(p for p in road.pieces if p.lane.internal)
    inside = junction.start_s_m + junction.length_m / 2
    placed = road.place_s_m(inside, 4.5)
    assert not road.piece_at(placed).lane.internal
    assert placed > inside
    lane_s = 0.5 * (road.pieces[0].start_s_m + road.pieces[0].length_m)
    assert road.place_s_m(lane_s, 4.5) == lane_s


@pytest.mark.parametrize("length_m", [0.6, 4.5, 12.0])
def test_a_body_stands_whole_on_a_lane_off_the_junctions_at_both_its_ends(town, length_m):
    """Asked anywhere along the route, a body stands with both its ends on one lane
    (the town's lanes are long enough), and one moved off a junction stands
    JUNCTION_CLEARANCE_M off it: SUMO holds stops on lanes only, and never inserted a
    stopped car reaching back into a junction (SUMO's Braunschweig: its traffic drove
    through ours)."""
    from scenarios.sumo_net.route_road import JUNCTION_CLEARANCE_M

    road = make_road(load_spec(GRID_TOWN))
    for asked_m in np.arange(length_m, road.length_m - length_m, 0.25):
        s_m = road.place_s_m(float(asked_m), length_m)
        piece = road.piece_at(s_m)
        start_m, end_m = piece.start_s_m, piece.start_s_m + piece.length_m
        assert not piece.lane.internal
        assert start_m - 1e-9 <= s_m - length_m / 2 < s_m + length_m / 2 <= end_m + 1e-9
        if s_m != asked_m:
            gaps_m = (s_m - length_m / 2 - start_m, end_m - s_m - length_m / 2)
            assert min(gaps_m) == pytest.approx(JUNCTION_CLEARANCE_M), asked_m


def test_a_relative_net_file_is_read_from_the_scenario_folder(tmp_path):
    spec = load_spec(GRID_TOWN)
    assert spec.road.net_file == str((CATALOG_DIR / "networks" / "grid-10x10.net.xml").resolve())
    moved = tmp_path / "town.toml"
    moved.write_text(GRID_TOWN.read_text())
    with pytest.raises(SpecError, match=r"road\.net_file: no such file"):
        make_road(load_spec(moved))


@pytest.mark.parametrize("change, field", [
    ({"road": {"net_file": None}}, "road.net_file"),
    ({"road": {"lanes": 2}}, "road.lanes"),
    ({"traffic": {"flow_vph_per_lane": 300.0}}, "traffic.flow_vph_per_lane"),
    ({"scenario": {"backend": "highway"}}, "scenario.backend"),
    ({"ego": {"lane": 1}}, "ego.lane"),
])
def test_sumo_net_spec_errors_name_the_field(change, field):
    spec = load_spec(GRID_TOWN)
    plain = spec.to_plain()
    for table, values in change.items():
        plain[table].update(values)
        plain[table] = {k: v for k, v in plain[table].items() if v is not None}
    with pytest.raises(SpecError, match=field.replace(".", r"\.")):
        type(spec).from_plain(plain)


def test_built_in_roads_refuse_network_fields():
    spec = load_spec(CATALOG_DIR / "seed-lesson.toml")
    for table, values, field in [("traffic", {"vehicles": 10}, "traffic.vehicles"),
                                 ("road", {"net_file": "x.net.xml"}, "road.net_file")]:
        plain = spec.to_plain()
        plain[table].update(values)
        with pytest.raises(SpecError, match=field.replace(".", r"\.")):
            type(spec).from_plain(plain)
    plain = spec.to_plain()
    del plain["road"]["lanes"]
    with pytest.raises(SpecError, match=r"road\.lanes: is required"):
        type(spec).from_plain(plain)


def test_a_crowd_of_overlapping_lanes_still_finds_the_lane_a_point_is_on():
    """Twenty lanes stacked on one another, then a lane beside them: a point on
    the last one has more lane pieces near it than one lookup returns."""
    from scenarios.sumo_net.drivable_area import DrivableArea

    stacked = [np.array([[47.5, 1.2], [52.5, 1.2]])] * 20  # each one piece, centred at x 50
    beside = np.array([[0.0, 4.0], [100.0, 4.0]])  # its pieces' midpoints are farther away
    area = DrivableArea([*stacked, beside], [3.2] * 21, [20], [])
    assert area.contains(np.array([[50.0, 3.2], [50.0, 2.0], [50.0, 5.8]])).tolist() == [
        True, True, False]


def test_a_bad_network_file_is_bad_input_for_run_and_sweep(tmp_path):
    from click.testing import CliRunner

    from sdc.cli import main

    (tmp_path / "routes.net.xml").write_text("<routes/>\n")
    scenario = tmp_path / "town.toml"
    scenario.write_text(GRID_TOWN.read_text().replace("networks/grid-10x10.net.xml",
                                                      "routes.net.xml"))
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(f'[sweep]\nname = "x"\nbase = "{scenario}"\nsamples = 2\n'
                     '[sweep.params]\n"ego.speed_mps" = { uniform = [3.0, 5.0] }\n')
    for args in (["run", str(scenario)], ["sweep", str(sweep), "--out", str(tmp_path / "o")]):
        result = CliRunner().invoke(main, args)
        assert result.exit_code == 2, result.output
        assert "road.net_file" in result.stderr and "not a SUMO network" in result.stderr


def test_network_errors_name_the_scenario_file_the_field_and_the_network_as_written(
        tmp_path, monkeypatch):
    from click.testing import CliRunner

    from sdc.cli import main

    monkeypatch.chdir(tmp_path)
    (tmp_path / "nets").mkdir()
    (tmp_path / "nets" / "broken.net.xml").write_text("<net><edge")
    sweep = tmp_path / "sweep.toml"
    sweep.write_text('[sweep]\nname = "x"\nbase = "town.toml"\nsamples = 2\n'
                     '[sweep.params]\n"ego.speed_mps" = { uniform = [3.0, 5.0] }\n')
    for net, problem in [("nets/missing.net.xml", "no such file: nets/missing.net.xml"),
                         ("nets/broken.net.xml", "nets/broken.net.xml: the SUMO network is "
                                                 "not well-formed XML (unclosed token")]:
        (tmp_path / "town.toml").write_text(
            GRID_TOWN.read_text().replace("networks/grid-10x10.net.xml", net))
        ran = CliRunner().invoke(main, ["run", "town.toml"])
        assert ran.exit_code == 2 and ran.stderr.startswith(
            f"error: town.toml: road.net_file: {problem}")
        swept = CliRunner().invoke(main, ["sweep", "sweep.toml", "--dry-run"])
        assert swept.exit_code == 2 and swept.stderr.startswith(
            f"error: sweep.toml: sweep.base: town.toml: road.net_file: {problem}")


def test_a_lane_off_a_network_route_says_its_lane_is_0():
    plain = load_spec(GRID_TOWN).to_plain()
    plain["obstacles"][0]["lane"] = 5
    with pytest.raises(SpecError) as raised:
        ScenarioSpec.from_plain(plain)
    assert str(raised.value) == (
        'obstacles[0].lane: 5, but a "sumo_net" road is the ego\'s route, one lane: every lane '
        "index is 0 (a body beside the route: lateral_offset_m, + to the left)")


def dead_end_road(tmp_path) -> tuple[dict, object]:
    """A sumo_net road on a network of one straight 200 m two-lane edge: its route
    ends where the network does (SUMO's vehicles leave it there)."""
    net = road_source(RoadSpec(length_m=200.0, lanes=2, lane_width_m=3.5)).network_file(tmp_path)
    plain = load_spec(GRID_TOWN).to_plain()
    plain["road"].update(net_file=str(net), length_m=150.0)
    return plain, make_road(ScenarioSpec.from_plain(plain))


def test_past_the_end_of_a_route_that_leaves_the_network_is_no_kerb(tmp_path):
    _, road = dead_end_road(tmp_path)
    assert road.length_m == pytest.approx(200.0)
    lane_y = float(road.center_xy[0, 1])

    def hit(cx, cy):
        return collision_with(np.array([cx, cy, 0.0, 4.85, 1.93]), Contacts(-1, -1, math.inf),
                              road)

    assert hit(200.5, lane_y) is None  # its front 2.9 m out of the network
    assert hit(190.0, lane_y - 2.0) == ROAD_EDGE  # over the side kerb before the end
    assert hit(199.0, lane_y - 2.0) == ROAD_EDGE  # ... and at the end


@pytest.mark.slow
def test_a_route_that_leaves_the_network_ends_the_run_without_a_made_up_kerb(tmp_path):
    """At 25 m/s the front moves 2.5 m a step: out of the network's last lane before
    the route's end is checked, where no kerb stands."""
    from sdc.run.episode import run_episode

    plain, _ = dead_end_road(tmp_path)
    plain["traffic"].update(vehicles=0, warm_up_s=0.0)
    plain["obstacles"] = []
    plain["ego"].update(lane=0, start_m=20.0, speed_mps=25.0)
    plain["scenario"].update(step_s=0.1, duration_s=20.0)
    plain["controller"] = {"name": "lane-keep"}
    row = run_episode(ScenarioSpec.from_plain(plain)).row
    assert row["collision_with"] == "none"
    assert row["termination"] == "route_end"


def test_the_lanes_beside_are_the_edges_next_lanes_open_to_cars(town):
    spec, net, _ = town
    road = make_road(spec)
    left, right = road.lanes_beside(0)
    places = {(lane.edge, lane.index): lane for lane in net.lanes.values()}
    for piece in road.pieces:  # brute force: each piece's middle against the network
        middle = piece.start_s_m + piece.length_m / 2
        for stretches, step in ((left, 1), (right, -1)):
            beside = places.get((piece.lane.edge, piece.lane.index + step))
            expected = beside is not None and beside.passenger
            inside = bool(np.any((stretches[:, 0] <= middle) & (middle <= stretches[:, 1])))
            assert inside == expected, (piece.lane.id, step)
    assert len(left) and np.all(np.diff(left.ravel()) > 0)  # in order, apart


def test_a_built_in_roads_lanes_beside_run_its_whole_length():
    road = StraightRoad.from_spec(RoadSpec(length_m=200.0, lanes=3, lane_width_m=3.5))
    left, right = road.lanes_beside(0)
    assert left.tolist() == [[0.0, 200.0]] and right.size == 0
    left, right = road.lanes_beside(2)
    assert left.size == 0 and right.tolist() == [[0.0, 200.0]]


def test_the_map_gives_how_far_the_lane_beside_runs_on():
    from sdc.run.lanes_beside import LanesBesideMap

    beside = LanesBesideMap((np.array([[0.0, 50.0], [80.0, 120.0]]), np.empty((0, 2))))
    assert beside.at(10.0) == (40.0, 0.0)
    assert beside.at(60.0) == (0.0, 0.0)  # a stretch without
    assert beside.at(100.0) == (20.0, 0.0)
    assert beside.at(None) is None
