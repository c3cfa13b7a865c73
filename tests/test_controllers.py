from __future__ import annotations

import numpy as np

from scenarios.scenario_spec import ControllerSpec, LaneKeepParams, SeedParams
from sdc.car.controllers import (
    AVOID_LEFT,
    AVOID_RIGHT,
    AVOID_STRAIGHT,
    LANE_KEEP,
    LaneKeepController,
    SeedController,
    make_controller,
)
from sdc.car.sensors import LaneReading

CLEAR = np.full(180, np.inf)


def reading(preview_offset_m: float) -> LaneReading:
    return LaneReading(preview_offset_m, 0.0, preview_offset_m, 10.0)


def obstacle_at(range_m: float, beam: int = 90) -> np.ndarray:
    ranges = CLEAR.copy()
    ranges[beam] = range_m
    return ranges


def test_seed_runs_left_straight_right_open_loop_then_keeps_the_lane():
    controller = SeedController(SeedParams())
    command, phase = controller.step(obstacle_at(4.9), reading(0.0))
    steps = [(command.steer_rad, phase)]
    for _ in range(39):  # sensors are ignored meanwhile, whatever they say
        command, phase = controller.step(obstacle_at(1.0), reading(3.0))
        steps.append((command.steer_rad, phase))
    assert steps == ([(0.7, AVOID_LEFT)] * 10 + [(0.0, AVOID_STRAIGHT)] * 20
                     + [(-0.7, AVOID_RIGHT)] * 10)
    command, phase = controller.step(CLEAR, reading(2.0))  # left of the lane: steer right
    assert (command.steer_rad, phase) == (-0.1, LANE_KEEP)


def test_seed_detection_window_is_the_11_central_beams_below_5_m():
    controller = SeedController(SeedParams())
    assert controller.detects(obstacle_at(4.99, 85)) and controller.detects(obstacle_at(4.99, 95))
    assert not controller.detects(obstacle_at(4.99, 84))
    assert not controller.detects(obstacle_at(4.99, 96))
    assert not controller.detects(obstacle_at(5.0, 90))


def test_lane_keeping_is_bang_bang_and_keeps_the_last_angle():
    controller = LaneKeepController(LaneKeepParams(deadband_m=0.05))
    assert controller.step(CLEAR, reading(-0.3))[0].steer_rad == 0.1  # right of centre: left
    assert controller.step(CLEAR, reading(0.01))[0].steer_rad == 0.1  # in the band: keep
    assert controller.step(CLEAR, reading(0.3))[0].steer_rad == -0.1
    assert controller.step(CLEAR, None)[0].steer_rad == -0.1  # lane not sensed: keep


def test_lane_keep_never_avoids():
    controller = make_controller(ControllerSpec("lane-keep", LaneKeepParams()))
    command, phase = controller.step(obstacle_at(0.5), reading(0.0))
    assert phase == LANE_KEEP and command.steer_rad == 0.0
