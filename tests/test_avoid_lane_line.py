"""Where avoid holds its lane and how it steers there (sdc.car.avoid.lane_line): the inside
of a gentle bend, the line its body fits through a tight one, the speed a bend
allows, pure pursuit toward the target. Lanes as arcs, fake returns, no SUMO."""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_avoid_perception import LANE_W, MODEL, PARAMS, frame_of, seen

from sdc.car.avoid.bend_room import track
from sdc.car.avoid.lane_frame import LaneFrame
from sdc.car.avoid.lane_line import (
    LaneLine,
    bend_speed_mps,
    inside_of_bend_m,
    pursuit_steer_rad,
)
from sdc.car.lane_path import LanePath

STRAIGHT = LanePath(np.array([[-200.0, 0.0], [200.0, 0.0]]), np.array([-200.0, 200.0]))


def arc(radius_m: float, axle_on_line: bool = False) -> LanePath:
    """A lane bending left (radius > 0) or right round a circle, the body centre on
    its centre line at station 0 heading along it (``axle_on_line``: the rear axle
    there instead, as on a steady bend)."""
    u = np.linspace(-80.0, 80.0, 641)
    r = radius_m
    x, y = r * np.sin(u / r), r * (1 - np.cos(u / r))
    if axle_on_line:  # the car's frame is from its body centre
        x = x - MODEL.center_ahead_of_rear_axle_m
    return LanePath(np.column_stack([x, y]), u)


# ---- the line in a gentle bend, and straight on ---------------------------------------

def test_straight_on_the_line_is_the_lanes_centre_and_nothing_binds():
    line = LaneLine(PARAMS).hold(frame_of(seen()), seen(speed_mps=10.0), STRAIGHT, None)
    assert line.target_m == 0.0 and line.free_m == math.inf and line.bend_mps == math.inf
    assert line.steer_path is STRAIGHT
    passing = LaneLine(PARAMS).hold(frame_of(seen()), seen(), STRAIGHT, None, centre_m=LANE_W)
    assert passing.target_m == LANE_W


def test_in_a_gentle_bend_the_car_holds_toward_its_inside():
    obs = seen()
    front_m = MODEL.length_m - MODEL.rear_overhang_m
    swing = math.hypot(60.0, front_m) - 60.0
    assert inside_of_bend_m(arc(60.0), obs) == pytest.approx(swing / 2, rel=0.05)
    assert inside_of_bend_m(arc(-60.0), obs) == pytest.approx(-swing / 2, rel=0.05)
    assert inside_of_bend_m(arc(30.0), obs) > inside_of_bend_m(arc(60.0), obs)
    assert inside_of_bend_m(STRAIGHT, obs) == 0.0
    # never more than the lane leaves beside the body
    room = LANE_W / 2 - MODEL.width_m / 2
    assert inside_of_bend_m(arc(3.0), obs) == pytest.approx(room)


# ---- tight bends ---------------------------------------------------------------------

def test_a_tight_bend_slows_the_car_to_its_lateral_acceleration():
    route = track(arc(20.0), 0.0, 30.0)
    limit = math.sqrt(PARAMS.turn_lateral_accel_mps2 * 20.0)
    assert bend_speed_mps(route, 0.0, seen(), PARAMS) == pytest.approx(limit, rel=0.1)
    wider = track(arc(40.0), 0.0, 30.0)
    assert bend_speed_mps(wider, 0.0, seen(), PARAMS) == pytest.approx(limit * math.sqrt(2),
                                                                       rel=0.1)
    # the inside's parallel is tighter: slower there
    assert bend_speed_mps(route, 1.0, seen(), PARAMS) < bend_speed_mps(route, -1.0, seen(),
                                                                       PARAMS)


def test_through_a_tight_bend_the_line_is_one_the_body_fits_and_it_is_held():
    path = arc(20.0)
    line = LaneLine(PARAMS)
    held = line.hold(frame_of(seen()), seen(speed_mps=5.0), path, None)
    assert line.bend_offset_m == held.target_m
    assert abs(held.target_m) <= LANE_W / 2 - MODEL.width_m / 2 + 1e-9
    assert held.free_m == math.inf and held.bend_mps < 10.0
    assert held.steer_path is not path  # the lane smoothed as the car's track is


def test_returns_at_the_bends_inside_push_the_line_out_or_stop_the_car():
    path = arc(20.0)
    # a wall along the inside's lane edge, 0.5 m into the lane, 10 to 25 m along
    u = np.linspace(10.0, 25.0, 61)
    inside = np.column_stack([(20.0 - 1.25) * np.sin(u / 20.0),
                              20.0 - (20.0 - 1.25) * np.cos(u / 20.0)])
    obs = seen(inside, speed_mps=5.0)
    frame = LaneFrame(obs, np.array([np.cos(obs.beam_angles_rad), np.sin(obs.beam_angles_rad)]),
                      path)
    clear = LaneLine(PARAMS).hold(frame_of(seen()), seen(speed_mps=5.0), path, None)
    pushed = LaneLine(PARAMS).hold(frame, obs, path, None)
    assert pushed.target_m < clear.target_m  # out, away from the wall
    # both lane edges walled: no offset fits, the car may go only so far
    outside = np.column_stack([(20.0 + 1.25) * np.sin(u / 20.0),
                               20.0 - (20.0 + 1.25) * np.cos(u / 20.0)])
    both = seen(np.vstack([inside, outside]), speed_mps=5.0)
    frame = LaneFrame(both, np.array([np.cos(both.beam_angles_rad),
                                      np.sin(both.beam_angles_rad)]), path)
    stuck = LaneLine(PARAMS).hold(frame, both, path, None)
    assert stuck.free_m < 15.0


# ---- steering -------------------------------------------------------------------------

def test_pursuit_steers_toward_the_target_and_not_on_it():
    def steer(path, target_m, speed_mps=8.0):
        return pursuit_steer_rad(path, target_m, 6.4, MODEL, speed_mps, 5.0)

    assert steer(STRAIGHT, 0.0) == 0.0
    assert steer(STRAIGHT, 3.5) > 0 > steer(STRAIGHT, -3.5)
    # on a steady bend, on its line: the bend's own steering angle
    bend = steer(arc(50.0, axle_on_line=True), 0.0)
    assert bend == pytest.approx(math.atan(MODEL.wheelbase_m / 50.0), rel=0.05)
    assert steer(arc(-50.0, axle_on_line=True), 0.0) == pytest.approx(-bend)
    # capped by the lateral acceleration at speed, and by the steering limit
    assert steer(STRAIGHT, 3.5, speed_mps=30.0) == pytest.approx(
        math.atan(MODEL.wheelbase_m * 5.0 / 30.0**2))
    sharp = pursuit_steer_rad(STRAIGHT, 2.0, 0.5, MODEL, 0.0, 5.0)  # 2 m over, 2 m on
    assert sharp == MODEL.max_steer_rad
