"""The closed-loop avoid-then-return controller (``avoid``): a composition of parts.

From what the car senses only: the range image, the lane reading (with its path:
the lane's centre line around the car), its own speed and steering, its vehicle
model, and the map's readings (stop line, lanes beside, crosswalk). Each step:

1. what it perceives (:mod:`sdc.car.avoid.perception`): the returns in the lane's
   own frame (:mod:`sdc.car.avoid.lane_frame`), the lanes beside and behind watched, the
   leaders tracked, what is nearest in its path;
2. which rules bind it (:mod:`sdc.car.avoid.road_rules`): foes and people watched, a
   queue at a junction waited behind rather than passed;
3. what it plans (:mod:`sdc.car.avoid.plan`): on an obstacle whose time to
   collision falls under ``detect_ttc_s``, a swerve to the side whose corridor is
   free and whose lane is open (left first), or braking; the pass held until the
   car's rear is past, then back; the phase (``wait`` where it cruises held by a
   rule of the road: a light, a duty to give way, a crossing, a queue at a junction);
4. where it holds its lane, through bends, and how it steers there
   (:mod:`sdc.car.avoid.lane_line`);
5. how it holds its speed (:mod:`sdc.car.avoid.speed_law`): following, cruising or
   braking, then bound by the lights, the duties to give way, the crossings, the
   room for its body in the bend ahead and the end of a lane it passes in.

Angles and offsets are ISO 8855: positive to the left.
"""

from __future__ import annotations

import math

from scenarios.spec.controller_params import AvoidParams
from scenarios.spec.spec_fields import build
from sdc.car.avoid.lane_frame import LaneFrame
from sdc.car.avoid.lane_line import LaneLine, Line, pursuit_steer_rad
from sdc.car.avoid.perception import STRAIGHT_AHEAD, Ahead, Perception, look_ahead
from sdc.car.avoid.plan import (
    AVOID_LEFT,
    AVOID_RETURN,
    AVOID_RIGHT,
    BRAKE,
    CRUISE,
    SWERVES,
    WAIT,
    Maneuver,
    Plan,
)
from sdc.car.avoid.road_rules import RoadRules
from sdc.car.avoid.speed_law import SpeedLaw
from sdc.car.controller_api import Command, Observation
from sdc.car.lane_path import LanePath

__all__ = ["AVOID_LEFT", "AVOID_RETURN", "AVOID_RIGHT", "BRAKE", "CRUISE", "WAIT",
           "AvoidController"]


class AvoidController:
    """Closed-loop avoid-then-return with time-to-collision detection (see the
    module; the phases: :mod:`sdc.car.avoid.plan`; the parameters: ``AvoidParams``)."""

    def __init__(self, params: dict):
        self.params = build(AvoidParams, params, "controller")
        self.perception = Perception(self.params)
        self.speed = SpeedLaw(self.params)
        self.rules = RoadRules(self.params, self.speed)
        self.maneuver = Maneuver(self.params, self.perception)
        self.line = LaneLine(self.params)
        self.held = False  # a rule of the road bound the last step's speed

    @property
    def phase(self) -> str:
        """The maneuver's phase, recorded in the trace: ``wait`` while it cruises held
        by a rule of the road."""
        phase = self.maneuver.phase
        return WAIT if phase == CRUISE and self.held else phase

    @property
    def target_m(self) -> float:
        """The lateral target of a pass, from the own lane's centre."""
        return self.maneuver.target_m

    def step(self, obs: Observation) -> Command:
        p, v = self.params, obs.vehicle
        self.speed.start(obs)
        lane = obs.lane
        path = LanePath.from_reading(lane, p.look_ahead_m) if lane else STRAIGHT_AHEAD
        # what it perceives, and the rules' watches
        frame = self.perception.frame(obs, path)
        self.perception.watch_lanes(frame, obs, path.offset_m)
        ahead = look_ahead(frame, obs, p, path.offset_m, self.maneuver.phase in SWERVES)
        self.perception.track(frame, obs, ahead)
        self.rules.watch(frame, obs, path, ahead.half_lane_m)
        leader = self.perception.leader
        following = leader.is_traffic(obs.t_s)  # not an obstacle to pass
        waiting = not following and self.rules.waits_at_junction(obs, ahead.gap_lane_m,
                                                                 leader.standing_since_s)
        # what it plans, where it holds its lane
        plan = self.maneuver.update(frame, obs, path, ahead, following or waiting,
                                    self.speed.cruise_mps)
        line = self._line(frame, obs, path, ahead)
        # how it holds its speed, and what binds it whatever else it does
        turn_mps = min(line.bend_mps, path.turn_speed_mps(p.turn_lateral_accel_mps2,
                                                          v.max_decel_mps2 * p.gap_decel_fraction,
                                                          behind_m=v.center_ahead_of_rear_axle_m))
        accel = self._plan_accel(plan, obs, ahead)
        if accel is None:
            accel = self._cruise_accel(obs, ahead, following, waiting, turn_mps)
        accel = min(accel, self.speed.room_accel(line.free_m, obs, turn_mps),  # the bend's room
                    self.rules.lane_end_accel(obs, self.maneuver.lane_end_side(), turn_mps))
        held_accel = min(self.rules.signal_accel(obs, turn_mps),
                         self.rules.give_way_accel(obs, turn_mps),
                         self.rules.crosswalk_accel(obs, turn_mps))
        self.held = waiting or held_accel < accel
        accel = min(accel, held_accel)
        if lane is None:
            return Command(0.0, accel)
        preview_m = max(p.min_preview_m, obs.speed_mps * p.preview_time_s)
        steer = pursuit_steer_rad(line.steer_path, line.target_m, preview_m, v, obs.speed_mps,
                                  p.max_lateral_accel_mps2)
        return Command(steer, accel)

    def _line(self, frame: LaneFrame, obs: Observation, path: LanePath, ahead: Ahead) -> Line:
        """The line held in the phase: the own lane's (cruising, returning), the passing
        lane's, or, braking, the target as it is (no limits of its own)."""
        phase = self.maneuver.phase
        if phase in (CRUISE, AVOID_RETURN):
            return self.line.hold(frame, obs, path, ahead.lane_s_m)
        if phase in SWERVES:  # the line in the lane it passes in
            return self.line.hold(frame, obs, path, ahead.path_s_m, self.maneuver.target_m)
        return Line(self.maneuver.target_m, math.inf, math.inf, path)

    def _plan_accel(self, plan: Plan | None, obs: Observation, ahead: Ahead) -> float | None:
        """The acceleration the plan fixes (None: the cruise's): braking, to stop as
        far back as the car can; swerving, the plan's."""
        if plan is None:
            return None
        if plan.phase == BRAKE:
            return self.speed.brake_accel(ahead.gap_lane_m, obs, far_back=True)
        return plan.accel_mps2

    def _cruise_accel(self, obs: Observation, ahead: Ahead, following: bool, waiting: bool,
                      turn_mps: float) -> float:
        """The acceleration when no plan fixed it: following a leader (the own
        lane's, or the passing lane's), to a stop ``wait_gap_m`` behind what is waited
        for, or toward the cruise speed as what is ahead and the bends allow.
        Passing with something coming the other way in the path and no way back
        behind the obstacle, it does not slow for that: the pass ends sooner."""
        p, speed, look = self.params, self.speed, self.perception
        gap_lane, gap_path = ahead.gap_lane_m, ahead.gap_path_m
        passing = self.maneuver.phase in SWERVES
        if passing and look.path_leader.comes_toward():
            return speed.speed_accel(math.inf, obs, turn_mps)
        gap = gap_path if passing else min(gap_lane, gap_path)
        in_lane = not passing and gap == gap_lane
        if following and in_lane:
            return speed.follow_accel(gap, max(look.leader.speed_mps() or 0.0, 0.0), obs,
                                      turn_mps)
        if passing and look.path_leader.is_traffic(obs.t_s):
            return speed.follow_accel(gap, max(look.path_leader.speed_mps() or 0.0, 0.0),
                                      obs, turn_mps)
        if waiting and in_lane:  # room to steer round it later
            return speed.speed_accel(gap - p.wait_gap_m + p.stop_margin_m, obs, turn_mps)
        return speed.speed_accel(gap, obs, turn_mps)
