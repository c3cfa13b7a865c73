"""What the avoid controller perceives: the lanes beside it, the leaders ahead, what
is in its path, from the range image in the lane's frame (:mod:`sdc.car.avoid.lane_frame`)
and the map's lanes beside.

Each step :class:`Perception` takes the returns into the lane's frame, watches the
lanes (left, right, own: may the car move into one now?) and tracks the leaders
(the nearest thing ahead in the own lane, in the body's path, in each lane beside:
:mod:`sdc.car.avoid.leader_watch`); :func:`look_ahead` finds what is nearest ahead in the
car's path along its lane and in its body's path. Sides are the sign of their
lateral offsets: ``LEFT`` +1, ``RIGHT`` -1, ``OWN`` 0.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from sdc.car.avoid.lane_frame import LaneFrame
from sdc.car.avoid.leader_watch import LeaderWatch
from sdc.car.avoid.rear_watch import RearWatch
from sdc.car.controller_api import Observation
from sdc.car.lane_path import LanePath

LEFT, RIGHT, OWN = 1.0, -1.0, 0.0  # the sign of a side's lateral offsets
#: the lane taken when it is not sensed (off the road's ends): straight ahead
STRAIGHT_AHEAD = LanePath(np.array([[-1000.0, 0.0], [1000.0, 0.0]]), np.array([-1000.0, 1000.0]))


class Ahead(NamedTuple):
    """What is nearest ahead of the front bumper at one step: in the car's path along
    its lane (its width and ``path_clearance_m`` each side, within the lane's edges)
    and in its body's path, wherever the body is. Gaps along the lane from the front
    bumper [m] (inf: nothing), stations of the nearest returns (None: none)."""

    half_lane_m: float  # half the width of the path along the lane
    in_lane: np.ndarray  # which returns are in it
    gap_lane_m: float
    lane_s_m: float | None
    gap_path_m: float
    path_s_m: float | None


def look_ahead(frame: LaneFrame, obs: Observation, params, offset_m: float,
               swerving: bool) -> Ahead:
    """What is ahead (:class:`Ahead`); the body at ``offset_m`` from the lane's centre,
    ``swerving`` (out to pass): what its heading runs into, straight ahead of it too
    (a corner it heads clear of is no stop)."""
    p, v = params, obs.vehicle
    half_lane = min(obs.lane_width_m / 2 - p.edge_tolerance_m,
                    v.width_m / 2 + p.path_clearance_m)
    front_m = v.length_m / 2
    in_lane = frame.ahead(-half_lane, half_lane, front_m)
    body_half = v.width_m / 2 + p.edge_tolerance_m
    gap_lane, lane_s = frame.nearest(in_lane, front_m)
    in_path = frame.ahead(offset_m - body_half, offset_m + body_half, front_m)
    if swerving:
        in_path &= np.abs(frame.xy_m[:, 1]) <= body_half
    gap_path, path_s = frame.nearest(in_path, front_m)
    return Ahead(half_lane, in_lane, gap_lane, lane_s, gap_path, path_s)


def lane_bands(obs: Observation, edge_tolerance_m: float):
    """(side, lo, hi): the lanes left, right and own, inside their edges."""
    w, tol = obs.lane_width_m, edge_tolerance_m
    return ((LEFT, w / 2 + tol, 1.5 * w - tol), (RIGHT, -1.5 * w + tol, -w / 2 - tol),
            (OWN, -w / 2 + tol, w / 2 - tol))


def beside_m(side: float, obs: Observation) -> float:
    """How far the map's lane of the car's direction on ``side`` runs on ahead of the
    body centre (inf: the map does not say)."""
    if obs.lanes_beside is None:
        return math.inf
    return obs.lanes_beside.left_m if side == LEFT else obs.lanes_beside.right_m


class Perception:
    """The lanes and the leaders, step by step (see the module).

    May the car move into a lane (out to pass, or back)? With a range image that
    covers the rear (beams ``rear_view_deg`` round from straight ahead on both sides)
    only into a gap that stays open at the closing speed of what comes from behind
    (:mod:`sdc.car.avoid.rear_watch`). Without a rear view, only into a lane watched empty
    beside the car for a while (``lane_watch_s``, ``traffic_memory_s``,
    ``return_watch_s``).
    """

    def __init__(self, params):
        self.params = params
        self.rear_view = False  # known from the first range image on
        self._cos_sin: np.ndarray | None = None
        self.free_since_s: dict[float, float] = {}  # since when a lane was seen empty beside
        self.traffic_seen: set[float] = set()  # the lanes where something was seen beside
        self.rear = RearWatch(params)
        self.leader = LeaderWatch(params)  # in the own lane
        self.path_leader = LeaderWatch(params)  # in the body's path, wherever it is
        self.side_leaders = {LEFT: LeaderWatch(params), RIGHT: LeaderWatch(params)}

    def frame(self, obs: Observation, path: LanePath) -> LaneFrame:
        """This step's returns on ``path``."""
        if self._cos_sin is None or self._cos_sin.shape[1] != len(obs.beam_angles_rad):
            angles = obs.beam_angles_rad
            self._cos_sin = np.array([np.cos(angles), np.sin(angles)])
            reach_rad = math.radians(self.params.rear_view_deg)
            self.rear_view = bool(len(angles)) and (angles.max() >= reach_rad - 1e-9
                                                    and angles.min() <= -reach_rad + 1e-9)
        return LaneFrame(obs, self._cos_sin, path)

    def watch_lanes(self, frame: LaneFrame, obs: Observation, offset_m: float) -> None:
        """The lanes behind (with a rear view), or beside: note what :meth:`lane_open`
        judges by. The body at ``offset_m`` from the lane's centre."""
        bands = lane_bands(obs, self.params.edge_tolerance_m)
        if self.rear_view:
            self.rear.update(frame, obs, bands, offset_m)
            return
        # without a rear view traffic from behind is unseen: a lane counts as free only
        # after the car has watched it empty beside it for a while (from the first step)
        p, v = self.params, obs.vehicle
        for side, lo, hi in bands:
            seen = np.any(frame.within(lo, hi, -v.length_m / 2 - p.rear_margin_m, v.length_m))
            if seen or side not in self.free_since_s:
                self.free_since_s[side] = obs.t_s
            if seen:
                self.traffic_seen.add(side)

    def lane_open(self, side: float, obs: Observation) -> bool:
        """May the car move into that lane now (the class's rule)?"""
        if self.rear_view:
            return self.rear.open(side, obs)
        if side == OWN:
            return obs.t_s - self.free_since_s[OWN] >= self.params.return_watch_s - 1e-9
        watch_s = self.params.lane_watch_s
        if side in self.traffic_seen:
            watch_s = max(watch_s, self.params.traffic_memory_s)
        return obs.t_s - self.free_since_s[side] >= watch_s - 1e-9

    def track(self, frame: LaneFrame, obs: Observation, ahead: Ahead) -> None:
        """Track the leaders: in the own lane and in the body's path (the stations of
        their nearest returns), and, with a rear view, in the lanes beside."""
        self.leader.update(obs.t_s, ahead.lane_s_m)
        self.path_leader.update(obs.t_s, ahead.path_s_m)
        if self.rear_view:  # the lanes beside are judged by their leaders' speeds
            front_m = obs.vehicle.length_m / 2
            for side, lo, hi in lane_bands(obs, self.params.edge_tolerance_m)[:2]:
                _, side_s = frame.nearest(frame.ahead(lo, hi, front_m), front_m)
                self.side_leaders[side].update(obs.t_s, side_s)

    def flows_our_way(self, side: float) -> bool:
        """Does what is nearest ahead in the lane on ``side`` move the car's way
        faster than ``pass_max_speed_mps`` (traffic to follow there, not a car
        standing or coming the other way)?"""
        speed = self.side_leaders[side].speed_mps()
        return speed is not None and speed > self.params.pass_max_speed_mps
