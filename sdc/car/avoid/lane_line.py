"""Where the avoid controller holds its lane, through bends, and how it steers there.

:class:`LaneLine` picks the lateral target in a lane (its own, or the one it passes
in): through bends tighter than ``bend_radius_m`` the offset its body fits
(:mod:`sdc.car.avoid.bend_room`), held while the rear axle is in the bend, with how far
the car may go and the speed the bends allow on that line; elsewhere the inside of a
gentle bend (:func:`inside_of_bend_m`). :func:`pursuit_steer_rad` steers toward the
target. Offsets are ISO 8855: positive to the left of the own lane's centre.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from sdc.car.avoid.bend_room import Track, bend_room, track
from sdc.car.avoid.lane_frame import LaneFrame
from sdc.car.avoid.swerve import tightest_radius_m
from sdc.car.controller_api import Observation, VehicleModel
from sdc.car.lane_path import TURN_WINDOW_M, LanePath


class Line(NamedTuple):
    """Where the car holds a lane at one step."""

    target_m: float  # the lateral target, from the own lane's centre
    free_m: float  # how far the car may go (inf: as far as it likes)
    bend_mps: float  # the speed the bends ahead allow on that line (inf: any)
    steer_path: LanePath  # the path to steer along


class LaneLine:
    """The line held in a lane, step by step: the offset held through a tight bend."""

    def __init__(self, params):
        self.params = params
        self.bend_offset_m: float | None = None  # the offset held through a tight bend

    def hold(self, frame: LaneFrame, obs: Observation, path: LanePath,
             leader_s: float | None, centre_m: float = 0.0) -> Line:
        """Where the car holds the lane whose centre is ``centre_m`` from its own's
        (its own, or the one it passes in): its lateral target, how far it may go, the
        speed the bends ahead allow on that line and the path to steer along (through
        a tight bend the lane smoothed as the car's track is: a junction's turn is
        drawn as a few straight pieces).

        Through bends tighter than ``bend_radius_m`` ahead (up to where the car
        stops braking at ``gap_decel_fraction`` of its hardest, and as long again
        as the car; not past the leader at station ``leader_s``) the offset within
        that lane nearest its centre that leaves the body ``bend_clearance_m`` from
        every return (:mod:`sdc.car.avoid.bend_room`); once the rear axle is in such a bend,
        the offset held so far while it still fits (the corner beside the car is then
        out of the range image). No offset fits: the car stops short of where it
        would not. Elsewhere, the inside of a gentle bend (:func:`inside_of_bend_m`)."""
        p, v = self.params, obs.vehicle
        axle_s = path.car_s_m - v.center_ahead_of_rear_axle_m
        decel = v.max_decel_mps2 * p.gap_decel_fraction
        end_s = axle_s + obs.speed_mps**2 / (2 * decel) + 2 * v.length_m
        if leader_s is not None:
            end_s = min(end_s, leader_s - v.front_ahead_of_rear_axle_m - p.bend_clearance_m)
        route = track(path, axle_s, end_s)
        tight = np.abs(route.curvature_1pm) > 1.0 / p.bend_radius_m
        if not tight.any():
            self.bend_offset_m = None
            return Line(centre_m + inside_of_bend_m(path, obs), math.inf, math.inf, path)
        held = (self.bend_offset_m is not None and bool(tight[0])
                and abs(self.bend_offset_m - centre_m) <= obs.lane_width_m / 2)
        preferred = self.bend_offset_m if held else centre_m
        half_m, band_m = obs.lane_width_m / 2, max(obs.lane_width_m / 2 - v.width_m / 2, 0.0)
        room = bend_room(route, frame.xy_m, v, preferred, (centre_m - half_m, centre_m + half_m),
                         p.bend_clearance_m, tightest_radius_m(v, p.tightest_steer_fraction),
                         None if held else (centre_m - band_m, centre_m + band_m))
        offset = preferred if math.isnan(room.offset_m) else room.offset_m
        self.bend_offset_m = offset
        reach_m = max(p.min_preview_m, obs.speed_mps * p.preview_time_s) + TURN_WINDOW_M
        steer_along = track(path, axle_s - 1.0, axle_s + v.wheelbase_m + reach_m)
        return Line(offset, room.free_m, bend_speed_mps(route, offset, obs, p),
                    LanePath(steer_along.xy_m, steer_along.s_m))


def bend_speed_mps(route: Track, offset_m: float, obs: Observation, params) -> float:
    """The speed from which the car, braking at ``gap_decel_fraction`` of its
    hardest, takes the track's parallel at ``offset_m`` at no more than
    ``turn_lateral_accel_mps2``."""
    p = params
    curvature = route.curvature_1pm / np.maximum(1.0 - route.curvature_1pm * offset_m, 0.2)
    decel = obs.vehicle.max_decel_mps2 * p.gap_decel_fraction
    limit_sq = p.turn_lateral_accel_mps2 / np.maximum(np.abs(curvature), 1e-9)
    return float(np.sqrt(np.min(limit_sq + 2 * decel * (route.s_m - route.s_m[0]))))


def inside_of_bend_m(path: LanePath, obs: Observation) -> float:
    """How far toward the inside of the bend the car holds its line (+ left): in
    a bend of radius R its front swings sqrt(R^2 + f^2) - R outside the rear axle's
    track (f: the front bumper ahead of the rear axle); half of that centres the
    band the body sweeps on the lane, as far as the lane leaves room beside it."""
    v = obs.vehicle
    rear_m = v.center_ahead_of_rear_axle_m
    front_m = v.length_m - v.rear_overhang_m
    axle_s_m = path.car_s_m - rear_m
    curvature = path.curvature_1pm(axle_s_m, axle_s_m + front_m)
    if abs(curvature) < 1e-6:
        return 0.0
    radius_m = 1.0 / abs(curvature)
    swing_m = math.hypot(radius_m, front_m) - radius_m
    room_m = max(obs.lane_width_m / 2 - v.width_m / 2, 0.0)
    return math.copysign(min(swing_m / 2, room_m), curvature)


def pursuit_steer_rad(path: LanePath, target_m: float, preview_m: float,
                      vehicle: VehicleModel, speed_mps: float,
                      max_lateral_accel_mps2: float) -> float:
    """The lane's own curvature at the rear axle plus pure pursuit, in the lane's
    frame unrolled straight, from the rear axle toward the point ``preview_m``
    ahead of the body centre along the lane at lateral offset ``target_m``: the
    steering angle of that curvature (capped by the lateral acceleration).
    Through a junction's turn the car turns where its lane turns instead of
    cutting toward a point on the bend ahead; on a steady bend the rear axle
    runs on the target line."""
    rear_m = vehicle.center_ahead_of_rear_axle_m
    axle_s_m, axle_d_m = path.locate(-rear_m, 0.0)
    heading = path.heading_rad(axle_s_m)  # the lane's direction in the car's frame
    lateral_m = target_m - axle_d_m
    reach_m = preview_m + rear_m
    c, s = math.cos(heading), math.sin(heading)
    ahead_m = reach_m * c - lateral_m * s
    left_m = reach_m * s + lateral_m * c
    curvature = 2.0 * left_m / (ahead_m**2 + left_m**2)
    lane_1pm = path.curvature_1pm(axle_s_m, axle_s_m + TURN_WINDOW_M)
    curvature += lane_1pm / max(1.0 - lane_1pm * target_m, 0.2)  # the target's parallel
    if speed_mps > 0:
        limit = max_lateral_accel_mps2 / speed_mps**2
        curvature = max(-limit, min(limit, curvature))
    steer = math.atan(vehicle.wheelbase_m * curvature)
    return max(-vehicle.max_steer_rad, min(vehicle.max_steer_rad, steer))
