"""What avoid plans (sdc.car.avoid.plan, sdc.car.avoid.swerve): the phase's one transition
function, the swerve's kinematics, the side chosen, the pass followed and ended. Fake
observations of test_avoid_perception (one return per point), no SUMO."""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_avoid_perception import FRONT_M, LANE_W, MODEL, PARAMS, seen

from scenarios.spec.controller_params import AvoidParams
from sdc.car.avoid.perception import LEFT, RIGHT, STRAIGHT_AHEAD, Perception, look_ahead
from sdc.car.avoid.plan import (
    AVOID_LEFT,
    AVOID_RETURN,
    AVOID_RIGHT,
    BRAKE,
    CRUISE,
    SWERVES,
    Maneuver,
    next_phase,
)
from sdc.car.avoid.swerve import sight_needed_m, swerve_distance_m, tightest_radius_m
from sdc.car.controller_api import LanesBeside
from sdc.car.lane_path import LanePath

PHASES = (CRUISE, BRAKE, AVOID_LEFT, AVOID_RIGHT, AVOID_RETURN)


# ---- the phase: one transition function ------------------------------------------

@pytest.mark.parametrize("phase", PHASES)
def test_a_plan_sets_the_phase_whatever_it_was(phase):
    for planned in (BRAKE, AVOID_LEFT, AVOID_RIGHT):
        assert next_phase(phase, planned) == planned


def test_no_plan_ends_braking_and_keeps_the_rest():
    assert next_phase(BRAKE, None) == CRUISE
    for phase in (CRUISE, AVOID_LEFT, AVOID_RIGHT, AVOID_RETURN):
        assert next_phase(phase, None) == phase


def test_back_returns_only_from_a_pass_and_settled_ends_only_a_return():
    assert next_phase(AVOID_LEFT, None, back=True) == AVOID_RETURN
    assert next_phase(AVOID_RIGHT, None, back=True) == AVOID_RETURN
    assert next_phase(CRUISE, None, back=True) == CRUISE
    assert next_phase(BRAKE, None, back=True) == CRUISE
    assert next_phase(AVOID_RETURN, None, settled=True) == CRUISE
    assert next_phase(AVOID_LEFT, None, settled=True) == AVOID_LEFT
    # all in one step, in order: planned out, already past, settled on the centre
    assert next_phase(CRUISE, AVOID_LEFT, back=True) == AVOID_RETURN
    assert next_phase(CRUISE, AVOID_LEFT, back=True, settled=True) == CRUISE
    assert next_phase(CRUISE, BRAKE, back=True, settled=True) == BRAKE


# ---- the swerve ------------------------------------------------------------------

def test_the_tightest_radius_is_the_bicycles_at_that_steering():
    assert tightest_radius_m(MODEL, 1.0) == pytest.approx(MODEL.min_turn_radius_m)
    assert tightest_radius_m(MODEL, 0.5) > 2 * MODEL.min_turn_radius_m


def test_a_swerve_takes_longer_the_faster_and_the_wider():
    d = [swerve_distance_m(3.5, v, 0.0, MODEL, PARAMS) for v in (5.0, 10.0, 20.0)]
    assert d[0] < d[1] < d[2]
    assert swerve_distance_m(2.0, 15.0, 0.0, MODEL, PARAMS) < d[2] * 15 / 20
    # at speed: the time (bang-bang plus the steering's lag, times the factor) x speed
    t_s = (2 * math.sqrt(3.5 / PARAMS.max_lateral_accel_mps2)
           + 2 * PARAMS.swerve_steer_rad / MODEL.max_steer_rate_radps) * PARAMS.swerve_time_factor
    assert d[2] == pytest.approx(20.0 * t_s)


def test_braking_meanwhile_shortens_a_swerve_and_standing_still_it_is_two_arcs():
    assert (swerve_distance_m(3.5, 15.0, 8.0, MODEL, PARAMS)
            < swerve_distance_m(3.5, 15.0, 0.0, MODEL, PARAMS))
    radius = tightest_radius_m(MODEL, PARAMS.tightest_steer_fraction)
    arcs = 2 * math.sqrt(1.75 * (2 * radius - 1.75))
    assert swerve_distance_m(3.5, 0.0, 0.0, MODEL, PARAMS) == pytest.approx(arcs)


def test_the_sight_a_pass_needs_grows_with_the_oncoming_speed():
    slow = sight_needed_m(60.0, 10.0, MODEL, AvoidParams(oncoming_speed_mps=10.0))
    fast = sight_needed_m(60.0, 10.0, MODEL, AvoidParams(oncoming_speed_mps=20.0))
    assert 60.0 < slow < fast
    # out 60 m from 10 m/s, speeding up at follow_accel_mps2: while that car comes 20 m/s
    out_s = (math.sqrt(10.0**2 + 2 * PARAMS.follow_accel_mps2 * 60.0) - 10.0) / 1.5
    assert fast == pytest.approx(60.0 + 20.0 * out_s) and out_s < 6.0


# ---- the maneuver ----------------------------------------------------------------

def barrel(gap_m: float, lateral_m: float = 0.0) -> list[tuple[float, float]]:
    """A 0.6 m barrel's near face ``gap_m`` ahead of the front bumper: three returns."""
    x = FRONT_M + gap_m
    return [(x, lateral_m - 0.3), (x, lateral_m), (x, lateral_m + 0.3)]


def stepped(maneuver: Maneuver, obs, path: LanePath = STRAIGHT_AHEAD, traffic=False):
    look = maneuver.look
    frame = look.frame(obs, path)
    look.watch_lanes(frame, obs, path.offset_m)
    ahead = look_ahead(frame, obs, PARAMS, path.offset_m, maneuver.phase in SWERVES)
    look.track(frame, obs, ahead)
    return maneuver.update(frame, obs, path, ahead, traffic, cruise_mps=obs.speed_mps)


def watched(points) -> Maneuver:
    """A maneuver whose lanes were watched empty since t = 0, by the beams that see
    ``points`` later (a range image's beams keep their directions)."""
    maneuver = Maneuver(PARAMS, Perception(PARAMS))
    empty = seen(points, t_s=0.0)
    stepped(maneuver, empty._replace(ranges_m=np.full(len(empty.ranges_m), math.inf)))
    return maneuver


def test_a_threat_in_the_lane_plans_a_swerve_left_first():
    points = barrel(20.0)
    maneuver = watched(points)
    plan = stepped(maneuver, seen(points, t_s=5.0, speed_mps=8.0))  # 2.5 s away
    assert plan.phase == AVOID_LEFT == maneuver.phase and plan.side == LEFT
    assert plan.accel_mps2 == 0.0 and maneuver.target_m == plan.target_m >= LANE_W
    assert maneuver.obstacle_end_s == pytest.approx(FRONT_M + 20.0)


def test_far_enough_no_plan_and_the_phase_stays():
    points = barrel(60.0)
    maneuver = watched(points)
    assert stepped(maneuver, seen(points, t_s=5.0, speed_mps=8.0)) is None  # 7.5 s away
    assert maneuver.phase == CRUISE


def test_a_blocked_left_goes_right_and_both_blocked_brakes():
    car_left = [(FRONT_M + 30.0, LANE_W + y) for y in (-0.9, 0.0, 0.9)]
    car_right = [(FRONT_M + 30.0, -LANE_W + y) for y in (-0.9, 0.0, 0.9)]
    points = barrel(20.0) + car_left
    maneuver = watched(points)
    plan = stepped(maneuver, seen(points, t_s=5.0, speed_mps=8.0))
    assert plan.phase == AVOID_RIGHT and plan.side == RIGHT and plan.target_m <= -LANE_W
    points = barrel(20.0) + car_left + car_right
    maneuver = watched(points)
    plan = stepped(maneuver, seen(points, t_s=5.0, speed_mps=8.0))
    assert plan.phase == BRAKE == maneuver.phase and plan.accel_mps2 == -MODEL.max_decel_mps2
    assert maneuver.target_m == 0.0


def test_a_lane_not_watched_yet_is_taken_only_when_braking_cannot_stop():
    points = barrel(20.0)
    maneuver = Maneuver(PARAMS, Perception(PARAMS))
    assert stepped(maneuver, seen(points, t_s=0.0, speed_mps=8.0)).phase == BRAKE
    maneuver = Maneuver(PARAMS, Perception(PARAMS))
    plan = stepped(maneuver, seen(points, t_s=0.0, speed_mps=20.0))  # 25 m to stop
    assert plan.phase == AVOID_LEFT and plan.accel_mps2 < 0


def test_braking_ends_when_nothing_threatens_and_traffic_is_never_passed():
    points = barrel(20.0)
    maneuver = watched(points)
    maneuver.phase = BRAKE
    assert stepped(maneuver, seen(t_s=5.0, beams=3)) is None and maneuver.phase == CRUISE
    maneuver.phase = BRAKE
    assert stepped(maneuver, seen(points, t_s=5.0), traffic=True) is None
    assert maneuver.phase == CRUISE


def test_no_pass_on_a_side_the_map_shows_no_lane_of_ours_beyond_sight():
    points = barrel(20.0)
    maneuver = watched(points)
    plan = stepped(maneuver, seen(points, t_s=5.0, speed_mps=8.0,
                                  lanes_beside=LanesBeside(0.0, 0.0)))
    assert plan.phase == BRAKE  # seeing 80 m is not enough for a car coming at 20 m/s
    maneuver = watched(points)
    plan = stepped(maneuver, seen(points, t_s=5.0, speed_mps=8.0,
                                  lanes_beside=LanesBeside(math.inf, 0.0)))
    assert plan.phase == AVOID_LEFT and maneuver.lane_end_side() == LEFT


def shifted(offset_m: float, s_m: float) -> LanePath:
    """The straight lane seen from a body ``offset_m`` left of its centre at station
    ``s_m``."""
    return LanePath(np.array([[-1000.0, -offset_m], [1000.0, -offset_m]]),
                    np.array([s_m - 1000.0, s_m + 1000.0]))


def test_the_pass_ends_once_the_rear_is_past_and_settles_on_the_centre():
    points = barrel(20.0)
    maneuver = watched(points)
    stepped(maneuver, seen(points, t_s=5.0, speed_mps=8.0))
    end_s = maneuver.obstacle_end_s
    # beside the barrel, out in the left lane: still passing
    rear_past = end_s + MODEL.length_m / 2 + PARAMS.return_gap_m
    stepped(maneuver, seen(t_s=6.0, beams=3), shifted(LANE_W, rear_past - 1.0))
    assert maneuver.phase == AVOID_LEFT and maneuver.target_m > 0
    stepped(maneuver, seen(t_s=7.0, beams=3), shifted(LANE_W, rear_past + 0.1))
    assert maneuver.phase == AVOID_RETURN and maneuver.target_m == 0.0
    stepped(maneuver, seen(t_s=9.0, beams=3), shifted(PARAMS.settled_offset_m / 2, rear_past + 20))
    assert maneuver.phase == CRUISE
