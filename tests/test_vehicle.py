from __future__ import annotations

import math

import pytest

from scenarios.spec.bodies import VEHICLE_MODELS
from sdc.car.vehicle import GRAVITY_MPS2, Command, Vehicle, VehicleState

LESSON = VEHICLE_MODELS["x5-lesson"]


def drive(vehicle: Vehicle, state: VehicleState, command: Command, steps: int, dt_s=0.064):
    for _ in range(steps):
        state = vehicle.step(state, command, dt_s)
    return state


def test_straight_line_at_constant_speed():
    state = drive(Vehicle(LESSON, 0.9), VehicleState(0, 0, 0, 3.74, 0), Command(0.0), 100)
    assert state.x_m == pytest.approx(3.74 * 6.4) and state.y_m == pytest.approx(0.0)


def test_low_speed_circle_has_the_bicycle_radius():
    vehicle = Vehicle(LESSON, 0.9)
    state = drive(vehicle, VehicleState(0, 0, 0, 3.0, 0), Command(0.3), 20)  # reach the angle
    assert state.steer_rad == pytest.approx(0.3)
    radius = LESSON.wheelbase_m / math.tan(0.3)
    centre = (state.x_m - radius * math.sin(state.yaw_rad),
              state.y_m + radius * math.cos(state.yaw_rad))  # to the left of the rear axle
    for _ in range(200):  # every later rear-axle position lies on that circle
        state = vehicle.step(state, Command(0.3), 0.064)
        assert math.dist((state.x_m, state.y_m), centre) == pytest.approx(radius, rel=1e-9)
    assert state.yaw_rad != 0 and state.y_m != 0


def test_lesson_steering_reaches_0_7_rad_well_within_the_left_phase():
    state = VehicleState(0, 0, 0, 3.74, 0)
    reached = drive(Vehicle(LESSON, 0.9), state, Command(0.7), 3)
    assert reached.steer_rad == pytest.approx(0.7)  # 3 periods of 64 ms < 10


def test_road_car_steering_rate_is_limited():
    road_car = VEHICLE_MODELS["x5-road"]
    state = drive(Vehicle(road_car, 0.9), VehicleState(0, 0, 0, 3.74, 0), Command(0.7), 10)
    assert state.steer_rad == pytest.approx(0.5 * 0.64)


def test_friction_caps_lateral_acceleration_at_highway_speed():
    vehicle = Vehicle(LESSON, 0.9)
    speed = 25.0
    free = math.tan(0.7) / LESSON.wheelbase_m
    capped = vehicle.curvature_1pm(0.7, speed)
    assert capped == pytest.approx(0.9 * GRAVITY_MPS2 / speed**2)
    assert capped < free
    assert vehicle.curvature_1pm(0.7, 3.74) == pytest.approx(free)  # the lesson's speed: no cap
    state = drive(vehicle, VehicleState(0, 0, 0, speed, 0.7), Command(0.7), 10)
    yaw_rate = (vehicle.step(state, Command(0.7), 0.064).yaw_rad - state.yaw_rad) / 0.064
    assert speed * yaw_rate == pytest.approx(0.9 * GRAVITY_MPS2, rel=1e-6)


def test_speed_never_negative_and_accel_is_limited():
    vehicle = Vehicle(LESSON, 0.9)
    state = drive(vehicle, VehicleState(0, 0, 0, 1.0, 0), Command(0.0, -100.0), 5)
    assert state.speed_mps == 0.0
    state = vehicle.step(VehicleState(0, 0, 0, 0, 0), Command(0.0, 100.0), 1.0)
    assert state.speed_mps == LESSON.max_accel_mps2


def stopping_distance_m(friction_mu: float, speed_mps: float = 15.0, dt_s: float = 0.064):
    """Distance from full braking at speed_mps to rest, in the model's own steps."""
    vehicle = Vehicle(LESSON, friction_mu)
    state = VehicleState(0, 0, 0, speed_mps, 0)
    while state.speed_mps > 0:
        state = vehicle.step(state, Command(0.0, -100.0), dt_s)
    return state.x_m


def test_braking_is_limited_by_the_road_s_grip():
    """On ice (mu = 0.1) full braking from 15 m/s takes v^2 / (2 mu g) = 114.7 m, not
    the brakes' 14 m; on a dry road (mu = 0.9, mu g = 8.8) the brakes' 8 m/s^2 rule."""
    ice_m = stopping_distance_m(0.1)
    assert ice_m == pytest.approx(15.0**2 / (2 * 0.1 * GRAVITY_MPS2), rel=0.02)
    # (within a step: the last step covers v dt / 2 as the car comes to rest in it)
    assert stopping_distance_m(0.9) == pytest.approx(15.0**2 / (2 * 8.0), rel=1e-3)
    assert LESSON.braking_decel_mps2(0.1) == pytest.approx(0.981)
    assert LESSON.braking_decel_mps2(0.9) == 8.0


def test_the_friction_circle_shares_grip_between_braking_and_turning():
    vehicle = Vehicle(LESSON, 0.9)
    grip = 0.9 * GRAVITY_MPS2
    speed = 20.0
    cruising = vehicle.curvature_1pm(0.5, speed)
    braking = vehicle.curvature_1pm(0.5, speed, -8.0)
    assert cruising == pytest.approx(grip / speed**2)
    assert braking == pytest.approx(math.sqrt(grip**2 - 64.0) / speed**2)  # 3.7 of 8.8 m/s^2
    assert vehicle.curvature_1pm(0.5, speed, -grip) == 0.0  # no grip left to turn
    # a step braking hard while steering: lateral^2 + longitudinal^2 within (mu g)^2
    state = VehicleState(0, 0, 0, speed, 0.5)
    after = vehicle.step(state, Command(0.5, -8.0), 0.064)
    mean_speed = (speed + after.speed_mps) / 2
    lateral = mean_speed * after.yaw_rad / 0.064
    assert lateral**2 + 8.0**2 <= grip**2 * (1 + 1e-9)
    # on ice a car at the grip's limit slides straight on while braking fully
    ice = Vehicle(LESSON, 0.1)
    after = ice.step(VehicleState(0, 0, 0, speed, 0.5), Command(0.5, -8.0), 0.064)
    assert after.yaw_rad == 0.0 and after.speed_mps == pytest.approx(speed - 0.981 * 0.064)
