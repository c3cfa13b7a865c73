"""One world on city lanes: the straddle rule on every lane width SUMO networks use
(2.8-3.75 m), for traffic of any width, on the built-in roads and on networks (a
configuration built here with netconvert, its own flows in both lanes).

The world is judged with our own geometry (an independent check of what SUMO did):
no traffic body overlaps the ego or an obstacle, and one passing beside keeps
``PASS_CLEARANCE_M``.
"""

from __future__ import annotations

import functools
import subprocess
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pytest

from scenarios.scene import traffic_model
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.sumo.routes_xml import TRAFFIC_WIDTH_M, lanes_blocked
from scenarios.sumo.sumo_world import SumoWorld
from scenarios.sumo_net.build import sumo_binary
from scenarios.sumo_net.road_source import road_source
from scenarios.world_backends import make_road
from sdc.car.geometry import box_gap_m, boxes_overlap
from sdc.run.episode import run_episode

X5_LENGTH_M, X5_WIDTH_M = 4.85, 1.93
WIDTHS_M = (2.8, 3.0, 3.2, 3.5, 3.75)
CAR = '<vType id="c" speedFactor="normc(1,0.1,0.2,2)"/>'
TRUCK = ('<vType id="c" length="7.1" width="2.5" vClass="truck" '
         'speedFactor="normc(1,0.1,0.2,2)"/>')


def city_config(folder: Path, width_m: float, vtype: str = CAR, edge_m: int = 100,
                edges: int = 10, flow_lanes: tuple[int, ...] = (0, 1)) -> tuple[Path, list[str]]:
    """A straight two-lane street of ``edges`` edges ``edge_m`` long, lanes ``width_m``
    wide, joined at priority junctions, 600 veh/h of ``vtype`` entering each of
    ``flow_lanes`` at its start: its configuration and its edges."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "x.nod.xml").write_text("<nodes>" + "".join(
        f'<node id="n{i}" x="{i * edge_m}" y="0" type="priority"/>'
        for i in range(edges + 1)) + "</nodes>")
    (folder / "x.edg.xml").write_text("<edges>" + "".join(
        f'<edge id="e{i}" from="n{i}" to="n{i + 1}" numLanes="2" width="{width_m}" '
        'speed="33.33"/>' for i in range(edges)) + "</edges>")
    subprocess.run([sumo_binary("netconvert"), "-n", "x.nod.xml", "-e", "x.edg.xml",
                    "-o", "x.net.xml", "--no-turnarounds", "true"],
                   cwd=folder, check=True, capture_output=True)
    route = [f"e{i}" for i in range(edges)]
    (folder / "x.rou.xml").write_text(
        f'<routes>{vtype}<route id="r" edges="{" ".join(route)}"/>' + "".join(
            f'<flow id="f{lane}" type="c" route="r" begin="0" end="3600" vehsPerHour="600" '
            f'departLane="{lane}" departSpeed="max"/>' for lane in flow_lanes) + "</routes>")
    (folder / "x.sumocfg").write_text(
        '<configuration><input><net-file value="x.net.xml"/>'
        '<route-files value="x.rou.xml"/></input></configuration>')
    return folder / "x.sumocfg", route


@pytest.fixture(scope="module")
def city_configs(tmp_path_factory):
    """:func:`city_config` built once per set of arguments in this module (the tests
    only read its files): ``city_configs(width_m, ...)``."""
    @functools.cache
    def config(width_m: float, vtype: str = CAR, **kwargs) -> tuple[Path, list[str]]:
        return city_config(tmp_path_factory.mktemp("city"), width_m, vtype, **kwargs)
    return config


def city_spec(lesson_plain: dict, config: Path, route: list[str], *, seed: int,
              obstacles=(), ego_start_m: float = 200.0, duration_s: float = 60.0
              ) -> ScenarioSpec:
    """The ego on the street's right lane (a network's route is its edges' rightmost
    lane), entering one step after its flows begin."""
    plain = lesson_plain
    plain["scenario"].update(seed=seed, duration_s=duration_s, step_s=0.1)
    plain["road"] = {"kind": "sumo_config", "config_file": str(config), "length_m": 700.0,
                     "route_edges": route}
    plain["traffic"] = {"enter_s": 0.1}
    plain["obstacles"] = list(obstacles)
    plain["ego"].update(lane=0, start_m=ego_start_m, speed_mps=0.0)
    plain["controller"] = {"name": "lane-keep"}
    return ScenarioSpec.from_plain(plain)


def straight_spec(lesson_plain: dict, width_m: float, *, seed: int, lane: int = 0,
                  lanes: int = 2) -> ScenarioSpec:
    """A straight built-in road of ``lanes`` lanes ``width_m`` wide, traffic at 27 m/s in
    every lane from its start, 200 m behind the ego in ``lane``."""
    plain = lesson_plain
    plain["scenario"].update(seed=seed, duration_s=60.0, step_s=0.1)
    plain["road"].update(length_m=1000.0, lanes=lanes, lane_width_m=width_m,
                         speed_limit_mps=33.33)
    plain["traffic"] = {"flow_vph_per_lane": 600.0, "speed_mean_mps": 27.0,
                        "speed_dev": 0.1}
    plain["obstacles"] = []
    plain["ego"].update(lane=lane, start_m=200.0, speed_mps=0.0)
    plain["controller"] = {"name": "lane-keep"}
    return ScenarioSpec.from_plain(plain)


class Straddled(NamedTuple):
    """What happened around an ego reaching over a lane line."""

    through: int  # steps in which a traffic body overlapped the ego (boxes_overlap)
    least_m: float  # the least gap to a body beside it in the lane it reaches into
    beside: int  # steps a body was beside it in that lane
    behind: int  # steps a body was in that lane within 30 m behind it


def straddled(road, box: np.ndarray, side: int, lane_line_d_m: float,
              traffic: np.ndarray, seen: Straddled) -> Straddled:
    """``seen`` with one more step: the ego at ``box`` reaching over the lane line at
    ``lane_line_d_m`` on its ``side``, the step's ``traffic`` boxes."""
    if not len(traffic):
        return seen
    through = int(boxes_overlap(box, traffic).any())
    (ego_s,), _ = road.to_frenet(box[None, :2])
    other_s, other_d = road.to_frenet(traffic[:, :2])
    over = side * (other_d - lane_line_d_m) > 0  # centres in the lane it reaches into
    ahead_m = other_s - ego_s
    side_by_side = over & (np.abs(ahead_m) < (box[3] + traffic[:, 3]) / 2)
    close_behind = over & (ahead_m < 0) & (ahead_m > -30.0 - box[3])
    least_m = seen.least_m
    if side_by_side.any():
        least_m = min(least_m, float(box_gap_m(box, traffic[side_by_side]).min()))
    return Straddled(seen.through + through, least_m, seen.beside + int(side_by_side.any()),
                     seen.behind + int(close_behind.any()))


def straddle(spec: ScenarioSpec, reach_m: float, side: int = 1, speed_mps: float = 8.0,
             steps: int = 350, ramp_s: float = 0.0, line_side: int | None = None,
             from_reach_m: float | None = None) -> Straddled:
    """The world driven directly: the ego at ``speed_mps`` from its start, its body
    ``reach_m`` over its lane's left (``side`` 1) or right (-1) line, placed there from
    the start (``ramp_s`` 0) or moved there from its lane's centre over ``ramp_s``.
    ``line_side`` -``side``: the line is its lane's other one, and the ego, past it in
    the lane beside, reaches back over it into its own lane (a pass); ``from_reach_m``:
    the ramp starts with the body that far over the line (negative: short of it), not
    at its lane's centre."""
    road = make_road(spec)
    lane_d_m = road.lane_center_d_m(spec.ego.lane)
    width_m, _ = road.lane_widths_m(spec.ego.start_m, spec.ego.lane)
    line_d_m = lane_d_m + (line_side or side) * width_m / 2
    held_d_m = line_d_m + side * (reach_m - X5_WIDTH_M / 2)
    from_d_m = (lane_d_m if from_reach_m is None
                else line_d_m + side * (from_reach_m - X5_WIDTH_M / 2))
    s_m, t_s, step_s = spec.ego.start_m, 0.0, spec.scenario.step_s

    def box_at() -> np.ndarray:
        d_m = from_d_m + (held_d_m - from_d_m) * (min(t_s / ramp_s, 1.0) if ramp_s else 1.0)
        return np.array([*road.xy_at(s_m, d_m), float(road.heading_at(s_m)), X5_LENGTH_M,
                         X5_WIDTH_M])

    seen = Straddled(0, np.inf, 0, 0)
    with SumoWorld(spec, road, source=road_source(spec.road)) as world:
        world.start(box_at(), speed_mps)
        for _ in range(steps):
            s_m, t_s = s_m + speed_mps * step_s, t_s + step_s
            box = box_at()
            traffic = world.step(box, speed_mps).traffic_boxes
            seen = straddled(road, box, side, line_d_m, traffic, seen)
    return seen


def assert_one_world(seen: Straddled, blocks: bool, case) -> None:
    """No traffic through the ego, 0.3 m kept by every body beside it, and the case
    happened: traffic came up in the lane it reaches into and queued behind it where
    it blocks that lane, and passed beside it where it does not."""
    assert seen.through == 0, (case, seen)
    assert seen.least_m >= traffic_model.PASS_CLEARANCE_M - 1e-3, (case, seen)
    if blocks:
        assert seen.behind > 0, (case, seen)
    else:
        assert seen.beside > 0, (case, seen)


# ---------------------------------------------------------------- the rule, as numbers


@pytest.mark.parametrize("width_m", [2.5, *WIDTHS_M, 4.0])
@pytest.mark.parametrize("traffic_width_m", [1.8, 2.55])
def test_a_lane_is_shown_blocked_exactly_where_its_widest_traffic_lacks_the_clearance(
        width_m, traffic_width_m):
    for reach_m in np.arange(0.011, 1.2, 0.0437):  # never on the boundary itself
        room_m = (width_m - traffic_width_m) / 2 - reach_m  # a car at its centre
        blocks = traffic_model.blocks_neighbour(reach_m, width_m, traffic_width_m)
        assert blocks == (room_m < traffic_model.PASS_CLEARANCE_M), (reach_m, room_m)


def test_no_lane_beside_is_nothing_to_block():
    # a body 0.8 m over its lane's left line where its edge has no lane to the left
    assert traffic_model.sides_blocked(-0.2, 2.4, 0.0, 3.2, 1.8, (3.2, None)) == (False, False)
    assert traffic_model.sides_blocked(-0.2, 2.4, 0.0, 3.2, 1.8, (3.2, 2.8)) == (False, True)


def test_a_lane_beside_is_judged_by_its_own_width():
    # 0.45 m into a 3.5 m lane leaves a car 0.4 m; into a 3.0 m lane, 0.15 m
    for beside_m, blocks in ((3.5, False), (3.0, True)):
        assert traffic_model.sides_blocked(-0.5, 1.85, 0.0, 2.8, 1.8, (None, beside_m)) == (
            False, blocks)


@pytest.mark.parametrize("width_m", [2.5, 2.8, 3.2, 3.75])
def test_sumo_is_shown_every_body_inside_one_lane_and_a_stand_in_beside(width_m):
    for centre_m in np.linspace(-1.5, 1.5, 31):
        lateral_m = traffic_model.inside_lane_m(centre_m, 0.0, width_m, X5_WIDTH_M)
        assert abs(lateral_m) + X5_WIDTH_M / 2 <= width_m / 2 + 1e-9 or lateral_m == 0.0
        if abs(centre_m) + X5_WIDTH_M / 2 <= width_m / 2:
            assert lateral_m == pytest.approx(centre_m)  # where it is when it is inside
    for side in (-1, 1):  # the stand-in: inside the lane beside, at the shared line
        for beside_m in (2.8, 3.5):
            lateral_m = traffic_model.stand_in_lateral_m(side, 0.0, width_m, beside_m,
                                                         X5_WIDTH_M)
            near_line_m = side * (lateral_m - side * X5_WIDTH_M / 2)
            assert near_line_m == pytest.approx(width_m / 2)
    # wider than its lane: at the lane's centre
    assert traffic_model.inside_lane_m(0.4, 0.0, 1.8, X5_WIDTH_M) == 0.0


def test_a_networks_lanes_are_as_wide_as_its_file_says(city_configs, lesson_plain):
    config, route = city_configs(2.9)
    road = make_road(city_spec(lesson_plain, config, route, seed=1))
    width_m, (right_m, left_m) = road.lane_widths_m(300.0, 0)
    assert (width_m, right_m, left_m) == (pytest.approx(2.9), None, pytest.approx(2.9))

    def box_at(d_m: float, width_m: float = 1.8) -> np.ndarray:
        return np.array([*road.xy_at(300.0, d_m), float(road.heading_at(300.0)), 4.5, width_m])

    assert lanes_blocked(road, box_at(1.0), 0, 1.8) == [1]  # 0.45 m in: 0.1 m to pass
    assert lanes_blocked(road, box_at(0.75), 0, 1.8) == []  # 0.2 m in: 0.35 m to pass
    assert lanes_blocked(road, box_at(0.75), 0, 2.5) == [1]  # but not for a truck
    assert lanes_blocked(road, box_at(-1.0), 0, 2.5) == []  # no lane on its right


# ---------------------------------------------------------------- SUMO, in a real libsumo


def test_the_straddle_check_counts_a_body_through_the_ego(lesson_plain):
    """The check itself can fail: a car driving into the ego counts, one beside it
    at 0.1 m lowers the least gap, one 10 m behind in that lane counts as behind."""
    road = make_road(straight_spec(lesson_plain, 2.8, seed=1))
    line_d_m = road.lane_center_d_m(0) + 1.4
    ego = np.array([*road.xy_at(300.0, line_d_m + 0.5 - X5_WIDTH_M / 2), 0.0, X5_LENGTH_M,
                    X5_WIDTH_M])

    def car(s_m: float, d_m: float) -> np.ndarray:
        return np.array([[*road.xy_at(s_m, d_m), 0.0, 4.5, 1.8]])

    empty = Straddled(0, np.inf, 0, 0)
    into = straddled(road, ego, 1, line_d_m, car(301.0, line_d_m + 0.8), empty)
    assert into.through == 1 and into.least_m == 0.0 and into.beside == 1
    grazing = straddled(road, ego, 1, line_d_m, car(300.0, line_d_m + 0.5 + 0.1 + 0.9),
                        empty)
    assert grazing.through == 0 and grazing.least_m == pytest.approx(0.1)
    queued = straddled(road, ego, 1, line_d_m, car(290.0, line_d_m + 1.4), empty)
    assert (queued.through, queued.beside, queued.behind) == (0, 0, 1)
    other_side = straddled(road, ego, -1, line_d_m - 2.8, car(290.0, line_d_m + 1.4), empty)
    assert other_side.behind == 0


@pytest.mark.slow
@pytest.mark.parametrize("width_m", [2.5, *WIDTHS_M, 4.0])
def test_the_straddle_test_on_every_lane_width(lesson_plain, width_m):
    """The ego 0.2-0.9 m over its lane's left or right line at 8 m/s, placed there or
    moved there over 3 s, traffic at 27 m/s from behind in both lanes (in the lane it
    reaches into from the start, and changing into it from the ego's): over 20 seeds
    no car drives through the ego, every car beside it keeps 0.3 m, cars pass where
    the reach leaves them room and queue behind where it does not."""
    import copy
    for seed in range(20):
        reach_m, side = 0.2 + 0.7 * seed / 19, 1 if seed % 2 == 0 else -1
        ramp_s = 3.0 if seed % 4 >= 2 else 0.0
        spec = straight_spec(copy.deepcopy(lesson_plain), width_m, seed=seed,
                             lane=0 if side > 0 else 1)
        seen = straddle(spec, reach_m, side, ramp_s=ramp_s)
        blocks = traffic_model.blocks_neighbour(reach_m, width_m, TRAFFIC_WIDTH_M)
        assert_one_world(seen, blocks, (width_m, seed, reach_m, side, ramp_s))


@pytest.mark.slow
@pytest.mark.parametrize("width_m", [2.8, 3.2, 3.75])
def test_trucks_on_city_lanes_pass_a_straddling_ego_only_with_the_clearance(
        city_configs, lesson_plain, width_m):
    """A network's own flows of 2.5 m trucks in both lanes: the ego 0.1-0.9 m over its
    left lane line (a network's route is its rightmost lane) is shown in the lane it
    reaches into as soon as a truck would pass it with less than 0.3 m."""
    import copy
    config, route = city_configs(width_m, TRUCK)
    for reach_m in (0.1, 0.3, 0.5, 0.9):
        spec = city_spec(copy.deepcopy(lesson_plain), config, route, seed=1)
        seen = straddle(spec, reach_m, 1, ramp_s=2.0)
        assert_one_world(seen, traffic_model.blocks_neighbour(reach_m, width_m, 2.5),
                         (width_m, reach_m))


@pytest.mark.slow
@pytest.mark.parametrize("width_m", [2.8, 3.2])
def test_traffic_changing_into_the_lane_the_ego_reaches_into_stays_behind_it(
        city_configs, lesson_plain, width_m):
    """Traffic only in the ego's lane: every car in the lane it reaches into changed
    lanes to get there, behind the ego (in SUMO, behind its stand-in), never into it."""
    import copy
    config, route = city_configs(width_m, flow_lanes=(0,))
    for seed, reach_m in ((1, 0.5), (2, 0.8)):
        spec = city_spec(copy.deepcopy(lesson_plain), config, route, seed=seed)
        seen = straddle(spec, reach_m, 1, ramp_s=2.0)
        assert_one_world(seen, True, (width_m, seed, reach_m))


@pytest.mark.slow
def test_sumo_has_a_leader_for_the_car_behind_the_part_that_blocks_its_lane(lesson_plain):
    """libsumo's own view (the defect: the car in the lane the ego reached into had no
    leader at any step and drove into it): a car in that lane behind the ego has a
    leader no farther than the ego's rear, and it is no car of the traffic."""
    import libsumo

    spec = straight_spec(lesson_plain, 2.8, seed=94665)
    road = make_road(spec)
    d_m = road.lane_center_d_m(0) + 1.4 + 0.6 - X5_WIDTH_M / 2
    s_m, checked = 200.0, 0
    with SumoWorld(spec, road, source=road_source(spec.road)) as world:
        world.start(np.array([*road.xy_at(s_m, d_m), 0.0, X5_LENGTH_M, X5_WIDTH_M]), 8.0)
        for _ in range(300):
            s_m += 0.8
            world.step(np.array([*road.xy_at(s_m, d_m), 0.0, X5_LENGTH_M, X5_WIDTH_M]), 8.0)
            for vid in libsumo.vehicle.getIDList():
                pos_m = libsumo.vehicle.getLanePosition(vid)
                if (vid.startswith("traffic") and libsumo.vehicle.getLaneID(vid) == "road_1"
                        and s_m - 60.0 < pos_m < s_m - X5_LENGTH_M):
                    leader = libsumo.vehicle.getLeader(vid, 100.0)
                    assert leader is not None and leader[0], (vid, pos_m, s_m)
                    front_of_leader_m = pos_m + leader[1] + libsumo.vehicle.getMinGap(vid)
                    assert front_of_leader_m <= s_m - X5_LENGTH_M + 1e-6 or \
                        not leader[0].startswith("traffic"), (vid, leader)
                    checked += 1
    assert checked > 50  # cars came up behind it in that lane


@pytest.mark.slow
@pytest.mark.parametrize("width_m, reach_m, side", [(2.8, 0.6, 1), (3.2, 0.8, -1),
                                                     (3.75, 0.3, 1)])
def test_an_ego_steered_over_a_lane_line_by_its_controller(lesson_plain, width_m, reach_m,
                                                            side):
    """A plug-in steers the ego over the line and holds it (examples/straddler.py):
    the run's own collision check and the trace agree, no traffic goes into it."""
    import copy
    plain = copy.deepcopy(lesson_plain)
    spec = straight_spec(plain, width_m, seed=94665, lane=0 if side > 0 else 1)
    spec = ScenarioSpec.from_plain({**spec.to_plain(), "controller": {
        "name": f"{Path(__file__).parents[1] / 'examples' / 'straddler.py'}:Straddler",
        "reach_m": reach_m, "side": side, "speed_mps": 8.0}})
    episode = run_episode(spec)
    assert episode.row["status"] == "ok" and episode.row["collision"] is False, episode.row
    assert episode.row["world_overlaps"] == 0
    road = make_road(spec)
    line_d_m = road.lane_center_d_m(spec.ego.lane) + side * width_m / 2
    seen, reached = Straddled(0, np.inf, 0, 0), 0
    floats = episode.trace.floats
    for k, traffic in enumerate(episode.trace.traffic):
        box = np.array([floats["x_m"][k], floats["y_m"][k], floats["yaw_rad"][k],
                        X5_LENGTH_M, X5_WIDTH_M])
        (_,), (d_m,) = road.to_frenet(box[None, :2])
        reached += side * (d_m + side * X5_WIDTH_M / 2 - line_d_m) > reach_m - 0.15
        seen = straddled(road, box, side, line_d_m,
                         np.asarray(traffic, float).reshape(-1, 5), seen)
    assert reached > 200  # it did reach over and hold there
    assert_one_world(seen, traffic_model.blocks_neighbour(reach_m, width_m, TRAFFIC_WIDTH_M),
                     (width_m, reach_m, side))


@pytest.mark.slow
@pytest.mark.parametrize("width_m", [2.8, 3.0, 3.5])
def test_an_offset_obstacle_on_a_network_stands_in_every_lane_it_blocks(
        city_configs, lesson_plain, width_m):
    """A car and a truck standing 0.6 or 1.0 m left of their lane's centre on a
    network's street: traffic in the next lane never drives through them and passes
    with 0.3 m at least (before, a network showed SUMO an obstacle in its own lane only)."""
    import copy
    config, route = city_configs(width_m)
    for kind in ("car", "truck"):
        for offset_m in (0.6, 1.0):
            obstacle = {"kind": kind, "lane": 0, "position_m": 300.0,
                        "lateral_offset_m": offset_m}
            spec = city_spec(copy.deepcopy(lesson_plain), config, route, seed=1,
                             obstacles=[obstacle], ego_start_m=240.0, duration_s=50.0)
            episode = run_episode(spec)
            assert episode.row["status"] == "ok"
            box = np.array(episode.metadata["obstacle_boxes"][0])
            for traffic in episode.trace.traffic:
                boxes = np.asarray(traffic, float).reshape(-1, 5)
                if len(boxes):
                    gap_m = box_gap_m(box, boxes).min()
                    assert gap_m >= traffic_model.PASS_CLEARANCE_M - 1e-3, (kind, offset_m)


def grid_spec(net: Path, front_m: float, kind: str, seed: int,
              lateral_offset_m: float = 0.0) -> ScenarioSpec:
    """A 4 x 4 netgenerate city (2 lanes each way, 3.0 m lanes, 80 m edges, 20 m
    junctions), 80 cars, a route through three edges, an obstacle of ``kind`` whose
    front is asked at ``front_m`` along it (edges end at 80 and 180 m),
    ``lateral_offset_m`` left of the lane's centre, the ego standing at 10 m."""
    length_m = {"car": 4.5, "truck": 12.0}[kind]
    return ScenarioSpec.from_plain({
        "scenario": {"name": "edge", "duration_s": 30.0, "step_s": 0.064, "seed": seed},
        "road": {"kind": "sumo_net", "net_file": str(net), "length_m": 250.0,
                 "route_edges": ["A1B1", "B1C1", "C1D1"]},
        "traffic": {"vehicles": 80, "speed_dev": 0.1},
        "obstacles": [{"kind": kind, "lane": 0, "position_m": front_m - length_m / 2,
                       "lateral_offset_m": lateral_offset_m}],
        "ego": {"lane": 0, "start_m": 10.0, "speed_mps": 0.0},
        "controller": {"name": "lane-keep"}})


@pytest.fixture(scope="module")
def grid_net(tmp_path_factory) -> Path:
    """The 4 x 4 netgenerate city of :func:`grid_spec`, built once for the module's
    tests (they only read it)."""
    net = tmp_path_factory.mktemp("grid") / "grid.net.xml"
    subprocess.run([sumo_binary("netgenerate"), "--grid", "--grid.number", "4",
                    "--grid.length", "100", "--default.lanenumber", "2",
                    "--default.lanewidth", "3.0", "--no-turnarounds", "true", "-o", str(net)],
                   check=True, capture_output=True)
    return net


@pytest.mark.slow
def test_an_obstacle_reaching_a_junction_stands_where_sumo_holds_it(grid_net):
    """Asked to stand with its front at the end of an edge or past it into the
    junction, an obstacle stands back off the junction, as SUMO's stopped vehicle
    does (SUMO holds stops on lanes only; the part in the junction was shown to
    nobody, and cars waited at the stop line inside it): SUMO's front is ours, and no
    traffic body overlaps it (pairs_overlap), 3 seeds each."""
    import libsumo

    from analysis.measures.world_audit import pairs_overlap
    from scenarios.scene.snapshot import obstacle_boxes

    for kind, front_m in (("car", 80.0), ("car", 181.5), ("truck", 180.0)):
        for seed in (3, 4, 6):
            spec = grid_spec(grid_net, front_m, kind, seed)
            road = make_road(spec)
            box = obstacle_boxes(spec, road)[0]
            ego = np.array([*road.xy_at(10.0, 0.0), float(road.heading_at(10.0)), 4.85, 1.93])
            front_xy = box[:2] + box[3] / 2 * np.array([np.cos(box[2]), np.sin(box[2])])
            with SumoWorld(spec, road, source=road_source(spec.road)) as world:
                world.start(ego, 0.0)
                assert np.hypot(*(np.array(libsumo.vehicle.getPosition("obstacle.0"))
                                  - front_xy)) < 0.05, (kind, front_m)
                for k in range(470):
                    traffic = world.step(ego, 0.0).traffic_boxes
                    overlaps = pairs_overlap(traffic, np.repeat(box[None], len(traffic), 0))
                    assert not overlaps.any(), (kind, front_m, seed, k)


def test_an_obstacle_shown_beside_stands_at_any_position_along_its_edge(grid_net):
    """An obstacle reaching into the next lane is shown there as a second stopped
    vehicle wherever along its edge it stands: at 9 positions with every fraction of a
    metre (its stop was asked at SUMO's position unrounded, its departure rounded to a
    micrometre: half the positions departed past their own stop and SUMO refused it)."""
    import libsumo

    for k in range(9):
        spec = grid_spec(grid_net, 30.0 + k * 7.123457, "car", seed=3, lateral_offset_m=1.0)
        road = make_road(spec)
        ego = np.array([*road.xy_at(10.0, 0.0), float(road.heading_at(10.0)), 4.85, 1.93])
        with SumoWorld(spec, road, source=road_source(spec.road)) as world:
            world.start(ego, 0.0)
            world.step(ego, 0.0)
            assert {"obstacle.0", "obstacle.0.1"} <= set(libsumo.vehicle.getIDList()), k


@pytest.mark.slow
def test_an_obstacle_over_a_two_way_streets_centre_line_stands_in_the_opposite_lane(
        grid_net):
    """A car or a truck in the left lane of a two-way street, reaching 1.0 or 1.8 m
    over its centre line into the opposite lane (3.0 m lanes), stands there too, as a
    stopped vehicle of that lane: oncoming traffic came near it and no traffic body
    overlaps it (before, SUMO saw it in its own lane only and oncoming cars drove
    through it), 2 seeds each."""
    from analysis.measures.world_audit import pairs_overlap
    from scenarios.scene.snapshot import obstacle_boxes

    oncoming_near = 0
    for kind, width_m in (("car", 1.8), ("truck", 2.5)):
        for reach_m in (1.0, 1.8):
            for seed in (1, 2):
                lane_index = make_road(grid_spec(grid_net, 140.0, kind, seed)).pieces[0].lane.index
                # from the route's lane to the centre line, then the reach
                offset_m = (1 - lane_index) * 3.0 + 1.5 - width_m / 2 + reach_m
                spec = grid_spec(grid_net, 140.0, kind, seed, offset_m)
                road = make_road(spec)
                box = obstacle_boxes(spec, road)[0]
                ego = np.array([*road.xy_at(10.0, 0.0), float(road.heading_at(10.0)),
                                4.85, 1.93])
                with SumoWorld(spec, road, source=road_source(spec.road)) as world:
                    world.start(ego, 0.0)
                    for k in range(400):
                        traffic = world.step(ego, 0.0).traffic_boxes
                        overlaps = pairs_overlap(traffic, np.repeat(box[None], len(traffic), 0))
                        assert not overlaps.any(), (kind, reach_m, seed, k)
                        facing = np.cos(traffic[:, 2] - box[2]) < -0.9
                        near = np.hypot(*(traffic[:, :2] - box[:2]).T) < 15.0
                        oncoming_near += bool((facing & near).any())
    assert oncoming_near > 50, oncoming_near


@pytest.mark.slow
@pytest.mark.parametrize(("width_m", "reach_m"), [(2.8, 0.5), (2.8, 0.8), (3.2, 0.5),
                                                  (3.2, 0.8), (3.75, 0.3)])
def test_an_ego_in_the_lane_beside_its_route_reaching_back_is_one_world(
        city_configs, lesson_plain, width_m, reach_m):
    """An ego whose centre is in the lane beside its route's (an avoid pass; its route
    is the street's right lane), whole in that lane at first, then drifting over 3 s
    until it reaches back over the line into its route's lane, standing or at 2 m/s,
    traffic in both lanes: no body through it, 0.3 m kept by any passing beside, and
    traffic queued behind it where it blocks the lane (before, SUMO was shown such an
    ego as it was and registered the reach only as it entered a lane: traffic drove
    through it on 2.8 and 3.2 m lanes, 55-100 steps a run)."""
    import copy
    config, route = city_configs(width_m)
    for speed_mps in (0.0, 2.0):
        spec = city_spec(copy.deepcopy(lesson_plain), config, route, seed=3)
        seen = straddle(spec, reach_m, side=-1, speed_mps=speed_mps, ramp_s=3.0,
                        line_side=1, from_reach_m=-0.3)
        blocks = traffic_model.blocks_neighbour(reach_m, width_m, TRAFFIC_WIDTH_M)
        assert_one_world(seen, blocks, (width_m, reach_m, speed_mps))
