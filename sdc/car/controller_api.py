"""The controller protocol: what every controller, built-in or plug-in, follows.

A controller is any class with::

    def __init__(self, params: dict): ...     # the [controller] table without "name"
    def step(self, obs: Observation) -> Command: ...
    phase: str          # optional: read after each step and recorded in the trace
    look_ahead_m        # (not an attribute: the lane reading's preview distance is
                        #  the [controller] table's look_ahead_m, default 5 m)

One instance drives one run; ``step`` is called once per step, before the car
moves. Phases named ``avoid_*`` count as the maneuver in the result metrics
(``maneuver_started``, ``returned_to_lane``). A controller must be deterministic
given its observations: the trace of a run is compared bit for bit on replay.
"""

from __future__ import annotations

import math
from typing import NamedTuple, Protocol

import numpy as np

from scenarios.scene.signals import GREEN, NO_SIGNAL, RED, YELLOW
from scenarios.spec.bodies import VehicleModel
from sdc.car.sensors import LaneReading
from sdc.car.vehicle import Command

__all__ = ["GREEN", "NO_SIGNAL", "RED", "YELLOW", "Command", "Controller", "Crosswalk",
           "LaneReading", "LanesBeside", "Observation", "StopLine", "VehicleModel"]



class StopLine(NamedTuple):
    """The next stop line along the car's route, as a map and a camera give it: where
    the route enters a junction that takes traffic from another road too (a
    crossing, a merge), or one with a traffic light or a duty to give way."""

    distance_m: float  # along the route from the front bumper to the line
    signal: str  # red | yellow | green | none (no light, or one switched off)
    give_way: bool  # the car gives way there: a sign, right before left, a green without priority


class LanesBeside(NamedTuple):
    """The lanes beside the car's own, as a map gives them: how far each runs on
    ahead of the body centre, unbroken, in the car's direction and open to cars
    [m] (0: no such lane beside the car here, a kerb or the other direction's
    lane; inf: to the end of the map)."""

    left_m: float
    right_m: float


class Crosswalk(NamedTuple):
    """The next pedestrian crossing over the car's route, as a map gives it: where it
    lies along the route and how far it reaches either side of the lane's centre."""

    distance_m: float  # along the route from the front bumper to its near side (< 0: on it)
    depth_m: float  # its extent along the route
    right_m: float  # how far it reaches right of the lane's centre line (>= 0)
    left_m: float  # and left of it (>= 0)


class Observation(NamedTuple):
    """What the car senses at one step (ISO 8855: x ahead, y and angles to the left)."""

    t_s: float  # time since the run started
    step_s: float  # the control period: the time until the next step
    ranges_m: np.ndarray  # the range image, read-only; inf = no return within range
    beam_angles_rad: np.ndarray  # each beam's direction from the heading, index 0 leftmost
    lidar_ahead_m: float  # where the lidar sits, ahead of the rear axle
    lane: LaneReading | None  # offset, heading error, preview offset, s; None off the ends
    lane_width_m: float  # the width of the car's lane
    speed_mps: float
    steer_rad: float  # the road-wheel angle reached (the steering lags the command)
    vehicle: VehicleModel  # the car's size and actuator limits
    lidar_range_m: float = math.inf  # the lidar's range: no return means nothing up to it
    stop_line: StopLine | None = None  # the next stop line ahead (None: none on the route)
    lanes_beside: LanesBeside | None = None  # from the map (None: not known)
    crosswalk: Crosswalk | None = None  # the next pedestrian crossing (None: none ahead)


class Controller(Protocol):
    def step(self, obs: Observation) -> Command: ...
