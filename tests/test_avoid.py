"""The closed-loop avoid controller: unit tests on a fake straight road (boxes
ray-cast with the car's own lidar kernel), whole runs in libsumo."""

from __future__ import annotations

import math

import numpy as np
import pytest

from scenarios import CATALOG_DIR, ScenarioSpec, SpecError, load_spec
from scenarios.spec.bodies import VEHICLE_MODELS
from scenarios.spec.controller_params import AvoidParams
from scenarios.spec.controller_spec import ControllerSpec
from scenarios.spec.scenario_tables import beam_angles_rad
from sdc.car.avoid.controller import (
    AVOID_LEFT,
    AVOID_RETURN,
    AVOID_RIGHT,
    BRAKE,
    CRUISE,
    AvoidController,
)
from sdc.car.controller_api import Command, Observation
from sdc.car.controller_plugins import make_controller
from sdc.car.controllers import SeedController
from sdc.car.geometry_kernels import lidar_ranges_m
from sdc.car.sensors import LaneReading
from sdc.car.vehicle import Vehicle, VehicleState

MODEL = VEHICLE_MODELS["x5-lesson"]
ANGLES = beam_angles_rad(180, 180.0)
LANE_W = 3.5
STEP_S = 0.064
CENTER_AHEAD_M = MODEL.length_m / 2 - MODEL.rear_overhang_m
FRONT_AHEAD_M = MODEL.length_m - MODEL.rear_overhang_m  # of the rear axle


class FakeRoad:
    """A straight road along +x, its lanes' centres at y = k * LANE_W (the car's
    own lane at y = 0), ``lanes_left`` lanes left of it and ``lanes_right`` right."""

    def __init__(self, boxes=(), lanes_left=2, lanes_right=0, angles=ANGLES):
        self.boxes = np.array(boxes, dtype=float).reshape(-1, 5)
        left, right = (lanes_left + 0.5) * LANE_W, -(lanes_right + 0.5) * LANE_W
        self.edges = np.array([[-100.0, left, 400.0, left], [-100.0, right, 400.0, right]])
        self.angles = angles

    def observe(self, state: VehicleState, t_s: float = 3.2) -> Observation:
        yaw = state.yaw_rad
        origin = np.array([state.x_m + 3.85 * math.cos(yaw), state.y_m + 3.85 * math.sin(yaw)])
        ranges = lidar_ranges_m(origin, yaw, self.angles, self.boxes, self.edges, 80.0)
        ranges.flags.writeable = False
        cx = state.x_m + CENTER_AHEAD_M * math.cos(yaw)
        cy = state.y_m + CENTER_AHEAD_M * math.sin(yaw)
        preview = cy + 5.0 * math.sin(yaw)
        lane = LaneReading(cy, yaw, preview, cx)
        return Observation(t_s, STEP_S, ranges, self.angles, 3.85, lane, LANE_W,
                           state.speed_mps, state.steer_rad, MODEL, 80.0)


def barrel(ahead_of_front_m: float, lateral_m: float = 0.0) -> list[float]:
    """A 0.6 m barrel whose near face is ``ahead_of_front_m`` ahead of the car's
    front bumper (the car at x = 0 on its lane's centre)."""
    return [FRONT_AHEAD_M + ahead_of_front_m + 0.3, lateral_m, 0.0, 0.6, 0.6]


def car_at(x_m: float, y_m: float) -> list[float]:
    return [x_m, y_m, 0.0, 4.5, 1.8]


def at_speed(speed_mps: float, y_m: float = 0.0) -> VehicleState:
    return VehicleState(0.0, y_m, 0.0, speed_mps, 0.0)


def watched(controller: AvoidController, road: FakeRoad, state: VehicleState) -> None:
    """A first step at t = 0 with nothing around: the lanes' watch starts then."""
    controller.step(FakeRoad(lanes_left=road_lanes(road)[0],
                             lanes_right=road_lanes(road)[1]).observe(state, 0.0))


def road_lanes(road: FakeRoad) -> tuple[int, int]:
    left, right = road.edges[0, 1], road.edges[1, 1]
    return round(left / LANE_W - 0.5), round(-right / LANE_W - 0.5)


def first_step(road: FakeRoad, state: VehicleState, **params) -> tuple[Command, str]:
    controller = AvoidController(params)
    watched(controller, road, state)
    command = controller.step(road.observe(state))
    return command, controller.phase


# ---- detection -------------------------------------------------------------------

def test_an_off_centre_barrel_the_seed_misses_is_detected_by_time_to_collision():
    road = FakeRoad([barrel(4.0, lateral_m=1.3)])  # near the lane's left edge, 4 m ahead
    obs = road.observe(at_speed(3.74))
    assert not SeedController({}).detects(obs.ranges_m)  # outside its 11 central beams
    controller = AvoidController({})
    watched(controller, road, at_speed(3.74))
    controller.step(obs)
    assert controller.phase != CRUISE


def test_detection_is_by_time_to_collision_not_range():
    road = FakeRoad([barrel(50.0, lateral_m=-1.0)])
    assert first_step(road, at_speed(10.0))[1] == CRUISE  # 5 s away
    assert first_step(road, at_speed(15.0))[1] == AVOID_LEFT  # 3.3 s away
    assert first_step(road, at_speed(15.0), detect_ttc_s=3.0)[1] == CRUISE


def test_nothing_in_the_lane_keeps_cruising_at_the_cruise_speed():
    road = FakeRoad([car_at(30.0, LANE_W)])  # a car in the next lane is not in the way
    command, phase = first_step(road, at_speed(10.0), cruise_speed_mps=12.0)
    assert phase == CRUISE and command.accel_mps2 > 0 and command.steer_rad == 0.0
    command, phase = first_step(road, at_speed(10.0))  # cruise = the first step's speed
    assert phase == CRUISE and command.accel_mps2 == 0.0


def test_a_kerb_jutting_into_the_lane_is_not_in_the_way():
    road = FakeRoad([], lanes_left=1, lanes_right=0)
    kerb_y = -LANE_W / 2 + 0.25  # a junction's corner, 0.25 m into the lane
    road.edges = np.vstack([road.edges, [[20.0, kerb_y, 30.0, kerb_y]]])
    assert first_step(road, at_speed(10.0))[1] == CRUISE
    assert first_step(road, at_speed(10.0), path_clearance_m=0.6)[1] != CRUISE


# ---- side choice -----------------------------------------------------------------

def test_left_first_when_the_left_is_free():
    command, phase = first_step(FakeRoad([barrel(20.0)], lanes_left=1, lanes_right=1),
                                at_speed(8.0))
    assert phase == AVOID_LEFT and command.steer_rad > 0 and command.accel_mps2 == 0.0


def test_right_when_a_return_blocks_the_left_corridor():
    road = FakeRoad([barrel(20.0), car_at(40.0, LANE_W)], lanes_left=1, lanes_right=1)
    command, phase = first_step(road, at_speed(8.0))
    assert phase == AVOID_RIGHT and command.steer_rad < 0


def test_the_road_edge_blocks_a_side():
    road = FakeRoad([barrel(20.0), car_at(40.0, LANE_W)], lanes_left=1, lanes_right=0)
    command, phase = first_step(road, at_speed(8.0))
    assert phase == BRAKE and command.accel_mps2 < 0


def test_both_sides_blocked_brakes_and_says_so():
    road = FakeRoad([barrel(20.0), car_at(40.0, LANE_W), car_at(40.0, -LANE_W)],
                    lanes_left=1, lanes_right=1)
    command, phase = first_step(road, at_speed(8.0))
    assert phase == BRAKE and command.accel_mps2 < 0


def test_traffic_seen_beside_keeps_the_car_out_of_that_lane():
    road = FakeRoad([barrel(20.0)], lanes_left=1, lanes_right=0)
    controller = AvoidController({})
    state = at_speed(8.0)
    watched(controller, road, state)
    controller.step(FakeRoad([car_at(CENTER_AHEAD_M + 2.0, LANE_W)], 1, 0).observe(state, 1.0))
    controller.step(road.observe(state, 5.0))  # watched empty since, but traffic was there
    assert controller.phase == BRAKE
    fresh = AvoidController({})
    watched(fresh, road, state)
    fresh.step(road.observe(state, 5.0))
    assert fresh.phase == AVOID_LEFT


def test_an_unwatched_lane_only_to_escape_a_collision_braking_cannot():
    road = FakeRoad([barrel(20.0)], lanes_left=1, lanes_right=0)
    controller = AvoidController({})
    controller.step(road.observe(at_speed(8.0), 0.0))  # the run's first step
    assert controller.phase == BRAKE  # 4 m to stop, the lane not watched yet
    controller = AvoidController({})
    command = controller.step(road.observe(at_speed(20.0), 0.0))  # 25 m to stop
    assert controller.phase == AVOID_LEFT and command.accel_mps2 < 0


# ---- rear view -------------------------------------------------------------------

ALL_ROUND = beam_angles_rad(360, 360.0)


def waiting_behind_a_barrel(angles, passing_speed_mps: float = 20.0, queued: bool = False):
    """The car stopped 7 m behind a barrel; a car passes in the left lane from 40 m
    behind at ``passing_speed_mps`` (with ``queued``: another stands 2 m behind the
    car in its own lane). The phases step by step, and the passing car's x."""
    controller, state = AvoidController({}), at_speed(0.0)
    phases, xs = [], []
    for k in range(round(8.0 / STEP_S)):
        passing_x = -40.0 + passing_speed_mps * k * STEP_S
        boxes = [barrel(7.0), car_at(passing_x, LANE_W)]
        if queued:
            boxes.append(car_at(-MODEL.rear_overhang_m - 2.0 - 2.25, 0.0))
        road = FakeRoad(boxes, lanes_left=1, lanes_right=0, angles=angles)
        controller.step(road.observe(state, k * STEP_S))
        phases.append(controller.phase)
        xs.append(passing_x)
    return phases, np.array(xs)


def test_with_a_rear_view_the_car_pulls_out_only_once_the_gap_stays_open():
    phases, xs = waiting_behind_a_barrel(ALL_ROUND)
    out = phases.index(AVOID_LEFT)
    assert all(p == BRAKE for p in phases[:out])
    # the passing car's rear is ahead of the car's front: it has gone by
    assert xs[out] - 2.25 > FRONT_AHEAD_M
    # with the lesson's front lidar the car that went by keeps the lane closed
    front_phases, _ = waiting_behind_a_barrel(ANGLES)
    assert AVOID_LEFT not in front_phases


def test_a_gap_too_short_for_the_closing_speed_keeps_the_lane_closed():
    controller = AvoidController({})
    for k in range(10):  # closing at 20 m/s: 10 m + 3 s x 20 m/s is 70 m, more than 60
        x = -60.0 + 20.0 * k * STEP_S
        road = FakeRoad([barrel(7.0), car_at(x, LANE_W)], 1, 0, ALL_ROUND)
        controller.step(road.observe(at_speed(0.0), k * STEP_S))
        assert controller.phase == BRAKE
    slow = AvoidController({})  # the same gap closing at 2 m/s stays open long enough
    for k in range(10):
        x = -60.0 + 2.0 * k * STEP_S
        road = FakeRoad([barrel(7.0), car_at(x, LANE_W)], 1, 0, ALL_ROUND)
        slow.step(road.observe(at_speed(0.0), k * STEP_S))
    assert slow.phase == AVOID_LEFT


def test_a_car_standing_close_behind_in_the_next_lane_leaves_it_open():
    """A car stands 3 m behind the car's rear in the lane beside (queued, waiting to
    merge): what comes behind it must stop behind it, so the lane is open to pull
    out into; the same car closing at 8 m/s keeps it closed."""
    def phases(speed_mps: float) -> list[str]:
        controller = AvoidController({})
        rear_x = -MODEL.rear_overhang_m
        out = []
        for k in range(round(3.0 / STEP_S)):
            x = rear_x - 3.0 - 2.25 - speed_mps * (3.0 - k * STEP_S)
            road = FakeRoad([barrel(7.0), car_at(x, LANE_W)], 1, 0, ALL_ROUND)
            controller.step(road.observe(at_speed(0.0), k * STEP_S))
            out.append(controller.phase)
        return out

    assert AVOID_LEFT in phases(0.0)
    assert AVOID_LEFT not in phases(8.0)


def test_a_car_queued_behind_hides_the_next_lane():
    phases, _ = waiting_behind_a_barrel(ALL_ROUND, queued=True)
    assert AVOID_LEFT not in phases  # the lane behind it unseen is not open
    clear, _ = waiting_behind_a_barrel(ALL_ROUND)
    assert AVOID_LEFT in clear


# ---- feedback --------------------------------------------------------------------

def test_steering_feeds_back_toward_the_lateral_target():
    road = FakeRoad([barrel(20.0)], lanes_left=1, lanes_right=0)
    controller = AvoidController({})
    watched(controller, road, at_speed(8.0))
    controller.step(road.observe(at_speed(8.0)))
    assert controller.phase == AVOID_LEFT and controller.target_m >= LANE_W
    far = road.observe(VehicleState(0.0, controller.target_m + 1.0, 0.0, 8.0, 0.0))
    on = road.observe(VehicleState(0.0, controller.target_m, 0.0, 8.0, 0.0))
    short = road.observe(VehicleState(0.0, controller.target_m - 1.0, 0.0, 8.0, 0.0))
    assert controller.step(far).steer_rad < 0
    assert controller.step(on).steer_rad == pytest.approx(0.0, abs=1e-9)
    assert controller.step(short).steer_rad > 0
    # pointing toward the target already: steer less than when straight
    turned = road.observe(VehicleState(0.0, controller.target_m - 1.0, 0.2, 8.0, 0.0))
    assert controller.step(turned).steer_rad < controller.step(short).steer_rad


def drive(road: FakeRoad, state: VehicleState, seconds: float, **params):
    """Close the loop on the fake road: (states, phases), stopping at a contact."""
    controller, vehicle = AvoidController(params), Vehicle(MODEL, 0.9)
    states, phases = [], []
    for k in range(round(seconds / STEP_S)):
        command = controller.step(road.observe(state, k * STEP_S))
        states.append(state)
        phases.append(controller.phase)
        state = vehicle.step(state, command, STEP_S)
        front = state.x_m + FRONT_AHEAD_M
        if any(abs(b[1] - state.y_m) < (b[4] + MODEL.width_m) / 2 and front > b[0] - b[3] / 2
               and state.x_m - MODEL.rear_overhang_m < b[0] + b[3] / 2 for b in road.boxes):
            raise AssertionError(f"touched a box at {k * STEP_S:.2f} s")
    return states, phases


def test_brakes_to_a_stop_short_of_an_obstacle_it_cannot_pass():
    block = barrel(30.0)
    road = FakeRoad([block, car_at(block[0], LANE_W)], lanes_left=1, lanes_right=0)
    states, phases = drive(road, at_speed(15.0), 10.0)
    assert BRAKE in phases and not any(p.startswith("avoid_") for p in phases)
    assert states[-1].speed_mps == 0.0
    gap = road.boxes[0, 0] - 0.3 - (states[-1].x_m + FRONT_AHEAD_M)
    assert 1.0 < gap < 10.0


def test_closed_loop_round_a_barrel_and_back():
    road = FakeRoad([barrel(80.0, lateral_m=0.5)], lanes_left=1, lanes_right=0)
    states, phases = drive(road, at_speed(10.0), 18.0)  # seen at 40 m, after the watch
    kinds = [p for i, p in enumerate(phases) if i == 0 or phases[i - 1] != p]
    assert kinds == [CRUISE, AVOID_LEFT, AVOID_RETURN, CRUISE]
    y = np.array([s.y_m for s in states])
    assert y.max() == pytest.approx(LANE_W, abs=0.6)  # held near the next lane's centre
    assert abs(y[-1]) < 0.1 and min(s.speed_mps for s in states) > 9.9
    beside = [s.y_m for s in states if abs(s.x_m + CENTER_AHEAD_M - road.boxes[0, 0]) < 3.0]
    assert min(beside) > 2.0  # passed with the barrel well clear


def test_traffic_far_ahead_in_the_lane_does_not_hold_the_car_out():
    far = barrel(180.0)  # 100 m beyond the first barrel
    road = FakeRoad([barrel(80.0, lateral_m=0.5), far], lanes_left=1, lanes_right=0)
    states, phases = drive(road, at_speed(10.0), 13.0)
    kinds = [p for i, p in enumerate(phases) if i == 0 or phases[i - 1] != p]
    assert kinds == [CRUISE, AVOID_LEFT, AVOID_RETURN, CRUISE]
    assert abs(states[-1].y_m) < 0.3 and states[-1].x_m + FRONT_AHEAD_M < far[0] - 30


def test_params_are_validated_and_named():
    with pytest.raises(SpecError, match="controller.detect_ttc_s"):
        AvoidController({"detect_ttc_s": -1.0})
    with pytest.raises(SpecError, match="controller.bogus"):
        AvoidController({"bogus": 1})
    assert isinstance(make_controller(ControllerSpec("avoid", AvoidParams())), AvoidController)


# ---- whole runs in libsumo -------------------------------------------------------

@pytest.fixture(scope="module")
def lesson() -> ScenarioSpec:
    return load_spec(CATALOG_DIR / "seed-lesson.toml").with_controller("avoid")


@pytest.mark.slow
def test_seed_lesson_avoid_passes_and_returns(lesson):
    from sdc.run.episode import run_episode

    episode = run_episode(lesson)
    row = episode.row
    assert row["collision"] is False and row["collision_with"] == "none"
    assert row["maneuver_started"] is True and row["returned_to_lane"] is True
    assert 2.5 < row["max_abs_lane_offset_m"] < 4.5  # one lane over, closed loop
    assert row["min_gap_obstacle_m"] > 1.0
    speeds = episode.trace.floats["speed_mps"]
    assert np.all(np.abs(speeds - 3.74) < 1e-9)  # cruised through at the start's speed


@pytest.mark.slow
def test_obstacles_in_every_lane_stop_the_car_without_collision(lesson_plain):
    from sdc.run.episode import run_episode

    plain = lesson_plain
    plain["controller"] = {"name": "avoid"}
    plain["ego"]["speed_mps"] = 12.0
    plain["obstacles"] = [{"kind": "car", "lane": lane, "position_m": 50.0}
                          for lane in range(3)]
    plain["scenario"]["duration_s"] = 15.0
    episode = run_episode(ScenarioSpec.from_plain(plain))
    row = episode.row
    assert row["collision"] is False and row["termination"] == "duration"
    assert row["maneuver_started"] is False
    assert episode.trace.phase[-1] == BRAKE
    assert episode.trace.floats["speed_mps"][-1] == 0.0
    assert 0.5 < row["min_gap_obstacle_m"] < 10.0


@pytest.mark.slow
def test_avoid_runs_are_deterministic(lesson):
    from sdc.run.episode import run_episode

    busy = lesson.with_seed(5)
    first, second = run_episode(busy).row, run_episode(busy).row
    assert first["trace_sha256"] == second["trace_sha256"]
