"""Several egos in one SUMO world (sdc/run/shared_world.py): one ego through the shared
path is the plain run, egos are bodies to each other (seen, sensed, hit), a world of
the same runs gives the same traces, a run that ends leaves, and the placement rule
keeps sensing radii apart at the start.

Each test that steps SUMO drives a real libsumo simulation."""

from __future__ import annotations

import copy
import dataclasses
import math
import subprocess
from pathlib import Path

import numpy as np
import pytest

from analysis.measures.world_audit import pairs_overlap
from analysis.report.look_at import what_happened
from scenarios import CATALOG_DIR
from scenarios.scene.snapshot import OTHER_EGO, OTHER_OBSTACLE, TRAFFIC, Snapshot, sensing_radius_m
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.spec.toml_io import load_spec, read_toml
from scenarios.sumo_net.build import sumo_binary
from scenarios.sumo_net.road_source import road_source
from scenarios.world_backends import make_road
from sdc.car.collision import ROAD_EDGE, VEHICLE, describe
from sdc.car.controller_plugins import make_controller
from sdc.car.geometry_kernels import Contacts
from sdc.run.episode import Episode, Simulation, run_episode
from sdc.run.shared_world import Failed, Seats, run_group, run_world

QUICK_TOWN = Path(__file__).parent / "data" / "grid-town-quick.toml"
STEP_S = 0.064


def straight(start_m: float, *, lane: int = 0, speed_mps: float = 10.0,
             duration_s: float = 8.0, seed: int = 1, flow_vph: float = 0.0,
             obstacles: tuple = (), max_range_m: float | None = None) -> ScenarioSpec:
    """A built straight road of 1000 m, two 3.5 m lanes, no road edges in the lidar
    (its central beams see bodies only); a lane-keeping ego (it holds its speed)."""
    plain = copy.deepcopy(read_toml(CATALOG_DIR / "seed-lesson.toml"))
    plain["scenario"].update(seed=seed, duration_s=duration_s)
    plain["road"].update(length_m=1000.0, lanes=2, speed_limit_mps=27.78, see_edges=False)
    plain["traffic"] = ({"flow_vph_per_lane": flow_vph, "speed_mean_mps": 25.0,
                         "speed_dev": 0.1} if flow_vph else {"flow_vph_per_lane": 0.0})
    plain["obstacles"] = [dict(o) for o in obstacles]
    plain["ego"].update(lane=lane, start_m=start_m, speed_mps=speed_mps)
    if max_range_m is not None:
        plain["lidar"]["max_range_m"] = max_range_m
    plain["controller"] = {"name": "lane-keep"}
    return ScenarioSpec.from_plain(plain)


def town(seed: int, *, warm_seed: int = 11, duration_s: float = 6.0) -> ScenarioSpec:
    """The quick grid town, smaller: 300 cars warmed up 10 s (one warm state for every
    test: its seed fixed), a 6 s run on the route of ``seed``."""
    spec = load_spec(QUICK_TOWN)
    return dataclasses.replace(
        spec, scenario=dataclasses.replace(spec.scenario, seed=seed, duration_s=duration_s),
        traffic=dataclasses.replace(spec.traffic, vehicles=300, warm_up_s=10.0,
                                    warm_seed=warm_seed))


def with_roads(specs: list[ScenarioSpec]) -> list[tuple[ScenarioSpec, object]]:
    return [(spec, make_road(spec)) for spec in specs]


def episodes(outcomes: list) -> list[Episode]:
    """The episodes of ``outcomes`` (run_world's or run_group's), none of them failed."""
    failed = [r for r in outcomes if isinstance(r, Failed)]
    assert not failed, failed[0].traceback
    return outcomes


def boxes_at(episode: Episode, step: int) -> np.ndarray:
    """The traffic boxes an ego's trace holds at ``step`` (N, 5)."""
    return np.asarray(episode.trace.traffic[step], float).reshape(-1, 5)


def own_box(episode: Episode, step: int) -> np.ndarray:
    """The ego's own body box at ``step``, from its trace."""
    model = episode.metadata["vehicle"]
    return episode.trace.body_boxes(model["center_ahead_of_rear_axle_m"], model["length_m"],
                                    model["width_m"])[step]


def holds(boxes: np.ndarray, box: np.ndarray, tol: float = 1e-3) -> bool:
    """Is ``box`` among ``boxes`` (to float32's precision in a trace)?"""
    return bool(len(boxes)) and bool(np.any(np.all(np.abs(boxes - box) <= tol, axis=1)))


def without_wall_time(row: dict) -> dict:
    return {k: v for k, v in row.items() if k != "wall_time_s"}


# ------------------------------------------------------ one ego: the plain run


@pytest.mark.slow
@pytest.mark.parametrize("make", [
    lambda: town(11),
    lambda: straight(50.0, speed_mps=10.0, flow_vph=1200.0, seed=4),
], ids=["town-warm-state", "straight-flows"])
def test_one_ego_through_the_shared_path_is_the_plain_run(make):
    spec = make()
    alone = run_episode(spec, run_id="r")
    (shared,) = episodes(run_group([spec], ["r"]))
    assert shared.row["trace_sha256"] == alone.row["trace_sha256"]
    assert without_wall_time(shared.row) == without_wall_time(alone.row)
    assert shared.row["world_egos"] == 1
    # the comparison compared traffic, not two empty worlds
    assert any(len(t) for t in alone.trace.traffic)


# ------------------------------------------------------ egos are bodies to each other


def test_egos_see_each_other_and_one_runs_into_the_other():
    """A at 10 m/s behind B, who stands 50 m ahead in the same lane (B's parked car in
    the other lane): A's lidar sees B coming closer, A runs into B's rear, and B's run
    ends at the same step, hit from behind."""
    a = straight(50.0, speed_mps=10.0, duration_s=10.0)
    b = straight(100.0, speed_mps=0.0, duration_s=10.0, seed=2,
                 obstacles=({"kind": "car", "lane": 1, "position_m": 130.0},))
    run_a, run_b = episodes(run_world(with_roads([a, b]), ["a", "b"]))
    ra, rb = run_a.row, run_b.row
    assert ra["world_egos"] == rb["world_egos"] == 2
    assert ra["termination"] == "collision" and ra["collision_with"] == "vehicle"
    assert ra["collision_vclass"] == "passenger"
    assert ra["collision_role"] == "ran_into" and ra["collision_part"] == "front"
    assert rb["termination"] == "collision" and rb["collision_with"] == "vehicle"
    assert rb["collision_vclass"] == "passenger"
    assert rb["collision_role"] == "was_hit" and rb["collision_part"] == "rear"
    assert ra["collision_time_s"] == rb["collision_time_s"]
    # (50 m - a car's length) at 10 m/s
    assert ra["collision_time_s"] == pytest.approx((50.0 - 4.85) / 10.0, abs=0.2)

    # each one's traffic holds the other where it truly is, from the first step
    assert holds(boxes_at(run_a, 0), own_box(run_b, 0))
    assert holds(boxes_at(run_b, 0), own_box(run_a, 0))
    # and B's parked car (an obstacle of B's run) is a body in A's world too
    parked = run_b.metadata["obstacle_boxes"][0]
    assert holds(boxes_at(run_a, 0), np.array(parked))
    assert run_a.trace.traffic_class[0].count("passenger") == 2
    assert not len(run_a.metadata["obstacle_boxes"])  # A has none of its own

    # A's lidar saw B ahead, closer and closer, well before the hit
    lidar = np.array(run_a.trace.lidar)
    middle = lidar.shape[1] // 2
    ahead = lidar[:, middle - 1: middle + 2].min(axis=1)
    gap_m = 100.0 - 50.0 - 4.85
    assert ahead[0] == pytest.approx(gap_m, abs=3.0)  # B's rear, not the road's end
    hit_step = len(lidar) - 1
    assert ahead[hit_step - 10] < 30.0
    assert np.all(np.diff(ahead[:hit_step]) <= 1e-3)


def test_another_egos_collision_is_its_own_not_the_others_world_overlap():
    """A runs into B while C drives beside them and sees the two overlap at the hit:
    the hit is A's and B's collision (their rows); C's world audit does not count it
    as an overlap the coupling made up."""
    a = straight(50.0, speed_mps=10.0, duration_s=8.0)
    b = straight(100.0, speed_mps=0.0, duration_s=8.0, seed=2)
    c = straight(60.0, lane=1, speed_mps=10.0, duration_s=8.0, seed=3)
    run_a, run_b, run_c = episodes(run_world(with_roads([a, b, c]), ["a", "b", "c"]))
    assert run_a.row["collision_role"] == "ran_into" and run_b.row["collision_role"] == "was_hit"
    hit_step = len(run_a.trace) - 1
    # C saw both egos at the hit, and they overlap there
    seen = boxes_at(run_c, hit_step)
    assert holds(seen, own_box(run_a, hit_step)) and holds(seen, own_box(run_b, hit_step))
    assert pairs_overlap(own_box(run_a, hit_step)[None], own_box(run_b, hit_step)[None])[0]
    assert run_c.row["termination"] == "duration" and not run_c.row["collision"]
    assert run_c.row["world_overlaps"] == 0 and run_c.row["sumo_overlaps"] == 0


def test_another_runs_barrel_is_a_body_with_its_kind_for_a_class():
    """B's barrel stands in A's lane: A sees it as traffic of class "barrel" (no
    vehicle class names it) and runs into it, a collision with traffic; B, in the other
    lane, drives past it on."""
    a = straight(50.0, speed_mps=10.0, duration_s=10.0)
    b = straight(20.0, lane=1, speed_mps=5.0, duration_s=10.0, seed=2,
                 obstacles=({"kind": "barrel", "lane": 0, "position_m": 100.0},))
    run_a, run_b = episodes(run_world(with_roads([a, b]), ["a", "b"]))
    ra, rb = run_a.row, run_b.row
    assert ra["termination"] == "collision" and ra["collision_with"] == "vehicle"
    assert ra["collision_vclass"] == "barrel"
    assert "barrel" in run_a.trace.traffic_class[0]
    assert rb["termination"] == "duration" and not rb["collision"]
    assert len(ra["trace_sha256"]) == len(rb["trace_sha256"]) == 64


def test_a_collision_with_another_runs_body_is_told_from_one_with_traffic():
    """A runs into B, who stands in its lane; in a second world C runs into D's barrel;
    E, alone with flows of traffic and a parked car, runs into it. Each row says whose
    the body hit was (collision_body: other_ego, other_obstacle, obstacle), collision_with
    staying what the body is (a vehicle, a vehicle, an obstacle), and the report's words
    say it too."""
    a = straight(50.0, speed_mps=10.0, duration_s=8.0)
    b = straight(100.0, speed_mps=0.0, duration_s=8.0, seed=2)
    run_a, run_b = episodes(run_world(with_roads([a, b]), ["a", "b"]))
    for row in (run_a.row, run_b.row):
        assert (row["collision_with"], row["collision_vclass"]) == ("vehicle", "passenger")
        assert row["collision_body"] == "other_ego"
    assert what_happened(run_a.row).startswith("hit another run's ego (passenger) with its front")
    assert what_happened(run_b.row).startswith(
        "was hit by another run's ego (passenger) with its rear")

    c = straight(50.0, speed_mps=10.0, duration_s=8.0)
    d = straight(20.0, lane=1, speed_mps=5.0, duration_s=8.0, seed=2,
                 obstacles=({"kind": "barrel", "lane": 0, "position_m": 100.0},))
    run_c, run_d = episodes(run_world(with_roads([c, d]), ["c", "d"]))
    assert run_c.row["collision_body"] == "other_obstacle"
    assert run_c.row["collision_vclass"] == "barrel"
    assert run_d.row["collision_body"] is None and not run_d.row["collision"]

    e = straight(50.0, speed_mps=10.0, duration_s=8.0, flow_vph=600.0,
                 obstacles=({"kind": "car", "lane": 0, "position_m": 100.0},))
    alone = run_episode(e, run_id="e").row
    assert (alone["collision_with"], alone["collision_body"]) == ("obstacle", "obstacle")


def test_a_vehicle_hit_is_traffic_unless_the_world_says_it_is_another_runs():
    """sdc.car.collision.describe: a car touching the ego's side is SUMO's traffic, or
    another run's ego or obstacle where the snapshot's owners say so; a road edge is no
    body."""
    road = make_road(straight(50.0))
    ego = np.array([100.0, 1.75, 0.0, 4.85, 1.93])
    car = np.array([[100.0, 3.4, 0.0, 4.5, 1.8]])
    contacts = Contacts(-1, 0, math.inf)
    traffic = Snapshot(0.0, car, np.zeros((0, 5)), np.zeros(1), np.array(["passenger"]))
    assert describe(VEHICLE, ego, 5.0, contacts, traffic, road, 0.0).body == TRAFFIC
    for owner in (OTHER_EGO, OTHER_OBSTACLE):
        shared = traffic._replace(traffic_owners=np.array([owner], dtype=object))
        assert describe(VEHICLE, ego, 5.0, contacts, shared, road, 0.0).body == owner
    off = np.array([100.0, 8.0, 0.0, 4.85, 1.93])
    assert describe(ROAD_EDGE, off, 5.0, Contacts(-1, -1, math.inf), traffic, road,
                    0.0).body is None


#: city lane widths and a wide one: the egos are bodies to each other on each
LANE_WIDTHS_M = (2.8, 3.2, 3.75)


def two_way_street(folder: Path, lane_width_m: float) -> Path:
    """A netgenerate grid of 3 x 2 junctions 200 m apart, one lane of
    ``lane_width_m`` each way: A0B0 and B0A0 are the two directions of one street,
    their lanes' centres ``lane_width_m`` apart."""
    net = folder / f"street-{lane_width_m}.net.xml"
    subprocess.run([sumo_binary("netgenerate"), "--grid", "--grid.x-number", "3",
                    "--grid.y-number", "2", "--grid.length", "200", "--default.lanenumber",
                    "1", "--default.lanewidth", str(lane_width_m), "--no-turnarounds", "true",
                    "--output-file", str(net)], check=True, capture_output=True)
    return net


def on_street(net: Path, seed: int, start_m: float, speed_mps: float) -> ScenarioSpec:
    """A lane-keeping ego on the route of ``seed`` through ``net``, no traffic, 12 s
    (every ego of one world has the same road spec: its route is its seed's)."""
    return ScenarioSpec.from_plain({
        "scenario": {"name": "street", "duration_s": 12.0, "step_s": STEP_S, "seed": seed},
        "road": {"kind": "sumo_net", "net_file": str(net), "length_m": 180.0},
        "traffic": {"vehicles": 0, "warm_up_s": 0.0},
        "ego": {"lane": 0, "start_m": start_m, "speed_mps": speed_mps},
        "controller": {"name": "lane-keep"}})


def seed_starting_on(net: Path, edge: str) -> int:
    """The first seed whose route through ``net`` starts on ``edge``."""
    return next(seed for seed in range(1, 1000)
                if make_road(on_street(net, seed, 10.0, 10.0)).route_edges(0.0)[0] == edge)


@pytest.mark.parametrize("lane_width_m", LANE_WIDTHS_M)
def test_egos_pass_each_other_on_a_narrow_two_way_street_untouched(tmp_path, lane_width_m):
    """A and B drive toward each other in the two lanes of one street: as they pass,
    each holds the other's true box one lane width across, nobody hits anybody, and
    nothing overlaps that the world made up, on every lane width (an X5 is 1.93 m
    wide: 0.87 m apart on 2.8 m lanes)."""
    net = two_way_street(tmp_path, lane_width_m)
    a = on_street(net, seed_starting_on(net, "A0B0"), 10.0, 10.0)
    b = on_street(net, seed_starting_on(net, "B0A0"), 10.0, 10.0)
    run_a, run_b = episodes(run_world(with_roads([a, b]), ["a", "b"]))
    for row in (run_a.row, run_b.row):
        assert row["termination"] == "duration" and not row["collision"]
        assert row["world_overlaps"] == 0 and row["sumo_overlaps"] == 0
    steps = min(len(run_a.trace), len(run_b.trace))
    gap_m = [own_box(run_b, k)[0] - own_box(run_a, k)[0] for k in range(steps)]
    passing = int(np.argmin(np.abs(gap_m)))
    assert 0 < passing < steps - 1  # they did pass within the runs
    box_a, box_b = own_box(run_a, passing), own_box(run_b, passing)
    assert abs(box_a[1] - box_b[1]) == pytest.approx(lane_width_m, abs=0.15)
    assert holds(boxes_at(run_a, passing), box_b) and holds(boxes_at(run_b, passing), box_a)


@pytest.mark.parametrize("lane_width_m", LANE_WIDTHS_M)
def test_an_ego_runs_into_a_standing_ego_on_every_lane_width(tmp_path, lane_width_m):
    """A at 10 m/s behind B, who stands 60 m ahead in the same lane: one collision, A's
    front into B's rear at the same time in both rows, and no overlap counted as the
    world's."""
    net = two_way_street(tmp_path, lane_width_m)
    seed = seed_starting_on(net, "A0B0")  # one route: B stands on A's
    a, b = on_street(net, seed, 10.0, 10.0), on_street(net, seed, 70.0, 0.0)
    run_a, run_b = episodes(run_world(with_roads([a, b]), ["a", "b"]))
    ra, rb = run_a.row, run_b.row
    assert ra["collision_role"] == "ran_into" and ra["collision_part"] == "front"
    assert rb["collision_role"] == "was_hit" and rb["collision_part"] == "rear"
    assert ra["collision_time_s"] == rb["collision_time_s"]
    assert ra["collision_time_s"] == pytest.approx((60.0 - 4.85) / 10.0, abs=0.2)
    assert ra["world_overlaps"] == rb["world_overlaps"] == 0


def test_every_ego_of_a_world_has_its_own_stand_in_and_nobody_sees_it():
    """B (slot 1) reaches 0.9 m over its right lane line into A's lane (A far ahead),
    3.5 m lanes:
    SUMO holds B inside its lane and a stand-in of B's (``obstacle1.ego.right``) in
    A's lane at B's lane position; neither A nor B senses the stand-in (no box of B's
    snapshot overlaps B), and A's lane's traffic queues behind it, never into B."""
    import libsumo

    from scenarios.sumo.sumo_world import SumoWorld
    from sdc.car.geometry import boxes_overlap

    a = straight(700.0, lane=0, flow_vph=600.0, duration_s=40.0)
    b = straight(300.0, lane=1, flow_vph=600.0, duration_s=40.0)
    road = make_road(a)
    d_b_m = road.lane_center_d_m(1) - 1.75 - 0.9 + 1.93 / 2

    def boxes(k: int) -> dict[int, tuple[np.ndarray, float]]:
        s_a, s_b = 700.0 + 0.5 * k, 300.0 + 0.5 * k
        a_box = np.array([*road.xy_at(s_a, road.lane_center_d_m(0)), 0.0, 4.85, 1.93])
        return {0: (a_box, 5.0), 1: (np.array([*road.xy_at(s_b, d_b_m), 0.0, 4.85, 1.93]), 5.0)}

    behind = 0
    with SumoWorld(a, road, others=((b, road),), source=road_source(a.road)) as world:
        snapshots = world.start_all(boxes(0))
        for k in range(1, 400):
            pushed = boxes(k)
            snapshots = world.step_all(pushed)
            stand_in = "obstacle1.ego.right"
            assert libsumo.vehicle.getLaneID(stand_in) == "road_0"
            assert libsumo.vehicle.getLanePosition(stand_in) == pytest.approx(
                libsumo.vehicle.getLanePosition("ego1"), abs=1e-6)
            assert libsumo.vehicle.getLaneID("ego1") == "road_1"
            assert not boxes_overlap(pushed[1][0], snapshots[1].traffic_boxes).any(), k
            s_m, d_m = road.to_frenet(snapshots[1].traffic_boxes[:, :2])
            in_a_lane = np.abs(d_m - road.lane_center_d_m(0)) < 1.0
            behind += bool(np.any(in_a_lane & (s_m - (300.0 + 0.5 * k) > -40.0)
                                  & (s_m < 300.0 + 0.5 * k)))
    assert behind > 20  # A's lane's traffic came up behind B's stand-in


def test_a_run_alone_sees_no_second_ego():
    """The counterpart of the test above: without B, A drives its whole duration on an
    empty road and senses nothing."""
    a = straight(50.0, speed_mps=10.0, duration_s=3.0)
    (run_a,) = episodes(run_world(with_roads([a]), ["a"]))
    assert run_a.row["termination"] == "duration" and not run_a.row["collision"]
    assert all(len(t) == 0 for t in run_a.trace.traffic)
    assert np.all(np.isinf(np.array(run_a.trace.lidar)))


# ------------------------------------------------------ determinism


@pytest.mark.slow
def test_a_world_of_the_same_runs_gives_the_same_traces_and_counts_its_egos():
    specs = [town(seed) for seed in (11, 12, 13, 14, 15, 16)]
    ids = [f"r{i}" for i in range(len(specs))]
    first = episodes(run_group(specs, ids, 3))
    second = episodes(run_group(specs, ids, 3))
    assert [e.row["trace_sha256"] for e in first] == [e.row["trace_sha256"] for e in second]
    assert [without_wall_time(e.row) for e in first] == [without_wall_time(e.row)
                                                          for e in second]
    assert len({e.row["trace_sha256"] for e in first}) == len(specs)
    assert [e.row["world_egos"] for e in first] == [len(specs)] * len(specs)
    assert [e.row["run_id"] for e in first] == ids
    assert all(e.row["termination"] == "duration" for e in first)
    entries = [e.row["world_entry_step"] for e in first]
    assert entries[0] == 0 and max(entries) > 0  # some entered as seats freed
    assert_seated_apart(first, 3)


def assert_seated_apart(runs: list[Episode], seats: int) -> None:
    """At each step of their world no more than ``seats`` of ``runs`` were in it, and
    each ego entered farther from every other in it than the sum of their sensing
    radii, each where its run starts (read from the traces and rows)."""
    spans = [(e.row["world_entry_step"], e.row["world_entry_step"] + e.row["steps"] - 1)
             for e in runs]
    for step in range(max(end for _, end in spans) + 1):
        assert sum(a <= step <= b for a, b in spans) <= seats, step
    for i, run in enumerate(runs):
        entry = spans[i][0]
        assert run.trace.floats["t_s"][0] == 0.0
        start = own_box(run, 0)[:2]
        for j, other in enumerate(runs):
            if j != i and spans[j][0] <= entry <= spans[j][1]:
                there = own_box(other, entry - spans[j][0])[:2]
                gap_m = np.hypot(*(start - there))
                assert gap_m > (sensing_radius_m(run_spec(run))
                                + sensing_radius_m(run_spec(other))), (i, j, gap_m)


def run_spec(run: Episode) -> ScenarioSpec:
    return ScenarioSpec.from_plain(run.metadata["spec"])


def test_runs_on_routes_of_their_own_share_a_world_each_on_its_own():
    """Two town runs whose roads differ in length and turns (each ego's own) share one
    world; each drives its own road, as it would alone."""
    short = town(12)
    short = dataclasses.replace(short, road=dataclasses.replace(short.road, length_m=150.0))
    turning = town(14)
    turning = dataclasses.replace(turning, road=dataclasses.replace(
        turning.road, length_m=400.0, route_turns="any"))
    egos = with_roads([short, turning])
    assert egos[0][1].length_m < egos[1][1].length_m  # each its own road
    runs = episodes(run_group([short, turning], ["s", "t"], 2))
    assert [run.row["world_egos"] for run in runs] == [2, 2]
    for run, (spec, road) in zip(runs, egos, strict=True):
        assert run.metadata["spec"]["road"] == spec.to_plain()["road"]
        assert run.metadata["road"] == road.to_plain()


def test_an_entering_runs_obstacles_stand_where_its_spec_puts_them():
    """One seat, two town runs: the second enters as the first ends, its car obstacle
    with it. libsumo's own position of each run's obstacle, read as its run begins,
    is where the spec puts it (the body centre, half its length behind SUMO's front
    bumper), and it stands there at its entry as the first run's did at the start."""
    import libsumo

    from scenarios.sumo.routes_xml import ego_names
    from scenarios.world_backends import make_shared_world
    from sdc.run.world_loop import WorldLoop

    seen: dict[int, list[float]] = {}

    class Checked(Simulation):
        def begin(self, snapshot):
            super().begin(snapshot)
            for i, box in enumerate(snapshot.obstacle_boxes):
                vid = f"{ego_names(self.slot).obstacle_prefix}{i}"
                front = np.array(libsumo.vehicle.getPosition(vid))
                yaw = math.radians(90.0 - libsumo.vehicle.getAngle(vid))
                centre = front - box[3] / 2 * np.array([math.cos(yaw), math.sin(yaw)])
                seen.setdefault(self.slot, []).append(
                    float(np.hypot(*(centre - box[:2]))))
                assert libsumo.vehicle.getSpeed(vid) == 0.0

    egos = with_roads([town(12, duration_s=2.0), town(14, duration_s=2.0)])
    world = make_shared_world(egos, None, None)
    sims = [Checked(spec, world, road=road, controller=make_controller(spec.controller),
                    slot=slot) for slot, (spec, road) in enumerate(egos)]
    with world:
        loop = WorldLoop(world, sims, seating=Seats(egos, 1))
        ends = loop.run()
    assert ends == {0: "duration", 1: "duration"}
    assert loop.entered == {0: 0, 1: round(2.0 / STEP_S) + 1}
    assert set(seen) == {0, 1} and all(len(d) == 1 for d in seen.values())
    assert max(max(d) for d in seen.values()) < 0.05, seen


# ------------------------------------------------------ a run that ends leaves


@pytest.mark.parametrize("early_slot", [0, 1])
def test_a_run_that_ends_leaves_and_the_other_goes_on(early_slot):
    """Two egos side by side (lanes 0 and 1, 10 m apart along the road): the one whose
    run is 3 s long leaves the world at its end; the other drives its 6 s, and from the
    step after the first ended, nothing of it is in its traffic."""
    short = straight(100.0, lane=0, speed_mps=8.0, duration_s=3.0, seed=1)
    long = straight(110.0, lane=1, speed_mps=8.0, duration_s=6.0, seed=2)
    specs = [short, long] if early_slot == 0 else [long, short]
    runs = episodes(run_world(with_roads(specs), ["x", "y"]))
    ended, going = (runs[0], runs[1]) if early_slot == 0 else (runs[1], runs[0])
    n_short, n_long = round(3.0 / STEP_S), round(6.0 / STEP_S)
    assert ended.row["termination"] == "duration" and ended.row["steps"] == n_short + 1
    assert going.row["termination"] == "duration" and going.row["steps"] == n_long + 1
    assert going.row["sim_time_s"] == pytest.approx(n_long * STEP_S)
    assert not ended.row["collision"] and not going.row["collision"]
    for k in range(n_short + 1):  # while both are in the world: each sees the other
        assert len(boxes_at(going, k)) == 1 and holds(boxes_at(going, k), own_box(ended, k))
        assert len(boxes_at(ended, k)) == 1 and holds(boxes_at(ended, k), own_box(going, k))
    last = own_box(ended, n_short)
    for k in range(n_short + 1, n_long + 1):  # it left: not even where it stopped
        assert len(boxes_at(going, k)) == 0, k
        assert not holds(boxes_at(going, k), last, tol=5.0)
    # the one that stayed drove on, 8 m/s for its whole run
    s_m = going.trace.floats["s_m"]
    assert s_m[-1] - s_m[0] == pytest.approx(8.0 * n_long * STEP_S, rel=0.02)


@pytest.mark.parametrize("flow_vph", [0.0, 1200.0])
def test_a_waiting_run_enters_as_the_one_in_its_way_leaves(flow_vph):
    """Two egos 100 m apart in one lane (too close to share by the placement rule), two
    seats: the second enters the step after the first's 3 s run ends, where its run
    starts, and drives its own 4 s. Neither ever saw the other; on an empty road the
    late run is its run alone, step for step, and with traffic nothing drove through
    it or anything else (the world's audit)."""
    first = straight(100.0, duration_s=3.0, seed=1, flow_vph=flow_vph)
    second = straight(200.0, duration_s=4.0, seed=2, flow_vph=flow_vph)
    a, b = episodes(run_world(with_roads([first, second]), ["a", "b"], 2))
    n_a, n_b = round(3.0 / STEP_S), round(4.0 / STEP_S)
    assert (a.row["world_entry_step"], b.row["world_entry_step"]) == (0, n_a + 1)
    assert (a.row["steps"], b.row["steps"]) == (n_a + 1, n_b + 1)
    assert b.row["termination"] == "duration" and not b.row["collision"]
    assert not any(holds(boxes_at(a, k), own_box(b, 0), tol=5.0) for k in range(n_a + 1))
    assert b.row["world_overlaps"] == 0 and a.row["world_overlaps"] == 0
    assert b.trace.floats["s_m"][0] == pytest.approx(200.0, abs=0.5)
    if not flow_vph:  # it left as its run ended: the late one never sees it
        assert all(len(boxes_at(b, k)) == 0 for k in range(n_b + 1))
        assert b.row["trace_sha256"] == run_episode(second).row["trace_sha256"]


# ------------------------------------------------------ the placement rule


def seated_first(egos: list[tuple], seats: int | None = None) -> list[int]:
    """The slots of ``egos`` that enter their world as it starts, ``seats`` at a time
    (default: all)."""
    every = list(range(len(egos)))
    return Seats(egos, seats or len(egos)).entering(every, {}, 0)


def test_the_placement_rule_keeps_sensing_radii_apart():
    radius = sensing_radius_m(straight(10.0))
    assert radius == 150.0
    # start points farther apart than the sum of the radii: together
    assert seated_first(with_roads([straight(10.0), straight(400.0)])) == [0, 1]
    assert seated_first(with_roads([straight(10.0), straight(315.0)])) == [0, 1]
    # not farther: the second waits
    assert seated_first(with_roads([straight(10.0), straight(200.0)])) == [0]
    assert seated_first(with_roads([straight(10.0), straight(300.0)])) == [0]
    # lanes do not matter, distance does
    assert seated_first(with_roads([straight(10.0), straight(200.0, lane=1)])) == [0]
    # the first that fit enter, in slot order
    assert seated_first(with_roads([straight(10.0), straight(200.0), straight(400.0),
                                    straight(600.0)])) == [0, 2]


@pytest.mark.parametrize("seats", [1, 2, 3, 4])
def test_no_more_egos_enter_than_the_world_has_seats(seats):
    apart = with_roads([straight(start_m) for start_m in (10.0, 400.0, 790.0)])
    assert seated_first(apart, seats) == [0, 1, 2][:seats]


def test_a_waiting_ego_enters_by_where_the_others_are_now():
    egos = with_roads([straight(10.0), straight(300.0)])
    start = {i: Seats(egos, 2)._runs[i][0] for i in (0, 1)}
    seats = Seats(egos, 2)

    def at(x_m: float) -> dict[int, np.ndarray]:  # the first ego's box, moved along x
        return {0: np.array([start[0][0] + x_m, start[0][1], 0.0, 4.9, 2.0])}

    assert seats.entering([1], at(0.0), 5) == []  # 290 m apart: not yet
    assert seats.entering([1], at(-20.0), 5) == [1]  # driven 20 m away: 310 m
    assert seats.entering([1], {}, 5) == [1]  # the world is empty
    assert Seats(egos, 1).entering([1], at(-20.0), 5) == []  # no seat free


def test_an_obstacle_within_another_egos_radius_splits_them():
    far = ({"kind": "car", "lane": 1, "position_m": 200.0},)  # 200 m from the ego at 400
    near = ({"kind": "car", "lane": 1, "position_m": 300.0},)  # 100 m from it
    assert seated_first(with_roads([straight(10.0, obstacles=far), straight(400.0)])) == [0, 1]
    assert seated_first(with_roads([straight(10.0, obstacles=near),
                                    straight(400.0)])) == [0]
    # the other way round: the second ego's obstacle (ahead of it) near the first
    ahead = ({"kind": "barrel", "lane": 0, "position_m": 500.0},)  # 100 m from the ego at 600
    clear = ({"kind": "barrel", "lane": 0, "position_m": 400.0},)  # 200 m from it
    assert seated_first(with_roads([straight(600.0),
                                    straight(200.0, obstacles=ahead)])) == [0]
    assert seated_first(with_roads([straight(600.0),
                                    straight(200.0, obstacles=clear)])) == [0, 1]


def test_the_rule_sums_each_egos_own_radius():
    wide = straight(400.0, max_range_m=200.0)  # 225 m
    assert sensing_radius_m(wide) == 225.0
    # 390 m apart: 150 + 225 = 375 fit, 225 + 225 = 450 do not
    assert seated_first(with_roads([straight(10.0), wide])) == [0, 1]
    assert seated_first(with_roads([straight(10.0, max_range_m=200.0), wide])) == [0]
