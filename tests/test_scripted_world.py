"""The scripted backend: a world without a simulator (scenarios/scripted/scripted_world.py)."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from scenarios import CATALOG_DIR, load_spec
from scenarios.common.errors import SdcError, SpecError
from scenarios.scripted.scripted_world import CAR_SIZE_M, ScriptedWorld
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.world_backends import BACKENDS, make_road, make_world
from sdc.run.episode import run_episode

LESSON = CATALOG_DIR / "seed-lesson.toml"
#: the lesson on this backend: the base of the tests of sweeps, reports and replays
SCRIPTED_LESSON = Path(__file__).parent / "data" / "seed-lesson-scripted.toml"


def traffic_spec(lesson_plain, **traffic) -> ScenarioSpec:
    plain = copy.deepcopy(lesson_plain)
    plain["road"].update(length_m=400.0, speed_limit_mps=27.78)
    plain["traffic"] = {"flow_vph_per_lane": 900.0, "speed_mean_mps": 20.0, **traffic}
    plain["ego"].update(start_m=150.0, speed_mps=0.0)
    for obstacle in plain["obstacles"]:
        obstacle["position_m"] = 250.0
    plain["scenario"].update(backend="scripted", duration_s=10.0, seed=4)
    plain["controller"] = {"name": "lane-keep"}
    return ScenarioSpec.from_plain(plain)


def ego_box(spec: ScenarioSpec, road) -> np.ndarray:
    (x, y), = road.xy_at(np.array([spec.ego.start_m]), road.lane_center_d_m(spec.ego.lane))
    return np.array([x, y, 0.0, 4.85, 1.93])


def drive(spec: ScenarioSpec, steps: int) -> list:
    road = make_road(spec)
    box = ego_box(spec, road)
    with make_world(spec, road) as world:
        assert isinstance(world, ScriptedWorld) and world.backend == "scripted"
        return [world.start(box, 0.0)] + [world.step(box, 0.0) for _ in range(steps)]


def test_scripted_is_a_backend_a_spec_and_the_cli_accept():
    assert "scripted" in BACKENDS
    spec = load_spec(LESSON).with_backend("scripted")
    assert spec.scenario.backend == "scripted"
    with pytest.raises(SdcError, match="GUI"):
        make_world(spec, make_road(spec), gui=True)


def test_a_network_road_is_bad_input_on_the_scripted_backend(lesson_plain):
    plain = copy.deepcopy(lesson_plain)
    plain["scenario"]["backend"] = "scripted"
    plain["road"] = {"kind": "sumo_net", "net_file": "town.net.xml", "length_m": 100.0}
    with pytest.raises(SpecError, match="scenario.backend"):
        ScenarioSpec.from_plain(plain)


def test_obstacles_stand_where_the_spec_puts_them_and_the_clock_ticks():
    spec = load_spec(LESSON).with_backend("scripted")
    snapshots = drive(spec, 3)
    road = make_road(spec)
    (x, y), = road.xy_at(np.array([40.0]), road.lane_center_d_m(0))
    assert np.allclose(snapshots[0].obstacle_boxes[:, :2], [[x, y]])
    assert [s.t_s for s in snapshots] == pytest.approx([0.064 * k for k in range(1, 5)])
    assert all(len(s.traffic_boxes) == 0 for s in snapshots)


def test_traffic_boxes_drive_their_lanes_at_constant_speed_and_deterministically(lesson_plain):
    spec = traffic_spec(lesson_plain, warm_up_s=30.0)
    snapshots = drive(spec, 40)
    again = drive(spec, 40)
    for a, b in zip(snapshots, again, strict=True):
        assert np.array_equal(a.traffic_boxes, b.traffic_boxes)
    first = snapshots[0]
    assert len(first.traffic_boxes) >= 6  # warmed up: the road starts full
    assert np.all(first.traffic_boxes[:, 3:] == CAR_SIZE_M)
    assert set(first.traffic_classes) == {"passenger"}
    road = make_road(spec)
    centres = np.array([road.lane_center_d_m(i) for i in range(3)])
    for snapshot in snapshots:  # on a lane centre, at the lane's speed, none overlapping
        s, d = road.to_frenet(snapshot.traffic_boxes[:, :2])
        assert np.min(np.abs(d[:, None] - centres), axis=1) == pytest.approx(0.0, abs=1e-9)
        for lane in range(3):
            mine = np.sort(s[np.abs(d - centres[lane]) < 0.1])
            assert np.all(np.diff(mine) > CAR_SIZE_M[0])
    # a car seen in two snapshots moved its speed times the time between them
    s0, d0 = road.to_frenet(first.traffic_boxes[:, :2])
    s1, d1 = road.to_frenet(snapshots[10].traffic_boxes[:, :2])
    rear = np.argmin(s0 + 1e3 * (np.abs(d0 - centres[2]) > 0.1))  # the rearmost in lane 2
    v = first.traffic_speeds_mps[rear]
    moved = s1[np.abs(d1 - centres[2]) < 0.1] - s0[rear]
    assert np.min(np.abs(moved - v * 10 * 0.064)) < 1e-9
    # another traffic seed, another script
    other = drive(spec.with_seed(5), 0)[0]
    assert not np.array_equal(other.traffic_boxes, first.traffic_boxes)


def test_without_a_warm_up_traffic_enters_at_the_start_and_clears_the_ego(lesson_plain):
    spec = traffic_spec(lesson_plain)
    snapshots = drive(spec, 400)
    assert len(snapshots[0].traffic_boxes) == 0
    road = make_road(spec)
    entered = [road.to_frenet(s.traffic_boxes[:, :2])[0] for s in snapshots]
    assert max(len(s) for s in entered) >= 6 and min(np.min(s) for s in entered if len(s)) < 2
    # a lane with an obstacle in it has no traffic (it would drive through the barrel)
    d = np.concatenate([road.to_frenet(s.traffic_boxes[:, :2])[1] for s in snapshots[1:]])
    assert not np.any(np.abs(d - road.lane_center_d_m(0)) < 0.1)


def test_cars_in_the_egos_way_where_it_enters_are_taken_off(lesson_plain):
    plain = copy.deepcopy(lesson_plain)
    plain["obstacles"] = []
    spec = traffic_spec(plain, warm_up_s=30.0, flow_vph_per_lane=3000.0)
    first = drive(spec, 0)[0]
    road = make_road(spec)
    s, d = road.to_frenet(first.traffic_boxes[:, :2])
    near = np.abs(d - road.lane_center_d_m(0)) < 1.5 * 3.5
    # its lane and the next, from 30 m behind its rear to 10 m past its front (less the
    # bodies and a step's move): where 3000 cars an hour would put a car or two a lane
    assert not np.any(near & (s > 120.0) & (s < 160.0))


def test_slots_leave_and_the_world_has_no_witness(lesson_plain):
    spec = traffic_spec(lesson_plain)
    road = make_road(spec)
    box = ego_box(spec, road)
    with ScriptedWorld(spec, road) as world:
        assert world.twin() is None and world.warm_state_key is None
        assert world.signal_cycles_s == {}
        assert set(world.start_all({0: (box, 0.0), 1: (box, 0.0)})) == {0, 1}
        world.leave(1)
        assert set(world.step_all({0: (box, 0.0)})) == {0}
        assert world.vehicle_count() >= 0
        with pytest.raises(SdcError, match="no driver"):
            world.step_all({0: None})


def test_without_traffic_the_trace_is_sumos_bit_for_bit():
    spec = load_spec(LESSON)
    sumo, scripted = run_episode(spec), run_episode(spec.with_backend("scripted"))
    assert scripted.row["backend"] == "scripted"
    assert sumo.row["trace_sha256"] == scripted.row["trace_sha256"]


def test_sdc_run_takes_the_scripted_backend():
    from sdc.cli import main

    result = CliRunner().invoke(main, ["run", str(LESSON), "--backend", "scripted", "--json"])
    assert result.exit_code == 0, result.output
    row = json.loads(result.output.strip().splitlines()[-1])
    assert row["backend"] == "scripted" and row["returned_to_lane"] and not row["collision"]


def test_the_tests_scripted_lesson_is_the_catalogs_but_for_its_backend():
    assert load_spec(SCRIPTED_LESSON) == load_spec(LESSON).with_backend("scripted")
