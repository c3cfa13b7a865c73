"""How far a swerve takes the car along its lane, and how far ahead it must see.

The kinematics the avoid controller plans with (:mod:`sdc.car.avoid.plan`): a
sideways shift as bang-bang lateral acceleration plus the steering's lag, never
tighter than the steering allows; and the sight a pass needs where no lane of the
car's direction runs on beside it (a car may come the other way meanwhile).
"""

from __future__ import annotations

import math

from sdc.car.controller_api import VehicleModel


def tightest_radius_m(vehicle: VehicleModel, steer_fraction: float) -> float:
    """The rear axle's radius at ``steer_fraction`` of the steering limit: the
    tightest turn the car plans [m]."""
    steer_rad = steer_fraction * vehicle.max_steer_rad
    return vehicle.wheelbase_m / math.tan(steer_rad)


def swerve_distance_m(shift_m: float, speed_mps: float, brake_mps2: float,
                      vehicle: VehicleModel, params) -> float:
    """How far the car travels while shifting ``shift_m`` sideways, braking at
    ``brake_mps2`` meanwhile: bang-bang lateral acceleration (at most
    ``max_lateral_accel_mps2``) plus the steering's lag (winding up to
    ``swerve_steer_rad`` and back), times ``swerve_time_factor``; no less than an S of
    two arcs of the tightest radius (``tightest_steer_fraction``), however slow."""
    p, v = params, vehicle
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
    radius_m = tightest_radius_m(v, p.tightest_steer_fraction)
    half_m = min(shift_m / 2, radius_m)
    arcs_m = (2.0 * math.sqrt(half_m * (2 * radius_m - half_m))
              + max(0.0, shift_m - 2 * radius_m))
    return max(speed_mps * t_s - 0.5 * brake_mps2 * t_s**2, arcs_m)


def sight_needed_m(out_m: float, speed_mps: float, vehicle: VehicleModel, params) -> float:
    """How far ahead a side must be seen free to pass in it without a lane of the
    car's own direction there: what the car drives until it is back in its lane,
    ``out_m`` (speeding up at no more than ``follow_accel_mps2``), and what a car
    coming the other way at ``oncoming_speed_mps`` covers meanwhile."""
    accel = min(params.follow_accel_mps2, vehicle.max_accel_mps2)
    out_s = (math.sqrt(speed_mps**2 + 2 * accel * out_m) - speed_mps) / accel
    return out_m + params.oncoming_speed_mps * out_s
