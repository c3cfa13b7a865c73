"""The closed-loop avoid-then-return controller (``avoid``).

From what the car senses only: the range image, the lane reading, its own speed
and steering, its vehicle model. Each step the returns become points in the
lane's frame (:class:`LaneFrame`); an obstacle anywhere across the car's own
lane whose time to collision falls under ``detect_ttc_s`` starts the maneuver.
The car moves to a lateral target on the side whose corridor is free (left
first), holds it until the obstacle is beside and behind, and comes back, all by
feedback on the lane offset (:func:`pursuit_steer_rad`). It keeps a cruise speed
and brakes, up to a stop, when no side is free or swerving cannot clear in time.
Angles and offsets are ISO 8855: positive to the left.
"""

from __future__ import annotations

import math

import numpy as np

from scenarios.scenario_spec import AvoidParams
from scenarios.spec_fields import build
from sdc.car.controller_api import Command, Observation, VehicleModel

CRUISE, BRAKE = "cruise", "brake"
AVOID_LEFT, AVOID_RIGHT, AVOID_RETURN = "avoid_left", "avoid_right", "avoid_return"
LEFT, RIGHT, OWN = 1.0, -1.0, 0.0  # the sign of a side's lateral offsets


class LaneFrame:
    """The range image's returns in the lane's frame at one step.

    ``ahead_m``: along the lane from the car's body centre; ``lateral_m``: from
    the centre of the car's own lane (+ left), with the lane's curvature (read
    from the lane reading's preview) taken out.
    """

    def __init__(self, obs: Observation, cos_sin: np.ndarray, look_ahead_m: float):
        v = obs.vehicle
        hit = np.isfinite(obs.ranges_m)
        r = obs.ranges_m[hit]
        center_ahead_m = v.center_ahead_of_rear_axle_m
        x = (obs.lidar_ahead_m - center_ahead_m) + r * cos_sin[0, hit]  # from the body centre
        y = r * cos_sin[1, hit]
        lane = obs.lane
        if lane is None:
            offset_m, heading_rad, self.curvature_1pm = 0.0, 0.0, 0.0
        else:
            offset_m, heading_rad = lane.offset_m, lane.heading_error_rad
            self.curvature_1pm = lane_curvature_1pm(lane, look_ahead_m)
        c, s = math.cos(heading_rad), math.sin(heading_rad)
        self.ahead_m = x * c - y * s
        self.lateral_m = offset_m + x * s + y * c - 0.5 * self.curvature_1pm * self.ahead_m**2

    def within(self, lo_m: float, hi_m: float, behind_m: float, ahead_m: float) -> np.ndarray:
        """Which returns lie laterally in ``[lo_m, hi_m]`` and along the lane in
        ``[behind_m, ahead_m]`` (both from the body centre)."""
        lat, along = self.lateral_m, self.ahead_m
        return (lat >= lo_m) & (lat <= hi_m) & (along >= behind_m) & (along <= ahead_m)

    def gap_m(self, lo_m: float, hi_m: float, front_m: float) -> float:
        """Along the lane from ``front_m`` ahead of the body centre (its front bumper)
        to the nearest return laterally within ``[lo_m, hi_m]`` (inf if none)."""
        ahead = self.within(lo_m, hi_m, front_m - 0.5, math.inf)
        return float(self.ahead_m[ahead].min()) - front_m if ahead.any() else math.inf


def lane_curvature_1pm(lane, look_ahead_m: float) -> float:
    """The lane's curvature [1/m, + left] from the offset, heading error and the
    preview offset ``look_ahead_m`` ahead (0 without a usable preview)."""
    if not look_ahead_m:
        return 0.0
    straight_m = lane.offset_m + look_ahead_m * math.sin(lane.heading_error_rad)
    return 2.0 * (straight_m - lane.preview_offset_m) / look_ahead_m**2


def pursuit_steer_rad(target_m: float, offset_m: float, heading_rad: float,
                      curvature_1pm: float, preview_m: float, vehicle: VehicleModel,
                      speed_mps: float, max_lateral_accel_mps2: float) -> float:
    """Pure pursuit toward the point ``preview_m`` ahead along the lane at lateral
    offset ``target_m``: the steering angle whose arc from the rear axle passes
    through it, its curvature capped by the lateral acceleration."""
    center_ahead_m = vehicle.center_ahead_of_rear_axle_m
    lateral_m = target_m - offset_m + 0.5 * curvature_1pm * preview_m**2
    c, s = math.cos(heading_rad), math.sin(heading_rad)
    ahead_m = preview_m * c + lateral_m * s + center_ahead_m  # in the car's frame
    left_m = lateral_m * c - preview_m * s
    curvature = 2.0 * left_m / (ahead_m**2 + left_m**2)
    if speed_mps > 0:
        limit = max_lateral_accel_mps2 / speed_mps**2
        curvature = max(-limit, min(limit, curvature))
    steer = math.atan(vehicle.wheelbase_m * curvature)
    return max(-vehicle.max_steer_rad, min(vehicle.max_steer_rad, steer))


class AvoidController:
    """Closed-loop avoid-then-return with time-to-collision detection.

    Phases: ``cruise`` (lane keeping at the cruise speed), ``avoid_left`` /
    ``avoid_right`` (out to the lateral target and holding it while passing),
    ``avoid_return`` (back to the lane centre), ``brake`` (no way round: slowing,
    up to a stop, behind the obstacle).
    """

    def __init__(self, params: dict):
        self.params = build(AvoidParams, params, "controller")
        self.phase = CRUISE
        self.cruise_mps: float | None = self.params.cruise_speed_mps
        self.target_m = 0.0  # the lateral target, from the own lane's centre
        self.side = 0.0
        self.odometer_m = 0.0
        self.seen_at_m = 0.0  # odometer when the obstacle was last seen beside or ahead
        self.free_since_s: dict[float, float] = {}  # since when a lane was seen empty beside
        self.traffic_seen: set[float] = set()  # the lanes where something was seen beside
        self._cos_sin: np.ndarray | None = None

    # ---- perception --------------------------------------------------------
    def _frame(self, obs: Observation) -> LaneFrame:
        if self._cos_sin is None or self._cos_sin.shape[1] != len(obs.beam_angles_rad):
            self._cos_sin = np.array([np.cos(obs.beam_angles_rad), np.sin(obs.beam_angles_rad)])
        return LaneFrame(obs, self._cos_sin, self.params.look_ahead_m)

    def _side_blocked(self, frame: LaneFrame, side: float, target_m: float, obs: Observation,
                      reach_m: float) -> bool:
        """Any return in the corridor the car sweeps going to ``target_m`` and
        passing there, from beside it to ``reach_m`` ahead?"""
        p, v = self.params, obs.vehicle
        half_m = v.width_m / 2 + p.lateral_clearance_m
        inner_m = obs.lane_width_m / 2  # the own lane's edge on that side
        lo, hi = sorted((side * inner_m, target_m + side * half_m))
        return bool(np.any(frame.within(lo, hi, -v.length_m / 2 - p.rear_margin_m, reach_m)))

    def _watch_lanes(self, frame: LaneFrame, obs: Observation) -> None:
        """Note since when each lane (left, right, own) has been empty beside the car.
        Traffic from behind is out of the lidar's view: a lane counts as free only
        after the car has watched it empty for a while (from the first step)."""
        p, v, w = self.params, obs.vehicle, obs.lane_width_m
        tol = p.edge_tolerance_m
        for side, lo, hi in ((LEFT, w / 2 + tol, 1.5 * w - tol),
                             (RIGHT, -1.5 * w + tol, -w / 2 - tol),
                             (OWN, -w / 2 + tol, w / 2 - tol)):
            seen = np.any(frame.within(lo, hi, -v.length_m / 2 - p.rear_margin_m, v.length_m))
            if seen or side not in self.free_since_s:
                self.free_since_s[side] = obs.t_s
            if seen:
                self.traffic_seen.add(side)

    def _watched_free(self, side: float, obs: Observation, watch_s: float) -> bool:
        """Has the lane been seen empty beside the car for ``watch_s`` (for
        ``traffic_memory_s`` once something was ever seen there)?"""
        if side in self.traffic_seen:
            watch_s = max(watch_s, self.params.traffic_memory_s)
        return obs.t_s - self.free_since_s[side] >= watch_s - 1e-9

    # ---- decisions ---------------------------------------------------------
    def _swerve_distance_m(self, shift_m: float, speed_mps: float, brake_mps2: float,
                           obs: Observation) -> float:
        """How far the car travels while shifting ``shift_m`` sideways: bang-bang
        lateral acceleration plus the steering's lag, with a safety factor."""
        v = obs.vehicle
        accel = self.params.max_lateral_accel_mps2
        if speed_mps > 0:
            accel = min(accel, speed_mps**2 * math.tan(v.max_steer_rad) / v.wheelbase_m)
        if accel <= 0:
            return math.inf
        shift_m = max(shift_m, 0.0)
        t_s = 2.0 * math.sqrt(shift_m / accel) + 2.0 * 0.5 / v.max_steer_rate_radps
        t_s *= self.params.swerve_time_factor
        t_stop = speed_mps / brake_mps2 if brake_mps2 > 0 else math.inf
        t_s = min(t_s, t_stop)
        # however slow, the turn is no tighter than the steering allows: an S of two
        # arcs of the smallest radius
        radius_m = v.wheelbase_m / math.tan(0.9 * v.max_steer_rad)
        half_m = min(shift_m / 2, radius_m)
        arcs_m = (2.0 * math.sqrt(half_m * (2 * radius_m - half_m))
                  + max(0.0, shift_m - 2 * radius_m))
        return max(speed_mps * t_s - 0.5 * brake_mps2 * t_s**2, arcs_m)

    def _plan(self, frame: LaneFrame, obs: Observation, gap_m: float, in_lane: np.ndarray):
        """On an obstacle ahead: (phase, side, target) to swerve to, or brake."""
        p, v = self.params, obs.vehicle
        speed = obs.speed_mps
        offset = obs.lane.offset_m if obs.lane else 0.0
        near = in_lane & (frame.ahead_m <= frame.ahead_m[in_lane].min() + p.obstacle_depth_m)
        lat = frame.lateral_m[near]
        reach = gap_m + v.length_m + p.obstacle_depth_m + speed * p.free_time_s
        brake = v.max_decel_mps2
        stop_m = speed**2 / (2 * brake)
        can_stop = stop_m <= gap_m  # at the car's hardest braking, from now
        options = []
        for side, phase in ((LEFT, AVOID_LEFT), (RIGHT, AVOID_RIGHT)):
            # a lane not watched long enough only to escape a collision braking cannot
            if can_stop and not self._watched_free(side, obs, p.lane_watch_s):
                continue
            edge = lat.max() if side == LEFT else lat.min()
            clear_m = abs(edge) * (1 if side * edge > 0 else -1) + v.width_m / 2
            target = side * max(obs.lane_width_m, clear_m + p.lateral_clearance_m)
            if self._side_blocked(frame, side, target, obs, reach):
                continue
            shift = max(0.0, side * (side * (clear_m + 0.2) - offset))
            options.append((phase, side, target, shift))
        for phase, side, target, shift in options:  # keeping speed
            if self._swerve_distance_m(shift, speed, 0.0, obs) <= gap_m:
                return phase, side, target, 0.0
        if can_stop:
            return BRAKE, 0.0, 0.0, -brake
        for phase, side, target, shift in options:  # braking meanwhile
            if self._swerve_distance_m(shift, speed, brake, obs) <= gap_m:
                return phase, side, target, -brake
        if options:
            phase, side, target, _ = options[0]
            return phase, side, target, -brake
        return BRAKE, 0.0, 0.0, -brake

    # ---- the step ----------------------------------------------------------
    def step(self, obs: Observation) -> Command:
        p, v = self.params, obs.vehicle
        if self.cruise_mps is None:
            self.cruise_mps = obs.speed_mps
        self.odometer_m += obs.speed_mps * obs.step_s
        frame = self._frame(obs)
        self._watch_lanes(frame, obs)
        lane = obs.lane
        offset = lane.offset_m if lane else 0.0
        half_lane = obs.lane_width_m / 2 - p.edge_tolerance_m
        front_m = v.length_m / 2
        in_lane = frame.within(-half_lane, half_lane, front_m - 0.5, math.inf)
        gap_lane = float(frame.ahead_m[in_lane].min()) - front_m if in_lane.any() else math.inf
        # the car's own path, wherever it is: its body's width along the lane
        body_half = v.width_m / 2 + p.edge_tolerance_m
        gap_path = frame.gap_m(offset - body_half, offset + body_half, front_m)
        speed = obs.speed_mps
        ttc_lane = gap_lane / speed if speed > 0 else math.inf
        accel = None

        if self.phase in (CRUISE, AVOID_RETURN, BRAKE):
            # a threat: closing in under detect_ttc_s, or (slow or stopped) within the
            # waiting gap; once braking, anything in the lane the cruise would reach so
            holding = self.phase == BRAKE and gap_lane < (
                self.cruise_mps * p.detect_ttc_s + p.wait_gap_m)
            if ttc_lane < p.detect_ttc_s or gap_lane < p.wait_gap_m + 1.0 or holding:
                phase, side, target, accel = self._plan(frame, obs, gap_lane, in_lane)
                if phase != BRAKE:
                    self.phase, self.side, self.target_m = phase, side, target
                    self.seen_at_m = self.odometer_m
                else:
                    self.phase, accel = BRAKE, self._brake_accel(gap_lane, obs)
            elif self.phase == BRAKE:
                self.phase = CRUISE
        if self.phase in (AVOID_LEFT, AVOID_RIGHT):
            # the obstacle: anything in the own lane, or out of it up to the car's
            # side, from beside the car onward
            near_m = offset - self.side * (v.width_m / 2 + 0.05)
            far_m = self.side * max(half_lane, self.side * near_m)
            lo, hi = sorted((-self.side * half_lane, far_m))
            if frame.within(lo, hi, -front_m, math.inf).any():
                self.seen_at_m = self.odometer_m
            passed_m = self.odometer_m - self.seen_at_m
            if (passed_m > obs.lidar_ahead_m + v.rear_overhang_m + p.return_gap_m
                    and obs.t_s - self.free_since_s[OWN] >= p.return_watch_s - 1e-9):
                self.phase, self.target_m = AVOID_RETURN, 0.0
        if self.phase == AVOID_RETURN and abs(offset) < p.settled_offset_m:
            self.phase = CRUISE
        if self.phase in (CRUISE, AVOID_RETURN):
            self.target_m = 0.0

        if accel is None:
            gap = gap_path if self.phase in (AVOID_LEFT, AVOID_RIGHT) else min(gap_lane, gap_path)
            accel = self._speed_accel(gap, obs)
        if lane is None:
            return Command(0.0, accel)
        preview_m = max(p.min_preview_m, speed * p.preview_time_s)
        steer = pursuit_steer_rad(self.target_m, offset, lane.heading_error_rad,
                                  frame.curvature_1pm, preview_m, v, speed,
                                  p.max_lateral_accel_mps2)
        return Command(steer, accel)

    def _brake_accel(self, gap_m: float, obs: Observation) -> float:
        """Braking to stop ``stop_margin_m`` short of the obstacle: the deceleration
        that needs, times ``brake_gain``, up to the car's maximum."""
        p, v = self.params, obs.vehicle
        speed = obs.speed_mps
        room_m = gap_m - p.stop_margin_m
        if speed <= 0:
            return 0.0 if room_m > 0 else -v.max_decel_mps2
        wait_room_m = gap_m - p.wait_gap_m  # far enough back to steer round it later
        if wait_room_m > 0 and speed**2 / (2 * wait_room_m) <= v.max_decel_mps2 / p.brake_gain:
            room_m = wait_room_m
        need = speed**2 / (2 * room_m) if room_m > 0 else math.inf
        if speed < p.creep_speed_mps:  # the last of it: stop (rather than creep ever slower)
            need = max(need, speed / obs.step_s)
        return -min(v.max_decel_mps2, p.brake_gain * need)

    def _speed_accel(self, gap_m: float, obs: Observation) -> float:
        """Toward the cruise speed, or slower when something ahead in the path
        needs it (the speed from which the car still stops short of it)."""
        p, v = self.params, obs.vehicle
        room_m = gap_m - p.stop_margin_m
        allowed = math.sqrt(2 * v.max_decel_mps2 * 0.5 * room_m) if room_m > 0 else 0.0
        if obs.speed_mps > allowed:
            return self._brake_accel(gap_m, obs)
        accel = p.speed_gain_1ps * (min(self.cruise_mps, allowed) - obs.speed_mps)
        return max(-v.max_decel_mps2, min(v.max_accel_mps2, accel))
