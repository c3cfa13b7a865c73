"""Controllers: from a range image and a lane reading to a steering command.

Every controller returns a :class:`~sdc.car.vehicle.Command` (ISO 8855: positive
steering turns left; the lesson's Webots code uses the opposite sign) and the
phase it is in, which the trace records every step.
"""

from __future__ import annotations

import numpy as np

from scenarios.scenario_spec import ControllerSpec, LaneKeepParams, SeedParams
from sdc.car.sensors import LaneReading
from sdc.car.vehicle import Command

LANE_KEEP, AVOID_LEFT, AVOID_STRAIGHT, AVOID_RIGHT = (
    "lane_keep", "avoid_left", "avoid_straight", "avoid_right")
PHASES = (LANE_KEEP, AVOID_LEFT, AVOID_STRAIGHT, AVOID_RIGHT)


class LaneKeeper:
    """Bang-bang steering toward the lane centre seen at a look-ahead point.

    Steers ``keep_steer_rad`` toward the centre while the look-ahead offset is
    beyond ``deadband_m``; otherwise, and when the lane is not sensed, keeps the
    last angle (as the lesson did when the yellow line left the image).
    """

    def __init__(self, params: LaneKeepParams):
        self.params = params
        self.steer_rad = 0.0

    def steer(self, lane: LaneReading | None) -> float:
        if lane is not None:
            if lane.preview_offset_m > self.params.deadband_m:
                self.steer_rad = -self.params.keep_steer_rad
            elif lane.preview_offset_m < -self.params.deadband_m:
                self.steer_rad = self.params.keep_steer_rad
        return self.steer_rad


class LaneKeepController:
    """The control group: lane keeping only, never avoids."""

    def __init__(self, params: LaneKeepParams):
        self.look_ahead_m = params.look_ahead_m
        self._keeper = LaneKeeper(params)

    def step(self, ranges: np.ndarray, lane: LaneReading | None) -> tuple[Command, str]:
        return Command(self._keeper.steer(lane)), LANE_KEEP


class SeedController:
    """The lesson's avoid-then-return maneuver, reproduced exactly.

    If any of the ``detect_beams`` central beams reads below ``detect_range_m``,
    steer ``avoid_steer_rad`` left for ``left_periods`` control periods, straight
    for ``straight_periods``, right for ``right_periods``, open loop (sensors are
    ignored meanwhile), then resume lane keeping. Speed is left unchanged.
    """

    def __init__(self, params: SeedParams):
        self.params = params
        self.look_ahead_m = params.look_ahead_m
        self._keeper = LaneKeeper(params)
        self._plan: list[tuple[float, str]] = []

    def detects(self, ranges: np.ndarray) -> bool:
        center = len(ranges) // 2
        half = self.params.detect_beams // 2
        window = ranges[max(0, center - half): center - half + self.params.detect_beams]
        return bool(np.any(window < self.params.detect_range_m))

    def step(self, ranges: np.ndarray, lane: LaneReading | None) -> tuple[Command, str]:
        p = self.params
        if not self._plan and self.detects(ranges):
            self._plan = ([(p.avoid_steer_rad, AVOID_LEFT)] * p.left_periods
                          + [(0.0, AVOID_STRAIGHT)] * p.straight_periods
                          + [(-p.avoid_steer_rad, AVOID_RIGHT)] * p.right_periods)
            self._plan.reverse()
        if self._plan:
            steer_rad, phase = self._plan.pop()
            self._keeper.steer_rad = steer_rad  # lane keeping resumes from the last angle
            return Command(steer_rad), phase
        return Command(self._keeper.steer(lane)), LANE_KEEP


def make_controller(spec: ControllerSpec) -> SeedController | LaneKeepController:
    if spec.name == "seed":
        return SeedController(spec.params)
    return LaneKeepController(spec.params)
