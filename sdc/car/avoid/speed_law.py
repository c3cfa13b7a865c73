"""How the avoid controller holds its speed: the longitudinal law.

Toward the cruise speed by proportional feedback, never faster than the speed from
which it still stops short of what is ahead in its path braking at
``gap_decel_fraction`` of its hardest, nor than the bends ahead allow
(``turn_mps``); braking to a stop short of an obstacle; following a leader by the
intelligent driver model (Treiber et al. 2000). Every law answers an acceleration
[m/s^2] (negative: braking), within the car's limits.
"""

from __future__ import annotations

import math

from sdc.car.controller_api import Observation


class SpeedLaw:
    """The longitudinal law, its cruise speed ``cruise_speed_mps`` (none: the speed
    at the first step, :meth:`start`)."""

    def __init__(self, params):
        self.params = params
        self.cruise_mps: float | None = params.cruise_speed_mps

    def start(self, obs: Observation) -> None:
        """A step: the cruise speed is the first step's speed unless the params say."""
        if self.cruise_mps is None:
            self.cruise_mps = obs.speed_mps

    def speed_accel(self, gap_m: float, obs: Observation, turn_mps: float,
                    wait_m: float | None = None) -> float:
        """Toward the cruise speed, or slower when something ahead in the path ``gap_m``
        from the front bumper needs it (the speed from which the car still stops
        ``stop_margin_m`` short of it braking at ``gap_decel_fraction`` of its hardest:
        over it, :meth:`brake_accel` to stop ``wait_m`` short), or a bend of the lane
        ahead (``turn_mps``)."""
        p, v = self.params, obs.vehicle
        room_m = gap_m - p.stop_margin_m
        decel = v.max_decel_mps2 * p.gap_decel_fraction
        allowed = math.sqrt(2 * decel * room_m) if room_m > 0 else 0.0
        if obs.speed_mps > allowed:
            return self.brake_accel(gap_m, obs, wait_m)
        target = min(self.cruise_mps, allowed, turn_mps)
        if obs.speed_mps > turn_mps:  # braking for the bend as the limit falls
            return max(-v.max_decel_mps2, p.speed_gain_1ps * (target - obs.speed_mps)
                       - decel)
        accel = p.speed_gain_1ps * (target - obs.speed_mps)
        return max(-v.max_decel_mps2, min(v.max_accel_mps2, accel))

    def room_accel(self, free_m: float, obs: Observation, turn_mps: float) -> float:
        """To a stop ``stop_margin_m`` short of where the car may go no further,
        ``free_m`` from the front bumper (inf: no limit)."""
        if not math.isfinite(free_m):
            return math.inf
        return self.speed_accel(free_m, obs, turn_mps, wait_m=self.params.stop_margin_m)

    def brake_accel(self, gap_m: float, obs: Observation, wait_m: float | None = None,
                    far_back: bool = False) -> float:
        """Braking to stop ``wait_m`` (default ``wait_gap_m``) short of the obstacle
        ``gap_m`` ahead where the car can, else ``stop_margin_m`` short of it: the
        deceleration that needs, times ``brake_gain``, up to the car's maximum (under
        ``creep_speed_mps``: to a stop within the step). ``far_back`` (an obstacle to
        steer round once stopped): where the waiting gap is out of reach, the car's
        hardest, to stop as far back as it can."""
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

    def follow_accel(self, gap_m: float, leader_mps: float, obs: Observation,
                     turn_mps: float) -> float:
        """Following a leader ``gap_m`` ahead at ``leader_mps``: the intelligent
        driver model toward the cruise speed at the time gap ``follow_time_gap_s``
        (standing ``wait_gap_m`` behind; ``follow_accel_mps2``, ``follow_decel_mps2``),
        and never faster than the speed from which the car stops short of where the
        leader would stop braking as hard (:meth:`speed_accel` with the leader's
        stopping distance added to the gap)."""
        p, v = self.params, obs.vehicle
        speed = obs.speed_mps
        a_mps2, b_mps2 = min(p.follow_accel_mps2, v.max_accel_mps2), p.follow_decel_mps2
        wanted_m = p.wait_gap_m + max(0.0, speed * p.follow_time_gap_s + speed * (
            speed - leader_mps) / (2 * math.sqrt(a_mps2 * b_mps2)))
        free = (speed / self.cruise_mps) ** 4 if self.cruise_mps > 0 else math.inf
        idm = a_mps2 * (1 - free - (wanted_m / max(gap_m, 1e-3)) ** 2)
        decel = v.max_decel_mps2 * p.gap_decel_fraction
        bound = self.speed_accel(gap_m + leader_mps**2 / (2 * decel), obs, turn_mps)
        return max(-v.max_decel_mps2, min(idm, bound))

    def stop_short_accel(self, distance_m: float, obs: Observation, decel_mps2: float,
                         turn_mps: float) -> float:
        """To a stop ``stop_margin_m`` short of a place ``distance_m`` ahead of the front
        bumper, if the car can stop there braking at ``decel_mps2`` (or moves no faster
        than ``creep_speed_mps``); else no limit (too close: go on across)."""
        p = self.params
        if (obs.speed_mps > p.creep_speed_mps
                and obs.speed_mps**2 > 2 * decel_mps2 * max(distance_m, 0.0)):
            return math.inf
        return self.speed_accel(distance_m, obs, turn_mps, wait_m=p.stop_margin_m)
