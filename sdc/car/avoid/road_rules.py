"""The rules of the road that bind the avoid controller: lights, duties to give way,
pedestrian crossings, queues at junctions, lanes that end.

From the observation's map readings (``stop_line``, ``crosswalk``, ``lanes_beside``)
and the range image: :class:`RoadRules` remembers the stop lines passed (a junction
lies beyond each), when a foe was last seen before a line where the car gives way
(:mod:`sdc.car.avoid.foe_watch`) and when a person was last seen on the crossing ahead.
Each rule is a limit on the acceleration [m/s^2] (``math.inf``: none), a stop short
of a place by :class:`~sdc.car.avoid.speed_law.SpeedLaw`, or, for what stands ahead, whether
it is waited behind rather than passed.
"""

from __future__ import annotations

import math

from sdc.car.avoid.foe_watch import FoeWatch
from sdc.car.avoid.lane_frame import LaneFrame
from sdc.car.avoid.perception import beside_m
from sdc.car.avoid.speed_law import SpeedLaw
from sdc.car.controller_api import RED, YELLOW, Observation
from sdc.car.lane_path import LanePath


class RoadRules:
    """The rules, step by step (see the module)."""

    def __init__(self, params, speed: SpeedLaw):
        self.params = params
        self.speed = speed
        self.lines_s_m: list[float] = []  # the stop lines seen, along the road
        self.foes = FoeWatch(params)  # before a line where the car gives way
        self.foe_seen_s = -math.inf  # when a foe was seen last
        self.walker_seen_s = -math.inf  # when a person was seen on the crossing ahead

    # ---- what is watched ------------------------------------------------------------
    def watch(self, frame: LaneFrame, obs: Observation, path: LanePath,
              half_lane_m: float) -> None:
        """One step's returns: the foes before a line where the car gives way, within
        ``give_way_watch_m`` (beyond its lane's half width ``half_lane_m``), and the
        pedestrian crossing ahead, within ``give_way_watch_m``: a body the size of a
        person or a bicycle (``crosswalk_body_m``) on its roadway (someone on it, or
        stepping onto it)."""
        p, line = self.params, obs.stop_line
        if line is None or not line.give_way or line.distance_m > p.give_way_watch_m:
            self.foes.clear()
        else:
            line_s_m = path.car_s_m + obs.vehicle.length_m / 2 + line.distance_m
            if self.foes.foe_seen(obs, frame, path, half_lane_m, line_s_m):
                self.foe_seen_s = obs.t_s
        walk = obs.crosswalk
        if walk is None or walk.distance_m > p.give_way_watch_m:
            return
        near_m = obs.vehicle.length_m / 2 + walk.distance_m
        on_it = frame.within(-walk.right_m + p.crosswalk_kerb_m, walk.left_m - p.crosswalk_kerb_m,
                             near_m - p.crosswalk_margin_m,
                             near_m + walk.depth_m + p.crosswalk_margin_m)
        if frame.small_bodies(on_it, p.crosswalk_body_m):
            self.walker_seen_s = obs.t_s

    def waits_at_junction(self, obs: Observation, gap_m: float, standing_since_s: float
                          ) -> bool:
        """Is what stands ``gap_m`` ahead (standing since ``standing_since_s``) waited
        behind rather than passed: queued within ``junction_clear_m`` before the next
        stop line while its light is red or yellow; or, for less than
        ``queue_patience_s`` so far, queued before a line where cars give way or
        standing in a junction (up to ``junction_depth_m`` past a line seen: crossing
        or turning)? Notes the next stop line among those seen."""
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
        stood_s = obs.t_s - min(standing_since_s, obs.t_s)
        return (queued or in_junction) and stood_s < p.queue_patience_s

    # ---- the limits -----------------------------------------------------------------
    def signal_accel(self, obs: Observation, turn_mps: float) -> float:
        """Stopping short of the next stop line when its light is red and the car can
        stop there, or yellow and it can stop braking at ``yellow_decel_fraction`` of its
        hardest; otherwise no limit."""
        p, v, line = self.params, obs.vehicle, obs.stop_line
        if line is None or line.signal not in (RED, YELLOW):
            return math.inf
        decel = v.max_decel_mps2 * (1.0 if line.signal == RED else p.yellow_decel_fraction)
        return self.speed.stop_short_accel(line.distance_m, obs, decel, turn_mps)

    def give_way_accel(self, obs: Observation, turn_mps: float) -> float:
        """Stopping short of a line where the car gives way while a foe was seen in
        the last ``give_way_hold_s``, if the car can stop there; else no limit."""
        line = obs.stop_line
        if (line is None or not line.give_way
                or obs.t_s - self.foe_seen_s > self.params.give_way_hold_s + 1e-9):
            return math.inf
        return self.speed.stop_short_accel(line.distance_m, obs, obs.vehicle.max_decel_mps2,
                                           turn_mps)

    def crosswalk_accel(self, obs: Observation, turn_mps: float) -> float:
        """Stopping short of a pedestrian crossing while a person (or a bicycle) was seen
        on it in the last ``give_way_hold_s``, if the car can stop there (not once its
        front is on it); else no limit."""
        walk = obs.crosswalk
        if (walk is None or walk.distance_m < 0
                or obs.t_s - self.walker_seen_s > self.params.give_way_hold_s + 1e-9):
            return math.inf
        return self.speed.stop_short_accel(walk.distance_m, obs, obs.vehicle.max_decel_mps2,
                                           turn_mps)

    def lane_end_accel(self, obs: Observation, side: float | None, turn_mps: float) -> float:
        """Passing in the lane of the car's direction on ``side`` (None: not in such a
        lane) when it ends ahead (a merge): to a stop ``stop_margin_m`` short of its
        end, unless back in the own lane before."""
        if side is None:
            return math.inf
        end_m = beside_m(side, obs)  # from the body centre
        if not 0 < end_m < math.inf:
            return math.inf
        return self.speed.speed_accel(end_m - obs.vehicle.length_m / 2, obs, turn_mps,
                                      wait_m=self.params.stop_margin_m)
