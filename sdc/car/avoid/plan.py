"""What the avoid controller plans: the maneuver round an obstacle and its phase.

Phases: ``cruise`` (lane keeping at the cruise speed), ``avoid_left`` /
``avoid_right`` (out to the lateral target and holding it while passing),
``avoid_return`` (back to the lane centre), ``brake`` (no way round: slowing, up to
a stop, behind the obstacle). The phase changes in one place, :func:`next_phase`,
from what :class:`Maneuver` finds each step: a plan on an obstacle ahead (a side
to swerve to, or braking), the pass over or given up, the car settled back on its
lane's centre.

An obstacle in the car's path along its lane whose time to collision falls under
``detect_ttc_s`` (or, slow or stopped, within the waiting gap; once braking,
anything the cruise would reach so) asks for a plan: the side whose corridor is
free and whose lane is open (left first), if the swerve fits in the gap
(:mod:`sdc.car.avoid.swerve`); else braking, or, when braking cannot stop short, the
swerve anyway, braking meanwhile. What a leader followed or waited behind is
(traffic) is never passed.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from sdc.car.avoid.lane_frame import LaneFrame
from sdc.car.avoid.perception import LEFT, OWN, RIGHT, Ahead, Perception, beside_m
from sdc.car.avoid.swerve import sight_needed_m, swerve_distance_m
from sdc.car.controller_api import Observation
from sdc.car.lane_path import LanePath

CRUISE, BRAKE = "cruise", "brake"
#: cruising, held by a rule of the road: a light, a duty to give way, a crossing, a
#: queue at a junction (the recorded phase; the maneuver's own is cruise)
WAIT = "wait"
AVOID_LEFT, AVOID_RIGHT, AVOID_RETURN = "avoid_left", "avoid_right", "avoid_return"
SWERVES = (AVOID_LEFT, AVOID_RIGHT)  # out of the lane, passing


class Plan(NamedTuple):
    """A plan on an obstacle ahead: swerve to ``target_m`` on ``side`` (phase
    ``avoid_left`` / ``avoid_right``), or brake (phase ``brake``, side and target 0)."""

    phase: str
    side: float
    target_m: float  # the lateral target, from the own lane's centre
    end_s_m: float  # how far along the lane the obstacle's returns reach
    accel_mps2: float  # 0: keeping speed; the car's hardest braking: braking meanwhile


def next_phase(phase: str, planned: str | None, back: bool = False,
               settled: bool = False) -> str:
    """The phase after this one, from the step's findings in their order: a plan
    made (``planned``: its phase), else braking ends; out to pass and ``back`` (past
    what it passes, or something comes the other way): returning; returning and
    ``settled`` (within ``settled_offset_m`` of the lane's centre): cruising."""
    if planned is not None:
        phase = planned
    elif phase == BRAKE:
        phase = CRUISE
    if phase in SWERVES and back:
        phase = AVOID_RETURN
    if phase == AVOID_RETURN and settled:
        phase = CRUISE
    return phase


class Maneuver:
    """The maneuver, step by step (see the module): its phase, the side and lateral
    target of a pass, and how far along the lane what it passes reaches."""

    def __init__(self, params, perception: Perception):
        self.params = params
        self.look = perception
        self.phase = CRUISE
        self.side = 0.0
        self.target_m = 0.0  # the lateral target, from the own lane's centre
        self.obstacle_end_s = -math.inf  # how far along the lane what is passed reaches
        self.pass_in_lane = False  # passing in a lane of the car's direction (it may end)

    def update(self, frame: LaneFrame, obs: Observation, path: LanePath, ahead: Ahead,
               traffic: bool, cruise_mps: float) -> Plan | None:
        """One step: a plan on a threat ahead (a ``traffic`` leader, one followed or
        waited behind, is no obstacle to pass), the pass followed, and the phase
        after them (:func:`next_phase`). The plan made (None: none)."""
        plan = self._plan(frame, obs, path, ahead, traffic, cruise_mps)
        planned = None if plan is None else plan.phase
        if planned in SWERVES:
            self.side, self.target_m, self.obstacle_end_s = plan.side, plan.target_m, plan.end_s_m
            self.pass_in_lane = beside_m(plan.side, obs) > 0
        back = False
        if next_phase(self.phase, planned) in SWERVES:
            passed = self._passed(frame, obs, path, ahead.half_lane_m)
            back = passed or self._oncoming(obs, ahead.gap_lane_m)
        self.phase = next_phase(self.phase, planned, back,
                                abs(path.offset_m) < self.params.settled_offset_m)
        if self.phase in (CRUISE, AVOID_RETURN):
            self.target_m = 0.0
        return plan

    def lane_end_side(self) -> float | None:
        """The side of the lane of the car's direction it passes in (None: none)."""
        return self.side if self.phase in SWERVES and self.pass_in_lane else None

    def _plan(self, frame: LaneFrame, obs: Observation, path: LanePath, ahead: Ahead,
              traffic: bool, cruise_mps: float) -> Plan | None:
        """A plan when in the lane or braking and something in the lane is a threat:
        closing in under ``detect_ttc_s``, or (slow or stopped) within the waiting gap;
        once braking, anything in the lane the cruise would reach so. With a rear view,
        cruising toward a leader known to stand: a pass started ``early_pass_ttc_s``
        ahead, if one is open."""
        p = self.params
        if self.phase in SWERVES or traffic:
            return None
        speed, gap_lane = obs.speed_mps, ahead.gap_lane_m
        ttc_lane = gap_lane / speed if speed > 0 else math.inf
        holding = self.phase == BRAKE and gap_lane < (cruise_mps * p.detect_ttc_s + p.wait_gap_m)
        offset = path.offset_m
        if ttc_lane < p.detect_ttc_s or gap_lane < p.wait_gap_m + 1.0 or holding:
            return self._choose(frame, obs, offset, gap_lane, ahead.in_lane)
        if (self.look.rear_view and self.phase == CRUISE and ttc_lane < p.early_pass_ttc_s
                and self.look.leader.speed_mps() is not None):
            return self._choose(frame, obs, offset, gap_lane, ahead.in_lane, early=True)
        return None

    def _choose(self, frame: LaneFrame, obs: Observation, offset: float, gap_m: float,
                in_lane: np.ndarray, early: bool = False) -> Plan | None:
        """On an obstacle ahead: swerve or brake (:class:`Plan`). ``early`` (a standing
        obstacle still far): a pass into an open lane, or None. A side where the map
        has no lane of the car's direction on past the obstacle (a kerb, the other
        direction's lane, a lane that ends) needs its corridor seen free as far as a
        car coming the other way would come meanwhile
        (:func:`~sdc.car.avoid.swerve.sight_needed_m`, within the lidar's range). With a
        rear view, a lane whose nearest vehicle ahead comes the other way is no side
        to pass on, and a lane of the car's direction whose nearest moves the car's
        way needs its corridor free only as far as the lane change takes (that
        vehicle is then followed)."""
        p, v = self.params, obs.vehicle
        speed = obs.speed_mps
        near = frame.obstacle(in_lane, p.obstacle_depth_m)
        lat = frame.lateral_m[near]
        brake = v.max_decel_mps2
        stop_m = speed**2 / (2 * brake)
        can_stop = early or stop_m <= gap_m  # at the car's hardest braking, from now
        # from the body centre to where the car is back in its lane past the obstacle
        back_m = float(frame.ahead_m[near].max()) + p.return_gap_m + v.length_m
        options = []
        for side, phase in ((LEFT, AVOID_LEFT), (RIGHT, AVOID_RIGHT)):
            # a lane not open only to escape a collision braking cannot
            if can_stop and not self.look.lane_open(side, obs):
                continue
            if self.look.side_leaders[side].comes_toward():  # the other direction's lane
                continue
            edge = lat.max() if side == LEFT else lat.min()
            clear_m = abs(edge) * (1 if side * edge > 0 else -1) + v.width_m / 2
            target = side * max(obs.lane_width_m, clear_m + p.lateral_clearance_m)
            shift = max(0.0, side * (side * (clear_m + p.shift_margin_m) - offset))
            reach = gap_m + v.length_m + p.obstacle_depth_m + speed * p.free_time_s
            if beside_m(side, obs) < back_m:  # not a lane of ours all the way
                # out there until back past the obstacle and across into its lane
                out_m = back_m + swerve_distance_m(abs(target), speed, 0.0, v, p)
                reach = max(reach, sight_needed_m(out_m, speed, v, p))
                if reach > obs.lidar_range_m:
                    continue
            elif self.look.flows_our_way(side):  # followed once there: as far as the move
                reach = swerve_distance_m(abs(target - offset), speed, 0.0, v, p) + v.length_m
            if self._side_blocked(frame, side, target, obs, reach, offset, near):
                continue
            options.append((phase, side, target, shift))
        end_s = float(frame.s_m[near].max())
        for phase, side, target, shift in options:  # keeping speed
            if swerve_distance_m(shift, speed, 0.0, v, p) <= gap_m:
                return Plan(phase, side, target, end_s, 0.0)
        if early:
            return None
        if can_stop:
            return Plan(BRAKE, 0.0, 0.0, end_s, -brake)
        for phase, side, target, shift in options:  # braking meanwhile
            if swerve_distance_m(shift, speed, brake, v, p) <= gap_m:
                return Plan(phase, side, target, end_s, -brake)
        if options:
            phase, side, target, _ = options[0]
            return Plan(phase, side, target, end_s, -brake)
        return Plan(BRAKE, 0.0, 0.0, end_s, -brake)

    def _side_blocked(self, frame: LaneFrame, side: float, target_m: float, obs: Observation,
                      reach_m: float, offset_m: float, passed: np.ndarray) -> bool:
        """Any return but those of what is ``passed`` in the corridor the car's body
        sweeps going from ``offset_m`` to ``target_m`` and passing there, from beside
        it to ``reach_m`` ahead (a kerb at the own lane's edge included)?"""
        p, v = self.params, obs.vehicle
        half_m = v.width_m / 2 + p.lateral_clearance_m
        lo, hi = sorted((offset_m + side * v.width_m / 2, target_m + side * half_m))
        corridor = frame.within(lo, hi, -v.length_m / 2 - p.rear_margin_m, reach_m)
        return bool(np.any(corridor & ~passed))

    def _passed(self, frame: LaneFrame, obs: Observation, path: LanePath,
                half_lane: float) -> bool:
        """While out of the lane: follow how far along the lane what is passed
        reaches; is the car's rear ``return_gap_m`` past it and the own lane open?

        What is passed: returns in the own lane (or out of it up to the car's near
        side) no further than ``obstacle_depth_m`` beyond what was passed so far,
        or within the car's stopping distance ahead of its front. Traffic further
        ahead in the lane, and road edges, do not hold the car out."""
        p, v = self.params, obs.vehicle
        side, offset = self.side, path.offset_m
        near_m = offset - side * (v.width_m / 2 + 0.05)
        far_m = side * max(half_lane, side * near_m)
        lo, hi = sorted((-side * half_lane, far_m))
        stop_m = obs.speed_mps**2 / (2 * v.max_decel_mps2) + p.stop_margin_m
        reach_s = max(self.obstacle_end_s + p.obstacle_depth_m,
                      path.car_s_m + v.length_m / 2 + stop_m)
        part = frame.within(lo, hi, -v.length_m / 2, math.inf) & (frame.s_m <= reach_s)
        if part.any():
            self.obstacle_end_s = max(self.obstacle_end_s, float(frame.s_m[part].max()))
        rear_s = path.car_s_m - v.length_m / 2
        return rear_s >= self.obstacle_end_s + p.return_gap_m and self.look.lane_open(OWN, obs)

    def _oncoming(self, obs: Observation, gap_lane: float) -> bool:
        """Something coming the other way in the passing lane while the obstacle is
        still ahead: back behind it, if the own lane is open and the car can still
        stop short of the obstacle?"""
        p, v = self.params, obs.vehicle
        stop_m = obs.speed_mps**2 / (2 * v.max_decel_mps2) + p.stop_margin_m
        return (self.look.path_leader.comes_toward()
                and gap_lane > max(p.wait_gap_m + 1.0, stop_m)
                and self.look.lane_open(OWN, obs))
