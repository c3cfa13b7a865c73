"""The ego car: a kinematic bicycle with steering-rate and tyre (friction) limits.

State is the rear-axle centre (the bicycle's reference point). Angles follow
ISO 8855: yaw and steering positive counter-clockwise (a positive steering
angle turns left).

Tyre limits (the friction circle, or Kamm's circle, of CommonRoad's kinematic
single-track model): the tyres carry at most ``mu * g`` of acceleration [m/s^2],
longitudinal and lateral together, ``a_long^2 + a_lat^2 <= (mu g)^2``. Within it
the longitudinal command comes first: the command is clipped to the car's own
limits (``max_accel_mps2``, ``max_decel_mps2``) and to ``mu * g``; the lateral
acceleration ``speed^2 * curvature`` then gets what is left,
``sqrt((mu g)^2 - a_long^2)``, and a sharper steering angle makes the car slide
wide (its path's curvature is capped) instead of turning tighter. Braking as hard
as the road allows leaves no grip for turning.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from scenarios.spec.bodies import GRAVITY_MPS2, VehicleModel

__all__ = ["GRAVITY_MPS2", "Command", "Vehicle", "VehicleState"]


class VehicleState(NamedTuple):  # a tuple: made every step, cheaply
    x_m: float  # rear-axle centre
    y_m: float
    yaw_rad: float
    speed_mps: float
    steer_rad: float  # road-wheel angle reached by the steering actuator


class Command(NamedTuple):
    steer_rad: float  # requested road-wheel angle, positive = left
    accel_mps2: float = 0.0


class Vehicle:
    """Steps a :class:`VehicleState` under a :class:`Command`."""

    def __init__(self, model: VehicleModel, friction_mu: float):
        self.model = model
        self.friction_mu = friction_mu
        self.grip_mps2 = friction_mu * GRAVITY_MPS2  # the friction circle's radius
        self.max_brake_mps2 = model.braking_decel_mps2(friction_mu)
        self.max_drive_mps2 = min(model.max_accel_mps2, self.grip_mps2)

    def curvature_1pm(self, steer_rad: float, speed_mps: float, accel_mps2: float = 0.0) -> float:
        """Path curvature [1/m]: the bicycle's tan(steer)/wheelbase, capped so the
        lateral acceleration speed^2 * curvature stays within the grip the
        longitudinal acceleration ``accel_mps2`` leaves, ``sqrt((mu g)^2 - accel^2)``
        (the car slides wide instead of turning tighter)."""
        curvature = math.tan(steer_rad) / self.model.wheelbase_m
        if speed_mps**2 > 0:  # not > 0 alone: a speed under 1e-162 m/s squares to 0
            lateral_mps2 = (self.grip_mps2 if accel_mps2 == 0.0 else  # exact: no sqrt
                            math.sqrt(max(self.grip_mps2**2 - accel_mps2**2, 0.0)))
            limit = lateral_mps2 / speed_mps**2
            curvature = max(-limit, min(limit, curvature))
        return curvature

    def step(self, state: VehicleState, command: Command, dt_s: float) -> VehicleState:
        model = self.model
        max_delta = model.max_steer_rate_radps * dt_s
        target = max(-model.max_steer_rad, min(model.max_steer_rad, command.steer_rad))
        steer = state.steer_rad + max(-max_delta, min(max_delta, target - state.steer_rad))
        accel = max(-self.max_brake_mps2, min(self.max_drive_mps2, command.accel_mps2))
        speed = max(0.0, state.speed_mps + accel * dt_s)
        distance_m = (state.speed_mps + speed) / 2 * dt_s
        # the acceleration reached (less than asked when the car comes to rest)
        reached_mps2 = accel if speed > 0.0 else (speed - state.speed_mps) / dt_s
        curvature = self.curvature_1pm(steer, (state.speed_mps + speed) / 2, reached_mps2)
        turn_rad = curvature * distance_m
        yaw = state.yaw_rad
        if abs(turn_rad) < 1e-9:  # straight: the arc formula below divides by curvature
            dx, dy = distance_m * math.cos(yaw), distance_m * math.sin(yaw)
        else:  # exact arc of constant curvature
            dx = (math.sin(yaw + turn_rad) - math.sin(yaw)) / curvature
            dy = (math.cos(yaw) - math.cos(yaw + turn_rad)) / curvature
        return VehicleState(state.x_m + dx, state.y_m + dy, _wrap(yaw + turn_rad), speed, steer)

    def body_box(self, state: VehicleState) -> np.ndarray:
        """The body as a box ``[cx, cy, yaw, length, width]`` [m, rad]."""
        ahead = self.model.center_ahead_of_rear_axle_m
        c, s = math.cos(state.yaw_rad), math.sin(state.yaw_rad)
        return np.array([state.x_m + ahead * c, state.y_m + ahead * s, state.yaw_rad,
                         self.model.length_m, self.model.width_m])

    def point_ahead(self, state: VehicleState, ahead_m: float) -> tuple[float, float]:
        """World x, y of the point ``ahead_m`` in front of the rear axle [m]."""
        return (state.x_m + ahead_m * math.cos(state.yaw_rad),
                state.y_m + ahead_m * math.sin(state.yaw_rad))


def _wrap(angle_rad: float) -> float:
    return (angle_rad + math.pi) % (2 * math.pi) - math.pi
