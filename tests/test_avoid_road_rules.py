"""The rules that bind avoid (sdc.car.avoid.road_rules): lights, duties to give way,
pedestrian crossings, queues at junctions, lanes that end. Fake observations of
test_avoid_perception, no SUMO."""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_avoid_perception import FRONT_M, MODEL, PARAMS, frame_of, seen

from scenarios.spec.controller_params import AvoidParams
from sdc.car.avoid.perception import LEFT, RIGHT, STRAIGHT_AHEAD
from sdc.car.avoid.road_rules import RoadRules
from sdc.car.avoid.speed_law import SpeedLaw
from sdc.car.controller_api import (
    GREEN,
    NO_SIGNAL,
    RED,
    YELLOW,
    Crosswalk,
    LanesBeside,
    StopLine,
)

FREE = math.inf


def rules(**params) -> RoadRules:
    p = AvoidParams(cruise_speed_mps=15.0, **params)
    return RoadRules(p, SpeedLaw(p))


def at_line(distance_m: float, signal: str = NO_SIGNAL, give_way: bool = False,
            speed_mps: float = 10.0, t_s: float = 0.0, points=()):
    return seen(points, t_s=t_s, speed_mps=speed_mps,
                stop_line=StopLine(distance_m, signal, give_way))


# ---- lights ----------------------------------------------------------------------

def test_red_stops_the_car_where_it_can_and_lets_it_across_where_it_cannot():
    rule = rules()
    assert rule.signal_accel(at_line(12.0, RED), FREE) < 0  # over the speed to stop there
    red = at_line(18.0, RED)  # a limit: the speed from which it stops there
    assert rule.signal_accel(red, FREE) == rule.speed.stop_short_accel(
        18.0, red, MODEL.max_decel_mps2, FREE) < rule.signal_accel(at_line(30.0, RED), FREE)
    assert rule.signal_accel(at_line(5.0, RED), FREE) == math.inf  # 6.25 m to stop at 8
    assert rule.signal_accel(at_line(30.0, GREEN), FREE) == math.inf
    assert rule.signal_accel(seen(), FREE) == math.inf  # no line


def test_yellow_stops_the_car_only_at_the_gentler_deceleration():
    rule = rules()
    # 10 m/s: 12.5 m at 4 m/s^2 (half its hardest), 6.25 m at 8
    assert rule.signal_accel(at_line(10.0, YELLOW), FREE) == math.inf
    assert rule.signal_accel(at_line(10.0, RED), FREE) < 0
    assert rules(yellow_decel_fraction=1.0).signal_accel(at_line(10.0, YELLOW), FREE) < 0


# ---- giving way --------------------------------------------------------------------

def test_a_foe_seen_holds_the_car_at_a_give_way_line_for_the_hold_time():
    rule = rules()
    rule.foe_seen_s = 2.0  # as the foe watch would note it
    line = dict(distance_m=12.0, give_way=True)
    assert rule.give_way_accel(at_line(**line, t_s=2.5), FREE) < 0
    late = 2.0 + PARAMS.give_way_hold_s + 0.1
    assert rule.give_way_accel(at_line(**line, t_s=late), FREE) == math.inf
    assert rule.give_way_accel(at_line(12.0, t_s=2.5), FREE) == math.inf  # priority


def test_the_foe_watch_forgets_away_from_a_give_way_line():
    rule = rules()
    obs = at_line(20.0, give_way=True, points=[(40.0, 10.0)])
    rule.watch(frame_of(obs), obs, STRAIGHT_AHEAD, 1.2)
    assert len(rule.foes.scans) == 1
    far = at_line(PARAMS.give_way_watch_m + 1.0, give_way=True, t_s=0.1)
    rule.watch(frame_of(far), far, STRAIGHT_AHEAD, 1.2)
    assert rule.foes.scans == [] and rule.foe_seen_s == -math.inf


# ---- pedestrian crossings -----------------------------------------------------------

def walk_obs(points, distance_m: float = 12.0, t_s: float = 1.0):
    return seen(points, t_s=t_s, crosswalk=Crosswalk(distance_m, 4.0, 5.0, 5.0))


def test_a_person_on_the_crossing_stops_the_car_short_of_it():
    rule = rules()
    x = FRONT_M + 14.0  # 2 m onto the crossing
    person = walk_obs([(x, 2.0), (x, 2.2), (x + 0.2, 2.1)])
    rule.watch(frame_of(person), person, STRAIGHT_AHEAD, 1.2)
    assert rule.walker_seen_s == 1.0
    assert rule.crosswalk_accel(person, FREE) < 0
    gone = walk_obs([], t_s=1.0 + PARAMS.give_way_hold_s + 0.1)
    assert rule.crosswalk_accel(gone, FREE) == math.inf
    on_it = walk_obs([], distance_m=-1.0, t_s=1.5)  # its front on it: go on across
    assert rule.crosswalk_accel(on_it, FREE) == math.inf


def test_a_car_on_the_crossing_or_a_person_on_the_kerb_is_no_walker():
    rule = rules()
    x = FRONT_M + 14.0
    car = walk_obs([(x, y) for y in np.linspace(-1.0, 1.0, 7)])
    rule.watch(frame_of(car), car, STRAIGHT_AHEAD, 1.2)
    kerb = walk_obs([(x, 4.8), (x, 4.9)])  # within crosswalk_kerb_m of its end
    rule.watch(frame_of(kerb), kerb, STRAIGHT_AHEAD, 1.2)
    assert rule.walker_seen_s == -math.inf


# ---- queues at junctions ----------------------------------------------------------------

def test_what_stands_before_a_red_line_is_waited_behind_however_long():
    rule = rules()
    obs = at_line(30.0, RED, t_s=100.0)
    assert rule.waits_at_junction(obs, 25.0, standing_since_s=0.0)  # 5 m before the line
    assert not rule.waits_at_junction(obs, 30.0 - PARAMS.junction_clear_m - 1.0, 0.0)
    assert not rule.waits_at_junction(at_line(30.0, GREEN, t_s=100.0), 25.0, 0.0)


def test_a_queue_at_a_give_way_line_or_in_a_junction_is_waited_for_the_patience():
    rule = rules()
    obs = at_line(30.0, give_way=True, t_s=5.0)
    assert rule.waits_at_junction(obs, 25.0, standing_since_s=0.0)
    patience = PARAMS.queue_patience_s
    assert not rule.waits_at_junction(at_line(30.0, give_way=True, t_s=patience + 1.0), 25.0,
                                      standing_since_s=0.0)
    # the line is remembered: what stands past it, in the junction, is waited for too
    past = seen(t_s=6.0, stop_line=None)
    assert rule.waits_at_junction(past, 30.0 + 5.0, standing_since_s=5.0)
    assert not rule.waits_at_junction(past, 30.0 + PARAMS.junction_depth_m + 1.0, 5.0)
    assert rule.lines_s_m == [pytest.approx(MODEL.length_m / 2 + 30.0)]
    assert not rule.waits_at_junction(past, math.inf, 5.0)  # nothing ahead


# ---- lanes that end -----------------------------------------------------------------------

def test_passing_in_a_lane_that_ends_stops_short_of_its_end():
    rule = rules()
    ends = seen(speed_mps=10.0, lanes_beside=LanesBeside(15.0, math.inf))
    assert rule.lane_end_accel(ends, LEFT, FREE) < 0
    assert rule.lane_end_accel(ends, RIGHT, FREE) == math.inf  # runs on to the map's end
    assert rule.lane_end_accel(ends, None, FREE) == math.inf  # not passing in such a lane
    gone = seen(lanes_beside=LanesBeside(0.0, 0.0))  # no lane there: not this rule's
    assert rule.lane_end_accel(gone, LEFT, FREE) == math.inf
