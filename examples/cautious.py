"""An example controller plug-in: keep to the lane, brake for anything in the way.

It never swerves: it steers toward its lane's centre in proportion to the offset
seen ``look_ahead_m`` ahead, and brakes as hard as the car can when something
in the range image lies in its path closer than its stopping distance plus
``margin_m``. Try it::

    sdc run scenarios/catalog/seed-lesson.toml --controller examples/cautious.py:Cautious
    sdc sweep examples/cautious-sweep.toml --out cautious --workers 2

Everything it uses comes from ``sdc``'s two exports; see the manual's
docs/how-to/own-controller.md for the protocol.
"""

from __future__ import annotations

import numpy as np

from sdc import Command, Observation

PARAMS = {"margin_m": 3.0, "steer_gain_radpm": 0.3, "path_margin_m": 0.3, "look_ahead_m": 5.0}


class Cautious:
    def __init__(self, params: dict):
        unknown = sorted(set(params) - set(PARAMS))
        if unknown:
            raise ValueError(f"unknown parameters {unknown} (known: {sorted(PARAMS)})")
        values = {**PARAMS, **params}
        self.margin_m = float(values["margin_m"])
        self.steer_gain_radpm = float(values["steer_gain_radpm"])
        self.path_margin_m = float(values["path_margin_m"])
        if self.margin_m < 0 or self.steer_gain_radpm < 0 or self.path_margin_m < 0:
            raise ValueError("margin_m, steer_gain_radpm and path_margin_m must be >= 0")
        self.phase = "lane_keep"

    def gap_ahead_m(self, obs: Observation) -> float:
        """The distance from the front bumper to the nearest return in the car's path."""
        hit = np.isfinite(obs.ranges_m)
        ranges_m, angles_rad = obs.ranges_m[hit], obs.beam_angles_rad[hit]
        ahead_m = obs.lidar_ahead_m + ranges_m * np.cos(angles_rad)  # from the rear axle
        side_m = ranges_m * np.sin(angles_rad)
        half_width_m = obs.vehicle.width_m / 2 + self.path_margin_m
        front_m = obs.vehicle.front_ahead_of_rear_axle_m
        in_path = (np.abs(side_m) < half_width_m) & (ahead_m > front_m)
        return float(ahead_m[in_path].min() - front_m) if in_path.any() else np.inf

    def step(self, obs: Observation) -> Command:
        steer_rad = 0.0
        if obs.lane is not None:
            steer_rad = -self.steer_gain_radpm * obs.lane.preview_offset_m
        stopping_m = obs.speed_mps**2 / (2 * obs.vehicle.max_decel_mps2)
        if self.gap_ahead_m(obs) < stopping_m + self.margin_m:
            self.phase = "brake"
            return Command(steer_rad, -obs.vehicle.max_decel_mps2)
        self.phase = "lane_keep"
        return Command(steer_rad)
