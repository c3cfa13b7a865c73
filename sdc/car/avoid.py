"""The closed-loop avoid-then-return controller (``avoid``).

From what the car senses only: the range image, the lane reading (with its
path: the lane's centre line around the car), its own speed and steering, its
vehicle model. Each step the returns become points in the lane's own frame
(:class:`LaneFrame` on a :class:`~sdc.car.lane_path.LanePath`: along the arc
of a curve, through the route's lanes at a junction); an obstacle in the car's
path along its lane whose time to collision falls under ``detect_ttc_s``
starts the maneuver. The car moves to a lateral target on the side whose
corridor is free and whose lane is open (left first), holds it until its rear
is past what it passes, and comes back, all by feedback in the lane's frame
(:func:`pursuit_steer_rad`). It keeps a cruise speed, slows for the lane's
bends, and brakes, up to a stop, when no side is free or swerving cannot clear
in time. Angles and offsets are ISO 8855: positive to the left.
"""

from __future__ import annotations

import math

import numpy as np

from scenarios.scenario_spec import AvoidParams
from scenarios.spec_fields import build
from sdc.car.bend_room import Track, bend_room, track
from sdc.car.controller_api import RED, YELLOW, Command, Observation, VehicleModel
from sdc.car.foe_watch import FoeWatch
from sdc.car.lane_path import TURN_WINDOW_M, LanePath
from sdc.car.leader_watch import LeaderWatch
from sdc.car.rear_watch import RearWatch

CRUISE, BRAKE = "cruise", "brake"
AVOID_LEFT, AVOID_RIGHT, AVOID_RETURN = "avoid_left", "avoid_right", "avoid_return"
LEFT, RIGHT, OWN = 1.0, -1.0, 0.0  # the sign of a side's lateral offsets
#: an obstacle's face is what the lidar sees of it within this beyond its nearest
#: return [m], laterally joined by gaps under FACE_JOIN_M [m] (the beams' spacing at
#: a few tens of metres)
FACE_DEPTH_M, FACE_JOIN_M = 1.0, 0.6
#: the lane taken when it is not sensed (off the road's ends): straight ahead
STRAIGHT_AHEAD = LanePath(np.array([[-1000.0, 0.0], [1000.0, 0.0]]), np.array([-1000.0, 1000.0]))


class LaneFrame:
    """The range image's returns in lane coordinates at one step (:class:`LanePath`).

    ``s_m``: along the lane (the same for a point from step to step), ``ahead_m``:
    along the lane from the car's body centre, ``lateral_m``: from the centre of
    the car's own lane (+ left). Road edges along the lane stay at their offsets
    on curves and through junction turns, outside the lane.
    """

    def __init__(self, obs: Observation, cos_sin: np.ndarray, path: LanePath):
        hit = np.isfinite(obs.ranges_m)
        r = obs.ranges_m[hit]
        x = (obs.lidar_ahead_m - obs.vehicle.center_ahead_of_rear_axle_m) + r * cos_sin[0, hit]
        y = r * cos_sin[1, hit]
        self.xy_m = np.column_stack([x, y])  # in the car's frame, from its body centre
        self.s_m, self.lateral_m = path.to_lane(self.xy_m)
        self.ahead_m = self.s_m - path.car_s_m

    def within(self, lo_m: float, hi_m: float, behind_m: float, ahead_m: float) -> np.ndarray:
        """Which returns lie laterally in ``[lo_m, hi_m]`` and along the lane in
        ``[behind_m, ahead_m]`` (both from the body centre)."""
        lat, along = self.lateral_m, self.ahead_m
        return (lat >= lo_m) & (lat <= hi_m) & (along >= behind_m) & (along <= ahead_m)

    def obstacle(self, in_path: np.ndarray, depth_m: float) -> np.ndarray:
        """The returns of the obstacle whose nearest return is the nearest of
        ``in_path``: its face (the returns within ``FACE_DEPTH_M`` beyond that one,
        laterally joined to those in the path by gaps under ``FACE_JOIN_M``: a body
        reaching out of the lane, not a kerb beside it) and everything laterally
        within the face up to ``depth_m`` beyond it."""
        nearest_m = float(self.ahead_m[in_path].min())
        face = self.within(-math.inf, math.inf, nearest_m, nearest_m + FACE_DEPTH_M)
        core = self.lateral_m[in_path & face]
        lo, hi = float(core.min()), float(core.max())
        outside = np.sort(self.lateral_m[face])
        for lat in outside[outside > hi]:
            if lat - hi > FACE_JOIN_M:
                break
            hi = float(lat)
        for lat in outside[outside < lo][::-1]:
            if lo - lat > FACE_JOIN_M:
                break
            lo = float(lat)
        return self.within(lo, hi, nearest_m, nearest_m + depth_m)

    def ahead(self, lo_m: float, hi_m: float, front_m: float) -> np.ndarray:
        """Which returns lie laterally in ``[lo_m, hi_m]`` and ahead of the front
        bumper, ``front_m`` ahead of the body centre (0.5 m of slack behind it)."""
        return self.within(lo_m, hi_m, front_m - 0.5, math.inf)

    def small_bodies(self, among: np.ndarray, size_m: float) -> bool:
        """Is any of the returns ``among`` these part of a body no bigger than ``size_m``
        across and along the lane (a person, a bicycle; not a car, nor a kerb or an
        island's edge running on)? A body's returns: neighbours in beam order less than
        ``FACE_JOIN_M`` apart."""
        if not among.any():
            return False
        gaps = np.hypot(*np.diff(self.xy_m, axis=0).T)
        starts = np.concatenate([[0], np.flatnonzero(gaps > FACE_JOIN_M) + 1])
        body = np.repeat(np.arange(len(starts)), np.diff(np.append(starts, len(gaps) + 1)))
        span = np.maximum(
            np.maximum.reduceat(self.s_m, starts) - np.minimum.reduceat(self.s_m, starts),
            np.maximum.reduceat(self.lateral_m, starts)
            - np.minimum.reduceat(self.lateral_m, starts))
        return bool((span[body[among]] <= size_m).any())

    def nearest(self, among: np.ndarray, front_m: float) -> tuple[float, float | None]:
        """The nearest return ``among`` these: its gap along the lane from the front
        bumper ``front_m`` ahead of the body centre, and its station (inf, None: none)."""
        if not among.any():
            return math.inf, None
        i = int(np.argmin(np.where(among, self.ahead_m, math.inf)))
        return float(self.ahead_m[i]) - front_m, float(self.s_m[i])


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


class AvoidController:
    """Closed-loop avoid-then-return with time-to-collision detection.

    Phases: ``cruise`` (lane keeping at the cruise speed), ``avoid_left`` /
    ``avoid_right`` (out to the lateral target and holding it while passing),
    ``avoid_return`` (back to the lane centre), ``brake`` (no way round: slowing,
    up to a stop, behind the obstacle).

    Moving into a lane (out to pass, or back): with a range image that covers the
    rear (beams ``rear_view_deg`` round from straight ahead on both sides) only
    into a gap that stays open at the closing speed of what comes from behind
    (:mod:`sdc.car.rear_watch`). Without a rear view, only into a lane watched
    empty beside the car for a while (``lane_watch_s``, ``traffic_memory_s``,
    ``return_watch_s``).
    """

    def __init__(self, params: dict):
        self.params = build(AvoidParams, params, "controller")
        self.phase = CRUISE
        self.cruise_mps: float | None = self.params.cruise_speed_mps
        self.target_m = 0.0  # the lateral target, from the own lane's centre
        self.side = 0.0
        self.obstacle_end_s = -math.inf  # how far along the lane what is passed reaches
        self.free_since_s: dict[float, float] = {}  # since when a lane was seen empty beside
        self.traffic_seen: set[float] = set()  # the lanes where something was seen beside
        self.rear = RearWatch(self.params)
        self.leader = LeaderWatch(self.params)  # in the own lane
        self.path_leader = LeaderWatch(self.params)  # in the body's path, wherever it is
        self.side_leaders = {LEFT: LeaderWatch(self.params), RIGHT: LeaderWatch(self.params)}
        self.lines_s_m: list[float] = []  # the stop lines seen, along the road
        self.foes = FoeWatch(self.params)  # before a line where the car gives way
        self.foe_seen_s = -math.inf  # when a foe was seen last
        self.walker_seen_s = -math.inf  # when a person was seen on the crossing ahead
        self.bend_offset_m: float | None = None  # the offset held through a tight bend
        self.pass_in_lane = False  # passing in a lane of the car's direction (it may end)
        self._cos_sin: np.ndarray | None = None
        self._rear_view = False

    # ---- perception --------------------------------------------------------
    def _frame(self, obs: Observation, path: LanePath) -> LaneFrame:
        if self._cos_sin is None or self._cos_sin.shape[1] != len(obs.beam_angles_rad):
            angles = obs.beam_angles_rad
            self._cos_sin = np.array([np.cos(angles), np.sin(angles)])
            reach_rad = math.radians(self.params.rear_view_deg)
            self._rear_view = bool(len(angles)) and (angles.max() >= reach_rad - 1e-9
                                                     and angles.min() <= -reach_rad + 1e-9)
        return LaneFrame(obs, self._cos_sin, path)

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

    def _lane_bands(self, obs: Observation):
        """(side, lo, hi): the lanes left, right and own, inside their edges."""
        w, tol = obs.lane_width_m, self.params.edge_tolerance_m
        return ((LEFT, w / 2 + tol, 1.5 * w - tol), (RIGHT, -1.5 * w + tol, -w / 2 - tol),
                (OWN, -w / 2 + tol, w / 2 - tol))

    def _watch_lanes(self, frame: LaneFrame, obs: Observation) -> None:
        """Note since when each lane (left, right, own) has been empty beside the car.
        Without a rear view traffic from behind is unseen: a lane counts as free only
        after the car has watched it empty for a while (from the first step)."""
        p, v = self.params, obs.vehicle
        for side, lo, hi in self._lane_bands(obs):
            seen = np.any(frame.within(lo, hi, -v.length_m / 2 - p.rear_margin_m, v.length_m))
            if seen or side not in self.free_since_s:
                self.free_since_s[side] = obs.t_s
            if seen:
                self.traffic_seen.add(side)

    def _lane_open(self, side: float, obs: Observation) -> bool:
        """May the car move into that lane now (the class's rule)?"""
        if self._rear_view:
            return self.rear.open(side, obs)
        if side == OWN:
            return obs.t_s - self.free_since_s[OWN] >= self.params.return_watch_s - 1e-9
        watch_s = self.params.lane_watch_s
        if side in self.traffic_seen:
            watch_s = max(watch_s, self.params.traffic_memory_s)
        return obs.t_s - self.free_since_s[side] >= watch_s - 1e-9

    # ---- decisions ---------------------------------------------------------
    def _tightest_radius_m(self, vehicle: VehicleModel) -> float:
        """The rear axle's radius at ``tightest_steer_fraction`` of the steering
        limit: the tightest turn the car plans [m]."""
        steer_rad = self.params.tightest_steer_fraction * vehicle.max_steer_rad
        return vehicle.wheelbase_m / math.tan(steer_rad)

    def _swerve_distance_m(self, shift_m: float, speed_mps: float, brake_mps2: float,
                           obs: Observation) -> float:
        """How far the car travels while shifting ``shift_m`` sideways: bang-bang
        lateral acceleration plus the steering's lag, with a safety factor."""
        p, v = self.params, obs.vehicle
        accel = p.max_lateral_accel_mps2
        if speed_mps > 0:
            accel = min(accel, speed_mps**2 * math.tan(v.max_steer_rad) / v.wheelbase_m)
        if accel <= 0:
            return math.inf
        shift_m = max(shift_m, 0.0)
        t_s = 2.0 * math.sqrt(shift_m / accel) + 2.0 * p.swerve_steer_rad / v.max_steer_rate_radps
        t_s *= p.swerve_time_factor
        t_stop = speed_mps / brake_mps2 if brake_mps2 > 0 else math.inf
        t_s = min(t_s, t_stop)
        # however slow, the turn is no tighter than the steering allows: an S of two
        # arcs of the tightest radius
        radius_m = self._tightest_radius_m(v)
        half_m = min(shift_m / 2, radius_m)
        arcs_m = (2.0 * math.sqrt(half_m * (2 * radius_m - half_m))
                  + max(0.0, shift_m - 2 * radius_m))
        return max(speed_mps * t_s - 0.5 * brake_mps2 * t_s**2, arcs_m)

    def _plan(self, frame: LaneFrame, obs: Observation, offset: float, gap_m: float,
              in_lane: np.ndarray, early: bool = False):
        """On an obstacle ahead: ``(phase, side, target, end_s, accel)``, to swerve
        to ``target`` or brake; ``end_s``: how far along the lane the obstacle's
        returns reach. ``early`` (a standing obstacle still far): a pass into an
        open lane, or None. A side where the map has no lane of the car's direction
        on past the obstacle (a kerb, the other direction's lane, a lane that
        ends) needs its corridor seen free as far as a car coming the other way
        would come meanwhile (:meth:`_sight_needed_m`, within the lidar's range).
        With a rear view, a lane whose nearest vehicle ahead comes
        the other way is no side to pass on, and a lane of the car's direction whose
        nearest moves the car's way needs its corridor free only as far as the lane
        change takes (that vehicle is then followed)."""
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
            if can_stop and not self._lane_open(side, obs):
                continue
            if self.side_leaders[side].comes_toward():  # the other direction's lane
                continue
            edge = lat.max() if side == LEFT else lat.min()
            clear_m = abs(edge) * (1 if side * edge > 0 else -1) + v.width_m / 2
            target = side * max(obs.lane_width_m, clear_m + p.lateral_clearance_m)
            shift = max(0.0, side * (side * (clear_m + p.shift_margin_m) - offset))
            reach = gap_m + v.length_m + p.obstacle_depth_m + speed * p.free_time_s
            if self._beside_m(side, obs) < back_m:  # not a lane of ours all the way
                # out there until back past the obstacle and across into its lane
                out_m = back_m + self._swerve_distance_m(abs(target), speed, 0.0, obs)
                reach = max(reach, self._sight_needed_m(out_m, obs))
                if reach > obs.lidar_range_m:
                    continue
            elif self._flows_our_way(side, obs):  # followed once there: as far as the move
                reach = self._swerve_distance_m(abs(target - offset), speed, 0.0, obs) + v.length_m
            if self._side_blocked(frame, side, target, obs, reach, offset, near):
                continue
            options.append((phase, side, target, shift))
        end_s = float(frame.s_m[near].max())
        for phase, side, target, shift in options:  # keeping speed
            if self._swerve_distance_m(shift, speed, 0.0, obs) <= gap_m:
                return phase, side, target, end_s, 0.0
        if early:
            return None
        if can_stop:
            return BRAKE, 0.0, 0.0, end_s, -brake
        for phase, side, target, shift in options:  # braking meanwhile
            if self._swerve_distance_m(shift, speed, brake, obs) <= gap_m:
                return phase, side, target, end_s, -brake
        if options:
            phase, side, target, _ = options[0]
            return phase, side, target, end_s, -brake
        return BRAKE, 0.0, 0.0, end_s, -brake

    def _passing(self, frame: LaneFrame, obs: Observation, path: LanePath,
                 half_lane: float) -> None:
        """While out of the lane: follow how far along the lane what is passed
        reaches, and go back once the car's rear is ``return_gap_m`` past it and
        the own lane is open.

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
        if rear_s >= self.obstacle_end_s + p.return_gap_m and self._lane_open(OWN, obs):
            self.phase, self.target_m = AVOID_RETURN, 0.0

    # ---- the step ----------------------------------------------------------
    def step(self, obs: Observation) -> Command:
        p, v = self.params, obs.vehicle
        if self.cruise_mps is None:
            self.cruise_mps = obs.speed_mps
        lane = obs.lane
        path = LanePath.from_reading(lane, p.look_ahead_m) if lane else STRAIGHT_AHEAD
        frame = self._frame(obs, path)
        offset = path.offset_m
        if self._rear_view:  # the lanes are watched behind, or beside (_lane_open)
            self.rear.update(frame, obs, self._lane_bands(obs), offset)
        else:
            self._watch_lanes(frame, obs)
        # the car's path along its lane: its width and path_clearance_m each side
        half_lane = min(obs.lane_width_m / 2 - p.edge_tolerance_m,
                        v.width_m / 2 + p.path_clearance_m)
        front_m = v.length_m / 2
        in_lane = frame.ahead(-half_lane, half_lane, front_m)
        # the car's own path, wherever it is: its body's width along the lane (and,
        # swerving, straight ahead of it too: a corner it heads clear of is no stop)
        body_half = v.width_m / 2 + p.edge_tolerance_m
        gap_lane, lane_s = frame.nearest(in_lane, front_m)
        in_path = frame.ahead(offset - body_half, offset + body_half, front_m)
        if self.phase in (AVOID_LEFT, AVOID_RIGHT):  # swerving: what its heading runs into
            in_path &= np.abs(frame.xy_m[:, 1]) <= body_half
        gap_path, path_s = frame.nearest(in_path, front_m)
        self._track(frame, obs, lane_s, path_s)
        self._watch_foes(frame, obs, path, half_lane)
        self._watch_crosswalk(frame, obs)
        following = self.leader.is_traffic(obs.t_s)  # not an obstacle to pass
        waiting = not following and self._waits_at_junction(obs, gap_lane)
        accel = self._decide(frame, obs, path, gap_lane, in_lane, following or waiting)
        if self.phase in (AVOID_LEFT, AVOID_RIGHT):
            self._passing(frame, obs, path, half_lane)
            self._back_from_oncoming(obs, gap_lane)
        if self.phase == AVOID_RETURN and abs(offset) < p.settled_offset_m:
            self.phase = CRUISE
        target_m, free_m, bend_mps, steer_path = self.target_m, math.inf, math.inf, path
        if self.phase in (CRUISE, AVOID_RETURN):
            self.target_m = 0.0
            target_m, free_m, bend_mps, steer_path = self._lane_line(frame, obs, path, lane_s)
        elif self.phase in (AVOID_LEFT, AVOID_RIGHT):  # the line in the lane it passes in
            target_m, free_m, bend_mps, steer_path = self._lane_line(frame, obs, path, path_s,
                                                                     self.target_m)

        turn_mps = min(bend_mps, path.turn_speed_mps(p.turn_lateral_accel_mps2,
                                                     v.max_decel_mps2 * p.gap_decel_fraction,
                                                     behind_m=v.center_ahead_of_rear_axle_m))
        if accel is None:
            accel = self._cruise_accel(obs, gap_lane, gap_path, following, waiting, turn_mps)
        accel = min(accel, self._signal_accel(obs, turn_mps))  # whatever else it does
        accel = min(accel, self._give_way_accel(obs, turn_mps))
        accel = min(accel, self._crosswalk_accel(obs, turn_mps))
        if math.isfinite(free_m):  # no room for the body in the bend ahead: stop short
            accel = min(accel, self._speed_accel(free_m, obs, turn_mps, wait_m=p.stop_margin_m))
        accel = min(accel, self._lane_end_accel(obs, turn_mps))
        if lane is None:
            return Command(0.0, accel)
        preview_m = max(p.min_preview_m, obs.speed_mps * p.preview_time_s)
        steer = pursuit_steer_rad(steer_path, target_m, preview_m, v, obs.speed_mps,
                                  p.max_lateral_accel_mps2)
        return Command(steer, accel)

    def _track(self, frame: LaneFrame, obs: Observation, lane_s: float | None,
               path_s: float | None) -> None:
        """Track the leaders: in the own lane and in the body's path (the stations
        of their nearest returns), and in the lanes beside."""
        self.leader.update(obs.t_s, lane_s)
        self.path_leader.update(obs.t_s, path_s)
        if self._rear_view:  # the lanes beside are judged by their leaders' speeds
            front_m = obs.vehicle.length_m / 2
            for side, lo, hi in self._lane_bands(obs)[:2]:
                _, side_s = frame.nearest(frame.ahead(lo, hi, front_m), front_m)
                self.side_leaders[side].update(obs.t_s, side_s)

    def _decide(self, frame: LaneFrame, obs: Observation, path: LanePath, gap_lane: float,
                in_lane: np.ndarray, traffic: bool) -> float | None:
        """The phase at this step, in the lane or braking (a ``traffic`` leader, one
        followed or waited behind, is never an obstacle to pass): on a threat, the
        plan's; its acceleration when the plan fixes it (None: the cruise's)."""
        p = self.params
        if traffic and self.phase == BRAKE:
            self.phase = CRUISE
        if self.phase not in (CRUISE, AVOID_RETURN, BRAKE) or traffic:
            return None
        # a threat: closing in under detect_ttc_s, or (slow or stopped) within the
        # waiting gap; once braking, anything in the lane the cruise would reach so
        speed = obs.speed_mps
        ttc_lane = gap_lane / speed if speed > 0 else math.inf
        holding = self.phase == BRAKE and gap_lane < (
            self.cruise_mps * p.detect_ttc_s + p.wait_gap_m)
        offset = path.offset_m
        plan = None
        if ttc_lane < p.detect_ttc_s or gap_lane < p.wait_gap_m + 1.0 or holding:
            plan = self._plan(frame, obs, offset, gap_lane, in_lane)
        elif (self._rear_view and self.phase == CRUISE and ttc_lane < p.early_pass_ttc_s
              and self.leader.speed_mps() is not None):
            plan = self._plan(frame, obs, offset, gap_lane, in_lane, early=True)
        elif self.phase == BRAKE:
            self.phase = CRUISE
        if plan is None:
            return None
        phase, side, target, end_s, accel = plan
        if phase == BRAKE:
            self.phase = BRAKE
            return self._brake_accel(gap_lane, obs, far_back=True)
        self.phase, self.side, self.target_m = phase, side, target
        self.obstacle_end_s = end_s
        self.pass_in_lane = self._beside_m(side, obs) > 0
        return accel

    def _lane_end_accel(self, obs: Observation, turn_mps: float) -> float:
        """Passing in a lane of the car's direction that ends ahead (a merge): to a
        stop ``stop_margin_m`` short of its end, unless back in the own lane before."""
        if self.phase not in (AVOID_LEFT, AVOID_RIGHT) or not self.pass_in_lane:
            return math.inf
        end_m = self._beside_m(self.side, obs)  # from the body centre
        if not 0 < end_m < math.inf:
            return math.inf
        return self._speed_accel(end_m - obs.vehicle.length_m / 2, obs, turn_mps,
                                 wait_m=self.params.stop_margin_m)

    def _back_from_oncoming(self, obs: Observation, gap_lane: float) -> None:
        """Something coming the other way in the passing lane while the obstacle is
        still ahead: back behind it, if the own lane is open and the car can still
        stop short of the obstacle."""
        p, v = self.params, obs.vehicle
        stop_m = obs.speed_mps**2 / (2 * v.max_decel_mps2) + p.stop_margin_m
        if (self.path_leader.comes_toward() and gap_lane > max(p.wait_gap_m + 1.0, stop_m)
                and self._lane_open(OWN, obs)):
            self.phase, self.target_m = AVOID_RETURN, 0.0

    def _cruise_accel(self, obs: Observation, gap_lane: float, gap_path: float,
                      following: bool, waiting: bool, turn_mps: float) -> float:
        """The acceleration when no plan fixed it: following a leader (the own
        lane's, or the passing lane's), to a stop wait_gap_m behind what is waited
        for, or toward the cruise speed as what is ahead and the bends allow.
        Passing with something coming the other way in the path and no way back
        behind the obstacle (:meth:`_back_from_oncoming`), it does not slow for
        that: the pass ends sooner."""
        p = self.params
        passing = self.phase in (AVOID_LEFT, AVOID_RIGHT)
        if passing and self.path_leader.comes_toward():
            return self._speed_accel(math.inf, obs, turn_mps)
        gap = gap_path if passing else min(gap_lane, gap_path)
        in_lane = not passing and gap == gap_lane
        if following and in_lane:
            return self._follow_accel(gap, max(self.leader.speed_mps() or 0.0, 0.0), obs,
                                      turn_mps)
        if passing and self.path_leader.is_traffic(obs.t_s):
            return self._follow_accel(gap, max(self.path_leader.speed_mps() or 0.0, 0.0),
                                      obs, turn_mps)
        if waiting and in_lane:  # room to steer round it later
            return self._speed_accel(gap - p.wait_gap_m + p.stop_margin_m, obs, turn_mps)
        return self._speed_accel(gap, obs, turn_mps)

    def _lane_line(self, frame: LaneFrame, obs: Observation, path: LanePath,
                   leader_s: float | None, centre_m: float = 0.0
                   ) -> tuple[float, float, float, LanePath]:
        """Where the car holds the lane whose centre is ``centre_m`` from its own's
        (its own, or the one it passes in): its lateral target, how far it may go
        (inf: as far as it likes), the speed the bends ahead allow on that line and
        the path to steer along (through a tight bend the lane smoothed as the car's
        track is: a junction's turn is drawn as a few straight pieces).

        Through bends tighter than ``bend_radius_m`` ahead (up to where the car
        stops braking at ``gap_decel_fraction`` of its hardest, and as long again
        as the car; not past the leader) the offset within that lane nearest its
        centre that leaves the body ``bend_clearance_m`` from every return
        (:mod:`sdc.car.bend_room`); once the rear axle is in such a bend, the offset
        held so far while it still fits (the corner beside the car is then out of
        the range image). No offset fits: the car stops short of where it would
        not. Elsewhere, the inside of a gentle bend (:meth:`_inside_of_bend_m`)."""
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
            return centre_m + self._inside_of_bend_m(path, obs), math.inf, math.inf, path
        held = (self.bend_offset_m is not None and bool(tight[0])
                and abs(self.bend_offset_m - centre_m) <= obs.lane_width_m / 2)
        preferred = self.bend_offset_m if held else centre_m
        half_m, band_m = obs.lane_width_m / 2, max(obs.lane_width_m / 2 - v.width_m / 2, 0.0)
        room = bend_room(route, frame.xy_m, v, preferred, (centre_m - half_m, centre_m + half_m),
                         p.bend_clearance_m, self._tightest_radius_m(v),
                         None if held else (centre_m - band_m, centre_m + band_m))
        offset = preferred if math.isnan(room.offset_m) else room.offset_m
        self.bend_offset_m = offset
        reach_m = max(p.min_preview_m, obs.speed_mps * p.preview_time_s) + TURN_WINDOW_M
        steer_along = track(path, axle_s - 1.0, axle_s + v.wheelbase_m + reach_m)
        return (offset, room.free_m, self._bend_speed_mps(route, offset, obs),
                LanePath(steer_along.xy_m, steer_along.s_m))

    def _bend_speed_mps(self, route: Track, offset_m: float, obs: Observation) -> float:
        """The speed from which the car, braking at ``gap_decel_fraction`` of its
        hardest, takes the track's parallel at ``offset_m`` at no more than
        ``turn_lateral_accel_mps2``."""
        p = self.params
        curvature = route.curvature_1pm / np.maximum(1.0 - route.curvature_1pm * offset_m, 0.2)
        decel = obs.vehicle.max_decel_mps2 * p.gap_decel_fraction
        limit_sq = p.turn_lateral_accel_mps2 / np.maximum(np.abs(curvature), 1e-9)
        return float(np.sqrt(np.min(limit_sq + 2 * decel * (route.s_m - route.s_m[0]))))

    @staticmethod
    def _inside_of_bend_m(path: LanePath, obs: Observation) -> float:
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

    def _sight_needed_m(self, out_m: float, obs: Observation) -> float:
        """How far ahead a side must be seen free to pass in it without a lane of
        the car's own direction there: what the car drives until it is back in its
        lane, ``out_m`` (speeding up at no more than ``follow_accel_mps2``), and
        what a car coming the other way at ``oncoming_speed_mps`` covers meanwhile."""
        speed = obs.speed_mps
        accel = min(self.params.follow_accel_mps2, obs.vehicle.max_accel_mps2)
        out_s = (math.sqrt(speed**2 + 2 * accel * out_m) - speed) / accel
        return out_m + self.params.oncoming_speed_mps * out_s

    @staticmethod
    def _beside_m(side: float, obs: Observation) -> float:
        """How far the map's lane of the car's direction on ``side`` runs on ahead
        of the body centre (inf: the map does not say)."""
        if obs.lanes_beside is None:
            return math.inf
        return obs.lanes_beside.left_m if side == LEFT else obs.lanes_beside.right_m

    def _flows_our_way(self, side: float, obs: Observation) -> bool:
        """Does what is nearest ahead in the lane on ``side`` move the car's way
        faster than ``pass_max_speed_mps`` (traffic to follow there, not a car
        standing or coming the other way)?"""
        speed = self.side_leaders[side].speed_mps()
        return speed is not None and speed > self.params.pass_max_speed_mps

    def _waits_at_junction(self, obs: Observation, gap_m: float) -> bool:
        """Is what stands ``gap_m`` ahead waited behind rather than passed: queued
        within ``junction_clear_m`` before the next stop line while its light is red
        or yellow; or, for less than ``queue_patience_s`` so far, queued before a
        line where cars give way or standing in a junction (up to
        ``junction_depth_m`` past a line seen: crossing or turning)?"""
        p, line = self.params, obs.stop_line
        if obs.lane is None or not math.isfinite(gap_m):
            return False
        front_s_m = obs.lane.s_m + obs.vehicle.length_m / 2
        what_s_m = front_s_m + gap_m
        queued = False
        if line is not None:
            line_s_m = front_s_m + line.distance_m
            if not any(abs(s - line_s_m) < 1.0 for s in self.lines_s_m):
                self.lines_s_m.append(line_s_m)
            if line_s_m - p.junction_clear_m <= what_s_m < line_s_m:
                if line.signal in (RED, YELLOW):
                    return True
                queued = line.give_way
        in_junction = any(s <= what_s_m <= s + p.junction_depth_m for s in self.lines_s_m)
        stood_s = obs.t_s - min(self.leader.standing_since_s, obs.t_s)
        return (queued or in_junction) and stood_s < p.queue_patience_s

    def _watch_foes(self, frame: LaneFrame, obs: Observation, path: LanePath,
                    half_lane_m: float) -> None:
        """Before a line where the car gives way, within ``give_way_watch_m``: note
        when a foe was seen last (:mod:`sdc.car.foe_watch`)."""
        line = obs.stop_line
        if line is None or not line.give_way or line.distance_m > self.params.give_way_watch_m:
            self.foes.clear()
            return
        front_m = obs.vehicle.length_m / 2
        line_s_m = path.car_s_m + front_m + line.distance_m
        if self.foes.foe_seen(obs, frame, path, half_lane_m, line_s_m):
            self.foe_seen_s = obs.t_s

    def _give_way_accel(self, obs: Observation, turn_mps: float) -> float:
        """Stopping short of a line where the car gives way while a foe was seen in
        the last ``give_way_hold_s``, if the car can stop there; else no limit."""
        line = obs.stop_line
        if (line is None or not line.give_way
                or obs.t_s - self.foe_seen_s > self.params.give_way_hold_s + 1e-9):
            return math.inf
        return self._stop_at_line_accel(obs, obs.vehicle.max_decel_mps2, turn_mps)

    def _watch_crosswalk(self, frame: LaneFrame, obs: Observation) -> None:
        """Before a pedestrian crossing, within ``give_way_watch_m``: note when a body
        the size of a person or a bicycle (``crosswalk_body_m``) was seen on its roadway
        (someone on it, or stepping onto it)."""
        p, walk = self.params, obs.crosswalk
        if walk is None or walk.distance_m > p.give_way_watch_m:
            return
        near_m = obs.vehicle.length_m / 2 + walk.distance_m
        on_it = frame.within(-walk.right_m + p.crosswalk_kerb_m, walk.left_m - p.crosswalk_kerb_m,
                             near_m - p.crosswalk_margin_m,
                             near_m + walk.depth_m + p.crosswalk_margin_m)
        if frame.small_bodies(on_it, p.crosswalk_body_m):
            self.walker_seen_s = obs.t_s

    def _crosswalk_accel(self, obs: Observation, turn_mps: float) -> float:
        """Stopping short of a pedestrian crossing while a person (or a bicycle) was seen
        on it in the last ``give_way_hold_s``, if the car can stop there (not once its front is on
        it); else no limit."""
        walk = obs.crosswalk
        if (walk is None or walk.distance_m < 0
                or obs.t_s - self.walker_seen_s > self.params.give_way_hold_s + 1e-9):
            return math.inf
        return self._stop_short_accel(walk.distance_m, obs, obs.vehicle.max_decel_mps2,
                                      turn_mps)

    def _signal_accel(self, obs: Observation, turn_mps: float) -> float:
        """Stopping short of the next stop line when its light is red and the car can
        stop there, or yellow and it can stop braking at ``yellow_decel_fraction`` of its
        hardest; otherwise no limit."""
        p, v, line = self.params, obs.vehicle, obs.stop_line
        if line is None or line.signal not in (RED, YELLOW):
            return math.inf
        decel = v.max_decel_mps2 * (1.0 if line.signal == RED else p.yellow_decel_fraction)
        return self._stop_at_line_accel(obs, decel, turn_mps)

    def _stop_at_line_accel(self, obs: Observation, decel_mps2: float, turn_mps: float
                            ) -> float:
        """To a stop ``stop_margin_m`` short of the next stop line (:meth:`_stop_short_accel`)."""
        return self._stop_short_accel(obs.stop_line.distance_m, obs, decel_mps2, turn_mps)

    def _stop_short_accel(self, distance_m: float, obs: Observation, decel_mps2: float,
                          turn_mps: float) -> float:
        """To a stop ``stop_margin_m`` short of a place ``distance_m`` ahead of the front
        bumper, if the car can stop there braking at ``decel_mps2``; else no limit (too
        close: go on across)."""
        p = self.params
        if (obs.speed_mps > p.creep_speed_mps
                and obs.speed_mps**2 > 2 * decel_mps2 * max(distance_m, 0.0)):
            return math.inf
        return self._speed_accel(distance_m, obs, turn_mps, wait_m=p.stop_margin_m)

    def _brake_accel(self, gap_m: float, obs: Observation, wait_m: float | None = None,
                     far_back: bool = False) -> float:
        """Braking to stop ``wait_m`` (default ``wait_gap_m``) short of the obstacle
        where the car can, else ``stop_margin_m`` short of it: the deceleration that
        needs, times ``brake_gain``, up to the car's maximum. ``far_back`` (an
        obstacle to steer round once stopped): where the waiting gap is out of
        reach, the car's hardest, to stop as far back as it can."""
        p, v = self.params, obs.vehicle
        speed = obs.speed_mps
        room_m = gap_m - p.stop_margin_m
        if speed <= 0:
            return 0.0 if room_m > 0 else -v.max_decel_mps2
        # far enough back to steer round it later
        wait_room_m = gap_m - (p.wait_gap_m if wait_m is None else wait_m)
        if wait_room_m > 0 and speed**2 / (2 * wait_room_m) <= v.max_decel_mps2:
            room_m = wait_room_m
        elif far_back and speed >= p.creep_speed_mps:
            return -v.max_decel_mps2
        need = speed**2 / (2 * room_m) if room_m > 0 else math.inf
        if speed < p.creep_speed_mps:  # the last of it: stop (rather than creep ever slower)
            need = max(need, speed / obs.step_s)
        return -min(v.max_decel_mps2, p.brake_gain * need)

    def _follow_accel(self, gap_m: float, leader_mps: float, obs: Observation,
                      turn_mps: float) -> float:
        """Following a leader ``gap_m`` ahead at ``leader_mps``: the intelligent
        driver model toward the cruise speed at the time gap ``follow_time_gap_s``,
        and never faster than the speed from which the car stops short of where
        the leader would stop braking as hard (:meth:`_speed_accel` with the
        leader's stopping distance added to the gap)."""
        p, v = self.params, obs.vehicle
        speed = obs.speed_mps
        a_mps2, b_mps2 = min(p.follow_accel_mps2, v.max_accel_mps2), p.follow_decel_mps2
        wanted_m = p.wait_gap_m + max(0.0, speed * p.follow_time_gap_s + speed * (
            speed - leader_mps) / (2 * math.sqrt(a_mps2 * b_mps2)))
        free = (speed / self.cruise_mps) ** 4 if self.cruise_mps > 0 else math.inf
        idm = a_mps2 * (1 - free - (wanted_m / max(gap_m, 1e-3)) ** 2)
        decel = v.max_decel_mps2 * p.gap_decel_fraction
        bound = self._speed_accel(gap_m + leader_mps**2 / (2 * decel), obs, turn_mps)
        return max(-v.max_decel_mps2, min(idm, bound))

    def _speed_accel(self, gap_m: float, obs: Observation, turn_mps: float,
                     wait_m: float | None = None) -> float:
        """Toward the cruise speed, or slower when something ahead in the path
        needs it (the speed from which the car still stops short of it braking at
        ``gap_decel_fraction`` of its hardest), or a bend of the lane ahead
        (``turn_mps``)."""
        p, v = self.params, obs.vehicle
        room_m = gap_m - p.stop_margin_m
        decel = v.max_decel_mps2 * p.gap_decel_fraction
        allowed = math.sqrt(2 * decel * room_m) if room_m > 0 else 0.0
        if obs.speed_mps > allowed:
            return self._brake_accel(gap_m, obs, wait_m)
        target = min(self.cruise_mps, allowed, turn_mps)
        if obs.speed_mps > turn_mps:  # braking for the bend as the limit falls
            return max(-v.max_decel_mps2, p.speed_gain_1ps * (target - obs.speed_mps)
                       - decel)
        accel = p.speed_gain_1ps * (target - obs.speed_mps)
        return max(-v.max_decel_mps2, min(v.max_accel_mps2, accel))
