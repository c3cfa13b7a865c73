"""How avoid holds its speed (sdc.car.avoid.speed_law): cruising, braking short of what is
ahead, following by the intelligent driver model, stopping short of a place. Fake
observations of test_avoid_perception, no SUMO."""

from __future__ import annotations

import math

import pytest
from test_avoid_perception import MODEL, PARAMS, seen

from scenarios.spec.controller_params import AvoidParams
from sdc.car.avoid.speed_law import SpeedLaw

FREE = math.inf  # nothing ahead, no bend


def law(cruise_mps: float | None = 15.0, **params) -> SpeedLaw:
    speed = SpeedLaw(AvoidParams(cruise_speed_mps=cruise_mps, **params))
    speed.start(seen(speed_mps=10.0))
    return speed


def test_the_cruise_speed_is_the_first_steps_unless_given():
    unset = SpeedLaw(AvoidParams())
    unset.start(seen(speed_mps=7.0))
    unset.start(seen(speed_mps=9.0))
    assert unset.cruise_mps == 7.0
    assert law(15.0).cruise_mps == 15.0


def test_toward_the_cruise_speed_by_the_gain_within_the_cars_limits():
    speed = law(12.0)
    assert speed.speed_accel(FREE, seen(speed_mps=10.0), FREE) == pytest.approx(
        PARAMS.speed_gain_1ps * 2.0)
    assert speed.speed_accel(FREE, seen(speed_mps=12.0), FREE) == 0.0
    assert law(40.0).speed_accel(FREE, seen(speed_mps=0.0), FREE) == MODEL.max_accel_mps2


def test_slower_as_something_ahead_needs_it():
    speed = law(15.0)
    obs = seen(speed_mps=10.0)
    # room: stops short of it braking at half its hardest from sqrt(2 * 4 * room)
    room = 10.0**2 / (2 * MODEL.max_decel_mps2 * PARAMS.gap_decel_fraction)
    gap = room + PARAMS.stop_margin_m
    assert speed.speed_accel(gap + 5.0, obs, FREE) > 0
    assert speed.speed_accel(gap - 1.0, obs, FREE) < 0  # over the allowed speed: brakes


def test_braking_for_a_bend_as_its_limit_falls():
    speed = law(15.0)
    accel = speed.speed_accel(FREE, seen(speed_mps=12.0), 10.0)
    decel = MODEL.max_decel_mps2 * PARAMS.gap_decel_fraction
    assert accel == pytest.approx(PARAMS.speed_gain_1ps * (10.0 - 12.0) - decel)


def test_braking_stops_wait_gap_short_where_it_can_else_stop_margin_short():
    speed = law()
    obs = seen(speed_mps=10.0)
    far = speed.brake_accel(40.0, obs)  # room to stop wait_gap_m short: 33 m
    assert far == pytest.approx(-PARAMS.brake_gain * 100 / (2 * (40.0 - PARAMS.wait_gap_m)))
    near = speed.brake_accel(10.0, obs)  # 3 m short of the waiting gap: stop margin
    assert near == -MODEL.max_decel_mps2  # 100 / 17 x 1.5 > 8
    assert speed.brake_accel(10.0, obs, far_back=True) == -MODEL.max_decel_mps2
    assert speed.brake_accel(30.0, obs, wait_m=0.0) > speed.brake_accel(30.0, obs)


def test_standing_it_stays_or_backs_off_never_creeps():
    speed = law()
    assert speed.brake_accel(10.0, seen(speed_mps=0.0)) == 0.0
    assert speed.brake_accel(1.0, seen(speed_mps=0.0)) == -MODEL.max_decel_mps2
    # under the creep speed: to a stop within the step
    slow = seen(speed_mps=0.3)
    assert speed.brake_accel(30.0, slow) == pytest.approx(
        -min(MODEL.max_decel_mps2, PARAMS.brake_gain * 0.3 / slow.step_s))


def test_following_is_the_intelligent_driver_model():
    speed = law(15.0)
    obs = seen(speed_mps=10.0)
    a = PARAMS.follow_accel_mps2
    gap = 60.0
    wanted = PARAMS.wait_gap_m + 10.0 * PARAMS.follow_time_gap_s  # same speed as the leader
    idm = a * (1 - (10.0 / 15.0) ** 4 - (wanted / gap) ** 2)
    assert speed.follow_accel(gap, 10.0, obs, FREE) == pytest.approx(idm)
    # closing on a slower leader asks more of the gap: it brakes
    assert speed.follow_accel(20.0, 2.0, obs, FREE) < 0 < speed.follow_accel(gap, 10.0, obs, FREE)
    assert speed.follow_accel(0.5, 0.0, obs, FREE) == -MODEL.max_decel_mps2  # at most its hardest


def test_stopping_short_of_a_place_only_where_the_car_can():
    speed = law()
    obs = seen(speed_mps=10.0)
    decel = MODEL.max_decel_mps2
    assert speed.stop_short_accel(5.0, obs, decel, FREE) == math.inf  # 6.25 m to stop
    # 12 m: over the speed from which it stops there at half its hardest, it brakes
    stop = speed.stop_short_accel(12.0, obs, decel, FREE)
    assert stop < 0 and stop == speed.speed_accel(12.0, obs, FREE, wait_m=PARAMS.stop_margin_m)
    assert speed.stop_short_accel(40.0, obs, decel, FREE) > 0  # far yet: speeding up
    creeping = seen(speed_mps=0.4)  # however close, from the creep speed it stops
    assert speed.stop_short_accel(0.0, creeping, decel, FREE) < 0


def test_room_ahead_binds_only_when_it_ends():
    speed = law()
    obs = seen(speed_mps=10.0)
    assert speed.room_accel(math.inf, obs, FREE) == math.inf
    assert speed.room_accel(12.0, obs, FREE) == speed.speed_accel(
        12.0, obs, FREE, wait_m=PARAMS.stop_margin_m) < 0
