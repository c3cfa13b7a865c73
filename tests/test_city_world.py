"""One world on city lanes: the straddle rule on every lane width SUMO networks use
(2.8-3.75 m), for traffic of any width, on the built-in roads and on networks (a
configuration built here with netconvert, its own flows in both lanes).

The world is judged with our own geometry (an independent check of what SUMO did):
no traffic body overlaps the ego or an obstacle, and one passing beside keeps
``PASS_CLEARANCE_M``.
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest

from scenarios.scene import traffic_model
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.sumo.routes_xml import lanes_blocked
from scenarios.sumo.sumo_world import SumoWorld
from scenarios.sumo_net.build import sumo_binary
from scenarios.world_backends import make_road
from sdc.car.geometry import box_gap_m
from sdc.run.episode import run_episode

X5_LENGTH_M, X5_WIDTH_M = 4.85, 1.93
WIDTHS_M = (2.8, 3.0, 3.2, 3.5, 3.75)
CAR = '<vType id="c" speedFactor="normc(1,0.1,0.2,2)"/>'
TRUCK = ('<vType id="c" length="7.1" width="2.5" vClass="truck" '
         'speedFactor="normc(1,0.1,0.2,2)"/>')


def city_config(folder: Path, width_m: float, vtype: str = CAR, edge_m: int = 100,
                edges: int = 10) -> tuple[Path, list[str]]:
    """A straight two-lane street of ``edges`` edges ``edge_m`` long, lanes ``width_m``
    wide, joined at priority junctions, 600 veh/h of ``vtype`` in each lane from its
    start: its configuration and its edges."""
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
            f'departLane="{lane}" departSpeed="max"/>' for lane in (0, 1)) + "</routes>")
    (folder / "x.sumocfg").write_text(
        '<configuration><input><net-file value="x.net.xml"/>'
        '<route-files value="x.rou.xml"/></input></configuration>')
    return folder / "x.sumocfg", route


def city_spec(lesson_plain: dict, config: Path, route: list[str], *, seed: int,
              obstacles=(), ego_start_m: float = 200.0, duration_s: float = 60.0
              ) -> ScenarioSpec:
    """The ego on the street's right lane, entering one step after its flows begin."""
    plain = lesson_plain
    plain["scenario"].update(seed=seed, duration_s=duration_s, step_s=0.1)
    plain["road"] = {"kind": "sumo_config", "config_file": str(config), "length_m": 700.0,
                     "route_edges": route}
    plain["traffic"] = {"enter_s": 0.1}
    plain["obstacles"] = list(obstacles)
    plain["ego"].update(lane=0, start_m=ego_start_m, speed_mps=0.0)
    plain["controller"] = {"name": "lane-keep"}
    return ScenarioSpec.from_plain(plain)


def straight_spec(lesson_plain: dict, width_m: float, *, seed: int) -> ScenarioSpec:
    """A straight built-in two-lane road of ``width_m`` lanes, traffic at 27 m/s from its
    start, 200 m behind the ego in the right lane."""
    plain = lesson_plain
    plain["scenario"].update(seed=seed, duration_s=60.0)
    plain["road"].update(length_m=1000.0, lanes=2, lane_width_m=width_m,
                         speed_limit_mps=33.33)
    plain["traffic"] = {"flow_vph_per_lane": 600.0, "speed_mean_mps": 27.0,
                        "speed_dev": 0.1}
    plain["obstacles"] = []
    plain["ego"].update(lane=0, start_m=200.0, speed_mps=0.0)
    plain["controller"] = {"name": "lane-keep"}
    return ScenarioSpec.from_plain(plain)


def straddle(spec: ScenarioSpec, reach_m: float, speed_mps: float = 8.0, steps: int = 450
             ) -> tuple[int, float, int]:
    """The ego held ``reach_m`` over its lane's left line at ``speed_mps``: the steps a
    traffic body overlapped it, the least gap to a body in the other lane beside it [m],
    and how many steps one was beside it."""
    road = make_road(spec)
    lane_d_m = road.lane_center_d_m(spec.ego.lane)
    width_m, _ = road.lane_widths_m(spec.ego.start_m, spec.ego.lane)
    d_m = lane_d_m + width_m / 2 + reach_m - X5_WIDTH_M / 2
    s_m = spec.ego.start_m
    through, least_m, beside = 0, np.inf, 0

    def box_at(s: float) -> np.ndarray:
        return np.array([*road.xy_at(s, d_m), float(road.heading_at(s)), X5_LENGTH_M,
                         X5_WIDTH_M])

    with SumoWorld(spec, road) as world:
        world.start(box_at(s_m), speed_mps)
        for _ in range(steps):
            s_m += speed_mps * spec.scenario.step_s
            box = box_at(s_m)
            traffic = world.step(box, speed_mps).traffic_boxes
            if not len(traffic):
                continue
            gaps = box_gap_m(box, traffic)
            through += int(np.any(gaps < 0))
            (ego_s,), _ = road.to_frenet(box[None, :2])
            other_s, other_d = road.to_frenet(traffic[:, :2])
            side = ((other_d > lane_d_m + width_m / 2)
                    & (np.abs(other_s - ego_s) < (X5_LENGTH_M + traffic[:, 3]) / 2))
            if side.any():
                beside += 1
                least_m = min(least_m, float(gaps[side].min()))
    return through, least_m, beside


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
    lateral_m = traffic_model.sumo_lateral_m(-0.2, 2.4, 0.0, 3.2, 1.93, 1.8, (3.2, None))
    assert lateral_m == pytest.approx((3.2 - 1.93) / 2)  # shown inside its own lane
    lateral_m = traffic_model.sumo_lateral_m(-0.2, 2.4, 0.0, 3.2, 1.93, 1.8, (3.2, 2.8))
    assert lateral_m == pytest.approx(2.4 - 1.93 / 2)  # shown as far as it reaches


def test_a_lane_beside_is_judged_by_its_own_width():
    # 0.45 m into a 3.5 m lane leaves a car 0.4 m; into a 3.0 m lane, 0.15 m
    for beside_m, blocks in ((3.5, False), (3.0, True)):
        lateral_m = traffic_model.sumo_lateral_m(-0.5, 1.85, 0.0, 2.8, 1.93, 1.8,
                                                 (None, beside_m))
        assert (lateral_m > (2.8 - 1.93) / 2 + 1e-9) == blocks


def test_a_networks_lanes_are_as_wide_as_its_file_says(tmp_path, lesson_plain):
    config, route = city_config(tmp_path, 2.9)
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


@pytest.mark.slow
@pytest.mark.parametrize("width_m", WIDTHS_M)
def test_the_straddle_test_on_every_lane_width(lesson_plain, width_m):
    """The ego held 0.5-0.9 m into the next lane at 8 m/s, traffic at 27 m/s from behind
    in it; 10 seeds: no car drives through the ego, every car beside keeps 0.3 m."""
    import copy
    for seed in range(10):
        reach_m = 0.5 + 0.4 * seed / 9
        spec = straight_spec(copy.deepcopy(lesson_plain), width_m, seed=seed)
        through, least_m, beside = straddle(spec, reach_m)
        assert through == 0, (width_m, seed, reach_m)
        assert least_m >= traffic_model.PASS_CLEARANCE_M - 1e-3, (width_m, seed, least_m)
        if not traffic_model.blocks_neighbour(reach_m, width_m, 1.8):
            assert beside > 0, (width_m, seed)  # room to pass: traffic did pass


@pytest.mark.slow
@pytest.mark.parametrize("width_m", WIDTHS_M)
def test_trucks_on_city_lanes_pass_a_straddling_ego_only_with_the_clearance(
        tmp_path, lesson_plain, width_m):
    """A network's own flows of 2.5 m trucks in both lanes: the ego 0.1-0.9 m into the
    next lane is shown there as soon as a truck would pass it with less than 0.3 m."""
    import copy
    config, route = city_config(tmp_path, width_m, TRUCK)
    for reach_m in (0.1, 0.3, 0.5, 0.9):
        spec = city_spec(copy.deepcopy(lesson_plain), config, route, seed=1)
        through, least_m, beside = straddle(spec, reach_m)
        assert through == 0, (width_m, reach_m)
        assert least_m >= traffic_model.PASS_CLEARANCE_M - 1e-3, (width_m, reach_m, least_m)
        if not traffic_model.blocks_neighbour(reach_m, width_m, 2.5):
            assert beside > 0, (width_m, reach_m)


@pytest.mark.slow
@pytest.mark.parametrize("width_m", [2.8, 3.0, 3.5])
def test_an_offset_obstacle_on_a_network_stands_in_every_lane_it_blocks(
        tmp_path, lesson_plain, width_m):
    """A car and a truck standing 0.6 or 1.0 m left of their lane's centre on a
    network's street: traffic in the next lane never drives through them and passes
    with 0.3 m at least (before, a network showed SUMO an obstacle in its own lane only)."""
    import copy
    config, route = city_config(tmp_path, width_m)
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
