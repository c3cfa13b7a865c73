"""The built-in controllers: from an :class:`Observation` to a :class:`Command`.

They follow the same protocol as any plug-in (``sdc.car.controller_api``): built
from the ``[controller]`` table's plain values, stepped with an observation,
their ``phase`` recorded every step. Steering is ISO 8855: positive turns left
(the lesson's Webots code uses the opposite sign).
"""

from __future__ import annotations

import numpy as np

from scenarios.spec.controller_params import LaneKeepParams, SeedParams
from scenarios.spec.spec_fields import build
from sdc.car.controller_api import Command, Observation
from sdc.car.sensors import LaneReading

LANE_KEEP, AVOID_LEFT, AVOID_STRAIGHT, AVOID_RIGHT = (
    "lane_keep", "avoid_left", "avoid_straight", "avoid_right")


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

    phase = LANE_KEEP

    def __init__(self, params: dict):
        self._keeper = LaneKeeper(build(LaneKeepParams, params, "controller"))

    def step(self, obs: Observation) -> Command:
        return Command(self._keeper.steer(obs.lane))


class SeedController:
    """The lesson's avoid-then-return maneuver, reproduced exactly.

    If any of the ``detect_beams`` central beams reads below ``detect_range_m``,
    steer ``avoid_steer_rad`` left for ``left_periods`` control periods, straight
    for ``straight_periods``, right for ``right_periods``, open loop (sensors are
    ignored meanwhile), then resume lane keeping. Speed is left unchanged.
    """

    def __init__(self, params: dict):
        self.params = build(SeedParams, params, "controller")
        self._keeper = LaneKeeper(self.params)
        self._plan: list[tuple[float, str]] = []
        self.phase = LANE_KEEP

    def detects(self, ranges: np.ndarray) -> bool:
        center = len(ranges) // 2
        half = self.params.detect_beams // 2
        window = ranges[max(0, center - half): center - half + self.params.detect_beams]
        return bool(np.any(window < self.params.detect_range_m))

    def step(self, obs: Observation) -> Command:
        p = self.params
        if not self._plan and self.detects(obs.ranges_m):
            self._plan = ([(p.avoid_steer_rad, AVOID_LEFT)] * p.left_periods
                          + [(0.0, AVOID_STRAIGHT)] * p.straight_periods
                          + [(-p.avoid_steer_rad, AVOID_RIGHT)] * p.right_periods)
            self._plan.reverse()
        if self._plan:
            steer_rad, self.phase = self._plan.pop()
            self._keeper.steer_rad = steer_rad  # lane keeping resumes from the last angle
            return Command(steer_rad)
        self.phase = LANE_KEEP
        return Command(self._keeper.steer(obs.lane))
