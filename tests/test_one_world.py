"""One physical world: SUMO's traffic sees the ego and the obstacles where they stand,
changes lanes over time, enters behind the ego only where it can stop, and every
collision says which part of the ego was hit and who moved into whom.

The world tests drive a real libsumo simulation with the ego held where the test
puts it, and judge with our own geometry (an independent check of what SUMO did).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import analysis.measures.world_audit as world_audit
from analysis.measures.world_audit import pairs_overlap, world_overlaps
from scenarios.common.errors import SpecError
from scenarios.scene import traffic_model
from scenarios.scene.boxes import as_boxes
from scenarios.scene.snapshot import Snapshot, passenger_classes
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.sumo.routes_xml import TRAFFIC_WIDTH_M, obstacle_lanes
from scenarios.sumo.sumo_world import SumoWorld
from scenarios.sumo_net.road_source import road_source
from scenarios.world_backends import make_road
from sdc.car.collision import FRONT, RAN_INTO, REAR, SIDE, WAS_HIT, describe, hit_part
from sdc.car.geometry import box_gap_m, boxes_overlap
from sdc.car.geometry_kernels import Contacts
from sdc.run.episode import run_episode
from sdc.run.sumo_driver import PASSED, sumo_drives

X5_LENGTH_M, X5_WIDTH_M = 4.85, 1.93


def two_lanes(lesson_plain: dict, *, seed: int, flow_vph: float = 600.0, speed_mps=27.0,
              obstacles=(), ego_start_m: float = 50.0, duration_s: float = 60.0) -> ScenarioSpec:
    """A straight two-lane road (3.5 m lanes), traffic faster than the ego from the
    road's start, the ego in lane 0 (the right one)."""
    plain = lesson_plain
    plain["scenario"].update(seed=seed, duration_s=duration_s)
    plain["road"].update(length_m=1000.0, lanes=2, speed_limit_mps=33.33)
    plain["traffic"] = {"flow_vph_per_lane": flow_vph, "speed_mean_mps": speed_mps,
                        "speed_dev": 0.1}
    plain["obstacles"] = list(obstacles)
    plain["ego"].update(lane=0, start_m=ego_start_m, speed_mps=0.0)
    plain["controller"] = {"name": "lane-keep"}
    return ScenarioSpec.from_plain(plain)


def held_box(road, s_m: float, d_m: float) -> np.ndarray:
    xy = road.xy_at(s_m, d_m)
    return np.array([xy[0], xy[1], float(road.heading_at(s_m)), X5_LENGTH_M, X5_WIDTH_M])


# ---------------------------------------------------------------- the rule, as numbers


def test_a_body_blocks_a_lane_only_where_a_car_cannot_pass_with_the_clearance():
    # 3.5 m lanes, 1.8 m cars: a car at its lane's centre has 0.85 m beside it
    slack_m = traffic_model.pass_slack_m(3.5, 1.8)
    assert slack_m == pytest.approx(0.85 - traffic_model.PASS_CLEARANCE_M)
    assert not traffic_model.blocks_neighbour(0.0, 3.5, 1.8)
    assert not traffic_model.blocks_neighbour(slack_m - 0.01, 3.5, 1.8)
    assert traffic_model.blocks_neighbour(slack_m + 0.01, 3.5, 1.8)
    # a lane too narrow to pass in: any reach over its line blocks it
    assert traffic_model.blocks_neighbour(0.01, 2.3, 1.8)


@pytest.mark.parametrize("offset_m", [0.0, 0.5, 1.0, 1.3, 1.5, 1.7, -1.6])
def test_sumo_sees_the_ego_inside_its_lane_and_a_stand_in_where_it_blocks(lesson_plain,
                                                                          offset_m):
    """libsumo's own positions: the ego inside its lane (nothing of it over a line), and
    a vehicle of its size beside it in a lane it blocks, none where it leaves room."""
    import libsumo

    spec = two_lanes(lesson_plain, seed=1, flow_vph=0.0)
    road = make_road(spec)
    d_m = road.lane_center_d_m(0) + offset_m
    lane = road.lane_at_d(d_m)
    reach_m = abs(d_m - road.lane_center_d_m(lane)) + X5_WIDTH_M / 2 - 3.5 / 2
    side = 1 if d_m > road.lane_center_d_m(lane) else -1
    blocks = traffic_model.blocks_neighbour(reach_m, 3.5, TRAFFIC_WIDTH_M) and 0 <= lane + side < 2
    with SumoWorld(spec, road, source=road_source(spec.road)) as world:
        world.start(held_box(road, 300.0, d_m), 5.0)
        world.step(held_box(road, 300.5, d_m), 5.0)
        assert libsumo.vehicle.getLaneID("ego") == f"road_{lane}"
        assert abs(libsumo.vehicle.getLateralLanePosition("ego")) <= (3.5 - X5_WIDTH_M) / 2 + 1e-6
        others = [v for v in libsumo.vehicle.getIDList() if v != "ego"]
        assert len(others) == int(blocks), others
        if blocks:
            (stand_in,) = others
            assert libsumo.vehicle.getLaneID(stand_in) == f"road_{lane + side}"
            assert libsumo.vehicle.getLanePosition(stand_in) == pytest.approx(
                libsumo.vehicle.getLanePosition("ego"), abs=1e-6)
            assert libsumo.vehicle.getSpeed(stand_in) == pytest.approx(5.0)


def test_an_offset_obstacle_stands_in_every_lane_it_blocks(lesson_plain):
    spec = two_lanes(lesson_plain, seed=1)
    road = make_road(spec)
    for kind, width_m in (("car", 1.8), ("truck", 2.5)):
        for offset_m in np.linspace(-1.5, 1.5, 13):
            box = np.array([*road.xy_at(300.0, road.lane_center_d_m(0) + offset_m), 0.0,
                            4.5, width_m])
            reach_m = offset_m + width_m / 2 - 3.5 / 2
            expected = [0, 1] if traffic_model.blocks_neighbour(reach_m, 3.5, 1.8) else [0]
            assert obstacle_lanes(road, box) == expected, (kind, offset_m)


# ---------------------------------------------------------------- the audit, brute force


def test_the_pairwise_overlap_test_agrees_with_the_cars_one_against_many():
    rng = np.random.default_rng(5)
    a = np.column_stack([rng.uniform(-4, 4, (500, 2)), rng.uniform(-np.pi, np.pi, 500),
                         rng.uniform(0.5, 12, 500), rng.uniform(0.5, 2.6, 500)])
    b = np.column_stack([rng.uniform(-4, 4, (500, 2)), rng.uniform(-np.pi, np.pi, 500),
                         rng.uniform(0.5, 12, 500), rng.uniform(0.5, 2.6, 500)])
    ours = pairs_overlap(a, b, tolerance_m=0.0)
    # boxes_overlap counts touching as overlapping; away from touching the two agree
    theirs = np.array([boxes_overlap(a[k], b[k : k + 1])[0] for k in range(500)])
    gaps = np.array([box_gap_m(a[k], b[k : k + 1])[0] for k in range(500)])
    clear = (gaps > 1e-6) | ~theirs
    assert ours[clear].tolist() == theirs[clear].tolist()
    assert 50 < ours.sum() < 450  # both kinds were tried


def step_overlaps(traffic: list, obstacles: list) -> int:
    return world_overlaps([np.asarray(traffic, float).ravel()], as_boxes(obstacles))


def test_a_step_counts_traffic_through_traffic_and_obstacles_not_touching_or_the_far():
    car = [0.0, 0.0, 0.0, 4.5, 1.8]
    through = [2.0, 1.0, 0.3, 4.5, 1.8]
    behind = [-6.0, 0.0, 0.0, 4.5, 1.8]  # 1.5 m gap
    beside = [0.0, 1.8, 0.0, 4.5, 1.8]  # touching side to side
    assert step_overlaps([car, behind, beside], []) == 0
    assert step_overlaps([car, through], []) == 1
    assert step_overlaps([behind], [[-4.0, 0.5, 0.0, 4.5, 2.5]]) == 1
    # two obstacles on top of each other are the spec's, not the traffic's doing
    assert step_overlaps([], [car, car]) == 0


def test_the_audit_of_a_trace_counts_the_steps_a_brute_force_loop_counts(monkeypatch):
    """Steps of different sizes, in chunks: every pair checked one by one agrees."""
    rng = np.random.default_rng(11)
    obstacles = as_boxes([[5.0, 0.0, 0.0, 12.0, 2.5], [-20.0, 3.0, 0.0, 0.6, 0.6]])
    rows = []
    for _ in range(300):
        n = int(rng.integers(0, 9))
        rows.append(np.column_stack([rng.uniform(-25, 25, n), rng.uniform(-5, 5, n),
                                     rng.normal(0, 0.2, n), np.full(n, 4.5),
                                     np.full(n, 1.8)]).ravel())

    def brute(row: np.ndarray) -> bool:
        boxes = row.reshape(-1, 5)
        bodies = np.vstack([boxes, obstacles])
        return any(pairs_overlap(boxes[i], bodies[j])[0]
                   for i in range(len(boxes)) for j in range(i + 1, len(bodies)))

    expected = sum(brute(row) for row in rows)
    assert 30 < expected < 270  # steps of both kinds
    monkeypatch.setattr(world_audit, "_PAIRS_PER_PASS", 500)  # many chunks
    assert world_overlaps(rows, obstacles) == expected


# ---------------------------------------------------------------- who hit whom


def test_the_part_hit_is_the_edge_nearest_the_contact():
    ego = np.array([0.0, 0.0, 0.0, 4.85, 1.93])
    assert hit_part(ego, np.array([2.4, 0.5])) == FRONT
    assert hit_part(ego, np.array([-2.4, -0.5])) == REAR
    assert hit_part(ego, np.array([0.5, -0.9])) == SIDE


def contact(ego_box, other_box, ego_mps, other_mps):
    snapshot = Snapshot(0.0, as_boxes([other_box]), as_boxes([]), np.array([other_mps]),
                        passenger_classes(1))
    return describe("vehicle", np.asarray(ego_box, float), ego_mps, Contacts(-1, 0, 0.0),
                    snapshot, None, 0.0)


def test_rear_ended_side_swiped_and_running_into_a_slower_car():
    ego = [0.0, 0.0, 0.0, 4.85, 1.93]
    rear_ender = [-4.6, 0.0, 0.0, 4.5, 1.8]
    assert contact(ego, rear_ender, 5.0, 12.0)[1:3] == (REAR, WAS_HIT)
    assert contact(ego, rear_ender, 0.0, 3.0)[1:3] == (REAR, WAS_HIT)
    cutting_in = [-1.0, 2.0, -0.35, 4.5, 1.8]  # from the left, heading right
    assert contact(ego, cutting_in, 20.0, 20.0)[1:3] == (SIDE, WAS_HIT)
    swerving = [0.0, 0.0, 0.05, 4.85, 1.93]  # the ego, heading left into a car beside it
    beside = [-1.0, 1.85, 0.0, 4.5, 1.8]
    assert contact(swerving, beside, 20.0, 20.0)[1:3] == (SIDE, RAN_INTO)
    standing = [0.0, 1.85, 0.0, 4.5, 1.8]  # grazed while the ego drives straight on
    assert contact(ego, standing, 20.0, 0.0)[1:3] == (SIDE, RAN_INTO)
    slower = [4.6, 0.2, 0.0, 4.5, 1.8]
    assert contact(ego, slower, 20.0, 10.0)[1:3] == (FRONT, RAN_INTO)
    # the ego standing, a car beside it turning away swings its back into its side: the
    # ego did not move, it was hit (it read ran_into: the car moved away from the contact)
    turning_away = [0.5, 1.75, 0.35, 4.5, 1.8]
    assert contact(ego, turning_away, 0.0, 5.0)[1:3] == (SIDE, WAS_HIT)
    assert contact(ego, turning_away, 3.0, 5.0)[1:3] == (SIDE, RAN_INTO)  # moving, it did
    assert contact(ego, slower, 20.0, 10.0).vehicle_class == "passenger"


# ---------------------------------------------------------------- SUMO, in a real libsumo


def drive_held(spec, d_m: float, speed_mps: float, steps: int):
    """The ego held ``d_m`` off its lane's centre at ``speed_mps``; yields each step's
    ego box and snapshot."""
    road = make_road(spec)
    s_m = spec.ego.start_m
    lane_d_m = road.lane_center_d_m(spec.ego.lane)
    with SumoWorld(spec, road, source=road_source(spec.road)) as world:
        world.start(held_box(road, s_m, lane_d_m + d_m), speed_mps)
        for _ in range(steps):
            s_m += speed_mps * spec.scenario.step_s
            box = held_box(road, s_m, lane_d_m + d_m)
            yield box, world.step(box, speed_mps)


@pytest.mark.slow
@pytest.mark.parametrize("offset_m", [1.0, 1.3, 1.5, 1.7])
def test_traffic_brakes_behind_or_passes_clear_of_an_ego_reaching_into_its_lane(
        lesson_plain, offset_m):
    """The straddle test: the ego 1.0-1.7 m left of its lane's centre at 8 m/s, faster
    traffic from behind in the next lane; over 10 seeds no car drives through it and
    every car passing beside it keeps 0.3 m (1.5 and 1.7 m leave no such room: there,
    traffic queues behind it)."""
    passed = 0
    for seed in range(10):
        spec = two_lanes(lesson_plain, seed=seed, duration_s=60.0)
        for box, snapshot in drive_held(spec, offset_m, 8.0, 500):
            traffic = snapshot.traffic_boxes
            beside = np.abs(traffic[:, 0] - box[0]) < (X5_LENGTH_M + 4.5) / 2
            if beside.any():
                passed += 1
                gap_m = box_gap_m(box, traffic[beside]).min()
                assert gap_m >= traffic_model.PASS_CLEARANCE_M - 1e-3, (seed, gap_m)
    if offset_m <= 1.3:
        assert passed > 0  # room to pass: traffic did pass, not queue


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["car", "truck"])
def test_traffic_never_drives_through_an_offset_obstacle(lesson_plain, kind):
    """Obstacles offset up to 1.5 m toward the lane with traffic: ``world_overlaps`` 0
    in every run; traffic passes them with at least 0.3 m, and does pass where there is
    room (no gridlock beside an obstacle)."""
    for offset_m in (0.6, 1.0, 1.5):
        passed = 0
        for seed in range(3):
            obstacle = {"kind": kind, "lane": 0, "position_m": 300.0,
                        "lateral_offset_m": offset_m}
            spec = two_lanes(lesson_plain, seed=seed, obstacles=[obstacle], ego_start_m=240.0,
                             duration_s=50.0)
            episode = run_episode(spec)
            row, box = episode.row, np.array(episode.metadata["obstacle_boxes"][0])
            assert row["status"] == "ok" and row["collision"] is False
            assert row["world_overlaps"] == 0, (kind, offset_m, seed)
            for traffic in episode.trace.traffic:
                boxes = np.asarray(traffic, float).reshape(-1, 5)
                beside = boxes[np.abs(boxes[:, 0] - box[0]) < (box[3] + 4.5) / 2]
                if len(beside):
                    passed += 1
                    assert box_gap_m(box, beside).min() >= traffic_model.PASS_CLEARANCE_M - 1e-3
        width_m = 2.5 if kind == "truck" else 1.8
        if not traffic_model.blocks_neighbour(offset_m + width_m / 2 - 1.75, 3.5, 1.8):
            assert passed > 0, (kind, offset_m)


@pytest.mark.slow
def test_traffic_passes_a_standing_ego_that_leaves_room(lesson_plain):
    """No gridlock beside a standing ego: at its lane's centre, or 1.0 m off it toward
    the traffic, the next lane's cars pass it (with 0.3 m at least)."""
    for offset_m in (0.0, 1.0):
        passed = 0
        for seed in range(3):
            spec = two_lanes(lesson_plain, seed=seed, ego_start_m=200.0)
            for box, snapshot in drive_held(spec, offset_m, 0.0, 400):
                traffic = snapshot.traffic_boxes
                beside = traffic[np.abs(traffic[:, 0] - box[0]) < (X5_LENGTH_M + 4.5) / 2]
                if len(beside):
                    passed += 1
                    assert box_gap_m(box, beside).min() >= traffic_model.PASS_CLEARANCE_M
        assert passed > 50, offset_m


@pytest.mark.slow
@pytest.mark.parametrize("lane_change_s", [None, 4.0])
def test_no_traffic_vehicle_moves_sideways_faster_than_a_lane_change_allows(lesson_plain,
                                                                          lane_change_s):
    """Every traffic vehicle's speed across the road, followed by its SUMO ID over a
    minute of a three-lane road in dense traffic, stays within a lane width per
    ``traffic.lane_change_s`` (it was a lane width in one step: 55 m/s)."""
    plain = lesson_plain
    plain["road"].update(length_m=1000.0, lanes=3, speed_limit_mps=33.33)
    plain["traffic"] = {"flow_vph_per_lane": 1200.0, "speed_mean_mps": 25.0, "speed_dev": 0.2}
    if lane_change_s is not None:
        plain["traffic"]["lane_change_s"] = lane_change_s
    plain["obstacles"] = [{"kind": "car", "lane": 0, "position_m": 500.0}]
    plain["ego"].update(lane=2, start_m=30.0, speed_mps=10.0)
    plain["scenario"].update(seed=3)
    spec = ScenarioSpec.from_plain(plain)
    road = make_road(spec)
    assert spec.traffic.lane_change_s == (lane_change_s or 2.0)  # 2 s by default
    bound_mps = road.lane_width_m / spec.traffic.lane_change_s
    last: dict[str, float] = {}
    fastest_mps, changes = 0.0, 0
    s_m = spec.ego.start_m
    with SumoWorld(spec, road, source=road_source(spec.road)) as world:
        world.start(held_box(road, s_m, road.lane_center_d_m(2)), 10.0)
        vehicle = world._sumo.vehicle
        for _ in range(round(60 / spec.scenario.step_s)):
            s_m += 10.0 * spec.scenario.step_s
            world.step(held_box(road, s_m, road.lane_center_d_m(2)), 10.0)
            ids = [v for v in vehicle.getIDList() if v.startswith("traffic.")]
            if not ids:
                continue
            _, d_m = road.to_frenet(np.array([vehicle.getPosition(v) for v in ids]))
            for vid, d in zip(ids, d_m.tolist(), strict=True):
                if vid in last:
                    speed = abs(d - last[vid]) / spec.scenario.step_s
                    fastest_mps = max(fastest_mps, speed)
                    changes += speed > 0.5
                last[vid] = d
    assert changes > 0  # lane changes happened
    assert bound_mps * 0.9 <= fastest_mps <= bound_mps * 1.05, fastest_mps


@pytest.mark.parametrize("seconds", [0.0, 0.5, 11.0])
def test_a_lane_change_shorter_than_a_second_is_bad_input(lesson_plain, seconds):
    lesson_plain["traffic"]["lane_change_s"] = seconds
    with pytest.raises(SpecError, match="traffic.lane_change_s"):
        ScenarioSpec.from_plain(lesson_plain)


@pytest.mark.slow
def test_no_car_enters_behind_a_standing_or_slow_ego_that_it_cannot_stop_for(lesson_plain):
    """The ego standing or slow 10-50 m ahead of the flows' entry (30 m/s traffic):
    0 collisions in the first 2 s over 20 seeds."""
    collisions = []
    for seed in range(20):
        start_m = 10.0 + 40.0 * (seed % 5) / 4
        plain = {**lesson_plain}
        spec = two_lanes(plain, seed=seed, flow_vph=1500.0, speed_mps=30.0,
                         ego_start_m=start_m, duration_s=2.0)
        spec = ScenarioSpec.from_plain({**spec.to_plain(),
                                        "ego": {**spec.to_plain()["ego"],
                                                "speed_mps": 3.0 * (seed % 2)}})
        row = run_episode(spec).row
        if row["collision"]:
            collisions.append((seed, start_m, row["collision_with"], row["collision_time_s"]))
    assert collisions == []


@pytest.mark.slow
def test_after_a_warm_up_no_car_is_left_behind_the_ego_that_cannot_stop_for_it(lesson_plain):
    """The ego entering warmed-up 30 m/s traffic standing or slow: 0 collisions in the
    first 2 s over 10 seeds."""
    collisions = []
    for seed in range(10):
        plain = two_lanes({**lesson_plain}, seed=seed, flow_vph=1500.0, speed_mps=30.0,
                          ego_start_m=150.0 + 20.0 * seed, duration_s=2.0).to_plain()
        plain["traffic"]["warm_up_s"] = 30.0
        plain["ego"]["speed_mps"] = 3.0 * (seed % 2)
        row = run_episode(ScenarioSpec.from_plain(plain)).row
        if row["collision"]:
            collisions.append((seed, row["collision_with"], row["collision_time_s"]))
    assert collisions == []


@pytest.mark.slow
def test_sumo_knows_the_egos_size_and_brakes(lesson_plain):
    spec = two_lanes(lesson_plain, seed=1, duration_s=1.0)
    road = make_road(spec)
    with SumoWorld(spec, road, source=road_source(spec.road)) as world:
        world.start(held_box(road, 50.0, road.lane_center_d_m(0)), 0.0)
        vehicle = world._sumo.vehicle
        assert vehicle.getLength("ego") == pytest.approx(X5_LENGTH_M)
        assert vehicle.getWidth("ego") == pytest.approx(X5_WIDTH_M)
        assert vehicle.getAccel("ego") == pytest.approx(3.0)
        assert vehicle.getDecel("ego") == pytest.approx(min(8.0, 0.9 * 9.81))
        assert math.isclose(vehicle.getEmergencyDecel("ego"), vehicle.getDecel("ego"))


@pytest.mark.slow
def test_the_traffic_family_leaves_a_way_past_its_obstacle():
    """No gridlock in the avoid-roads traffic family: in its 15 busiest samples
    (where avoid, which stops before it pulls out, ends stuck most often) SUMO's own
    driver in the ego's place gets past the stopped car every time, without a
    collision and without stopping: it changes lanes early, while moving."""
    from scenarios import CATALOG_DIR
    from scenarios.spec.sweep_plan import expand
    from scenarios.spec.sweep_spec import load_sweep

    runs = [r for r in expand(load_sweep(CATALOG_DIR / "sweeps" / "avoid-roads-traffic.toml"))
            if r.spec.controller.label == "avoid"]
    busiest = sorted(runs, key=lambda r: -r.spec.traffic.flow_vph_per_lane)[:15]
    for run in busiest:
        drive = sumo_drives(run.spec)
        assert drive.outcome == PASSED, (run.run_id, drive)
        assert drive.slowest_mps > 1.0, run.run_id
