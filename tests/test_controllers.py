from __future__ import annotations

import numpy as np

from scenarios.spec.bodies import VEHICLE_MODELS
from scenarios.spec.controller_params import LaneKeepParams
from scenarios.spec.controller_spec import ControllerSpec
from scenarios.spec.scenario_tables import beam_angles_rad
from sdc.car.controller_api import Observation
from sdc.car.controller_plugins import make_controller
from sdc.car.controllers import (
    AVOID_LEFT,
    AVOID_RIGHT,
    AVOID_STRAIGHT,
    LANE_KEEP,
    LaneKeepController,
    SeedController,
)
from sdc.car.sensors import LaneReading

CLEAR = np.full(180, np.inf)


def obs(ranges: np.ndarray, lane: LaneReading | None) -> Observation:
    return Observation(0.0, 0.064, ranges, beam_angles_rad(180, 180.0), 3.85, lane, 3.5,
                       3.74, 0.0, VEHICLE_MODELS["x5-lesson"])


def steps(controller, ranges, lane):
    command = controller.step(obs(ranges, lane))
    return command, controller.phase


def reading(preview_offset_m: float) -> LaneReading:
    return LaneReading(preview_offset_m, 0.0, preview_offset_m, 10.0)


def obstacle_at(range_m: float, beam: int = 90) -> np.ndarray:
    ranges = CLEAR.copy()
    ranges[beam] = range_m
    return ranges


def test_seed_runs_left_straight_right_open_loop_then_keeps_the_lane():
    controller = SeedController({})
    command, phase = steps(controller, obstacle_at(4.9), reading(0.0))
    seen = [(command.steer_rad, phase)]
    for _ in range(39):  # sensors are ignored meanwhile, whatever they say
        command, phase = steps(controller, obstacle_at(1.0), reading(3.0))
        seen.append((command.steer_rad, phase))
    assert seen == ([(0.7, AVOID_LEFT)] * 10 + [(0.0, AVOID_STRAIGHT)] * 20
                     + [(-0.7, AVOID_RIGHT)] * 10)
    command, phase = steps(controller, CLEAR, reading(2.0))  # left of the lane: steer right
    assert (command.steer_rad, phase) == (-0.1, LANE_KEEP)


def test_seed_detection_window_is_the_11_central_beams_below_5_m():
    controller = SeedController({})
    assert controller.detects(obstacle_at(4.99, 85)) and controller.detects(obstacle_at(4.99, 95))
    assert not controller.detects(obstacle_at(4.99, 84))
    assert not controller.detects(obstacle_at(4.99, 96))
    assert not controller.detects(obstacle_at(5.0, 90))


def test_lane_keeping_is_bang_bang_and_keeps_the_last_angle():
    controller = LaneKeepController({"deadband_m": 0.05})
    assert steps(controller, CLEAR, reading(-0.3))[0].steer_rad == 0.1  # right of centre: left
    assert steps(controller, CLEAR, reading(0.01))[0].steer_rad == 0.1  # in the band: keep
    assert steps(controller, CLEAR, reading(0.3))[0].steer_rad == -0.1
    assert steps(controller, CLEAR, None)[0].steer_rad == -0.1  # lane not sensed: keep


def test_lane_keep_never_avoids():
    controller = make_controller(ControllerSpec("lane-keep", LaneKeepParams()))
    command, phase = steps(controller, obstacle_at(0.5), reading(0.0))
    assert phase == LANE_KEEP and command.steer_rad == 0.0


# ---- the registry of built-ins -----------------------------------------------------

def test_one_line_of_the_registry_makes_a_built_in_whole():
    """Each line of ``BUILTIN_CONTROLLERS`` names the class and its parameters' class:
    the spec validates the table into that class, the sweep takes its fields, and the
    plug-in machinery builds the class from it, with nothing listed anywhere else."""
    import dataclasses

    from scenarios.spec import controller_params, controller_spec
    from scenarios.spec.controller_ref import BUILTIN_CONTROLLERS, controller_kind
    from sdc.car.controller_plugins import controller_class

    assert tuple(controller_params.CONTROLLER_PARAMS) == tuple(BUILTIN_CONTROLLERS)
    for name, builtin in BUILTIN_CONTROLLERS.items():
        params = controller_params.CONTROLLER_PARAMS[name]
        assert params.__name__ == builtin.params and params.__module__ == controller_params.__name__
        assert controller_kind(name) == "builtin"
        cls = controller_class(name)
        assert f"{cls.__module__}:{cls.__name__}" == builtin.controller
        spec = controller_spec.ControllerSpec.from_plain({"name": name})
        assert isinstance(spec.params, params)  # validated, defaults filled
        fields = {f.name for f in dataclasses.fields(params)}
        assert set(spec.plain_params()) <= fields  # round trip: every value, None left out
        assert all(spec.takes(name, field) for field in fields)  # sweepable
        assert isinstance(make_controller(spec), cls)
