"""Tracking a leader: the nearest return ahead in one band along the lane (the
car's own lane, its body's path, a lane beside), step by step. Its speed tells a
car to follow from an obstacle to pass.

The track is the leader's station along the lane (``LaneFrame.s_m``, the same for
a point from step to step) over the last ``leader_track_s``; its speed is the
change over the track. A station that moves by more than ``leader_jump_m``
against the track's prediction belongs to another thing: the track starts
afresh. The watch also remembers whether this leader was ever seen moving
faster than ``pass_max_speed_mps`` (a car that stopped in a queue) and since
when it stands.
"""

from __future__ import annotations

import math


class LeaderWatch:
    """The leader in one band, step by step (see the module)."""

    def __init__(self, params):
        self.params = params
        self.track: list[tuple[float, float]] = []  # (t, s) of the leader's nearest return
        self.moved = False  # was this leader seen moving faster than pass_max_speed_mps?
        self.standing_since_s = math.inf

    def update(self, t_s: float, s_m: float | None) -> None:
        """One step: the station of the nearest return in the lane (None: none)."""
        p, track = self.params, self.track
        if s_m is None:
            self._restart()
            return
        if track:
            speed = self.speed_mps() or 0.0
            expected_m = track[-1][1] + speed * (t_s - track[-1][0])
            if abs(s_m - expected_m) > p.leader_jump_m:
                self._restart()
        track.append((t_s, s_m))
        while t_s - track[0][0] > p.leader_track_s + 1e-9:
            track.pop(0)
        speed = self.speed_mps()
        if speed is None:
            return
        if speed > p.pass_max_speed_mps:
            self.moved, self.standing_since_s = True, math.inf
        elif self.standing_since_s == math.inf:
            self.standing_since_s = t_s

    def _restart(self) -> None:
        self.track.clear()
        self.moved, self.standing_since_s = False, math.inf

    def speed_mps(self) -> float | None:
        """The leader's speed along the lane (None until tracked for half of
        ``leader_track_s``)."""
        track = self.track
        span_s = track[-1][0] - track[0][0] if track else 0.0
        if span_s < self.params.leader_track_s / 2 - 1e-9:
            return None
        return (track[-1][1] - track[0][1]) / span_s

    def comes_toward(self) -> bool:
        """Does the leader come the other way, faster than ``pass_max_speed_mps``?"""
        speed = self.speed_mps()
        return speed is not None and speed < -self.params.pass_max_speed_mps

    def is_traffic(self, t_s: float) -> bool:
        """Is the leader traffic to follow or wait for, not an obstacle to pass:
        moving faster than ``pass_max_speed_mps``, or stopped after it was seen
        moving, for less than ``stand_patience_s``?"""
        speed = self.speed_mps()
        if speed is not None and speed > self.params.pass_max_speed_mps:
            return True
        return self.moved and t_s - self.standing_since_s < self.params.stand_patience_s
