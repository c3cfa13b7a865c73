"""What avoid perceives (sdc.car.avoid.lane_frame, sdc.car.avoid.perception): returns placed
in the lane's frame, the lanes watched, the leaders tracked, what is ahead. Fake
observations: one return at each point asked for, no ray casting, no SUMO."""

from __future__ import annotations

import math

import numpy as np
import pytest

from scenarios.spec.bodies import VEHICLE_MODELS
from scenarios.spec.controller_params import AvoidParams
from sdc.car.avoid.lane_frame import FACE_JOIN_M, LaneFrame
from sdc.car.avoid.perception import (
    LEFT,
    OWN,
    RIGHT,
    STRAIGHT_AHEAD,
    Perception,
    beside_m,
    lane_bands,
    look_ahead,
)
from sdc.car.controller_api import LanesBeside, Observation
from sdc.car.lane_path import LanePath
from sdc.car.sensors import LaneReading

MODEL = VEHICLE_MODELS["x5-lesson"]
LANE_W = 3.5
LIDAR_AHEAD_M = 3.85  # of the rear axle
SENSOR_M = LIDAR_AHEAD_M - MODEL.center_ahead_of_rear_axle_m  # ahead of the body centre
FRONT_M = MODEL.length_m / 2  # the front bumper, ahead of the body centre
PARAMS = AvoidParams()


def seen(points=(), t_s: float = 0.0, speed_mps: float = 10.0, beams: int | None = None,
         rear_view: bool = False, **fields) -> Observation:
    """An observation on a straight lane, the car on its centre at station 0, whose
    range image has one return at each of ``points`` (x ahead, y left of the body
    centre) and, to make ``beams`` beams, beams without a return; ``rear_view``: the
    beams reach round to straight behind on both sides."""
    pts = np.asarray(points, float).reshape(-1, 2)
    rel = pts - [SENSOR_M, 0.0]
    angles, ranges = np.arctan2(rel[:, 1], rel[:, 0]), np.hypot(rel[:, 0], rel[:, 1])
    free = (beams or len(pts) or 1) - len(pts)
    if rear_view:
        free = max(free, 2)
    spare = np.linspace(math.pi, -math.pi, free) if rear_view else np.full(free, 0.0)
    angles = np.concatenate([angles, spare])
    ranges = np.concatenate([ranges, np.full(free, math.inf)])
    return Observation(t_s, 0.064, ranges, angles, LIDAR_AHEAD_M, LaneReading(0.0, 0.0, 0.0, 0.0),
                       LANE_W, speed_mps, 0.0, MODEL, 80.0, **fields)


def frame_of(obs: Observation) -> LaneFrame:
    cos_sin = np.array([np.cos(obs.beam_angles_rad), np.sin(obs.beam_angles_rad)])
    return LaneFrame(obs, cos_sin, STRAIGHT_AHEAD)


# ---- the lane's frame -------------------------------------------------------------

def test_returns_land_where_they_are_in_the_lane_frame():
    frame = frame_of(seen([(20.0, 1.0), (-5.0, -3.0)], beams=4))
    assert frame.xy_m.shape == (2, 2)  # beams without a return are no points
    np.testing.assert_allclose(frame.ahead_m, [20.0, -5.0], atol=1e-9)
    np.testing.assert_allclose(frame.lateral_m, [1.0, -3.0], atol=1e-9)


def test_on_a_curved_lane_a_point_on_its_centre_line_is_at_offset_zero():
    radius = 50.0
    u = np.linspace(-60, 60, 121)
    xy = np.column_stack([radius * np.sin(u / radius), radius * (1 - np.cos(u / radius))])
    path = LanePath(xy, 100.0 + u)
    on_lane = xy[90]  # 30 m along the arc
    obs = seen([on_lane, on_lane + [0.0, 2.0]])
    cos_sin = np.array([np.cos(obs.beam_angles_rad), np.sin(obs.beam_angles_rad)])
    frame = LaneFrame(obs, cos_sin, path)
    assert frame.ahead_m[0] == pytest.approx(30.0, abs=0.05)
    assert frame.lateral_m[0] == pytest.approx(0.0, abs=0.02)
    assert frame.s_m[0] == pytest.approx(130.0, abs=0.05)
    assert frame.lateral_m[1] > 1.5  # left of the centre line, off the arc


def test_within_and_ahead_bound_both_ways():
    frame = frame_of(seen([(10.0, 0.0), (10.0, 2.0), (1.5, 0.0), (30.0, -1.0)]))
    assert list(frame.within(-1.0, 1.0, 0.0, 20.0)) == [True, False, True, False]
    # ahead of the front bumper (2.43 m ahead of the centre), 0.5 m of slack behind it
    assert list(frame.ahead(-1.5, 1.5, FRONT_M)) == [True, False, False, True]
    assert list(frame.ahead(-1.5, 1.5, 1.9)) == [True, False, True, True]


def test_an_obstacles_face_joins_across_small_gaps_only():
    # a body reaching from the lane out to 1.6 m left, returns 0.5 m apart; a kerb
    # 1.5 m further out is no part of it
    body = [(20.0, y) for y in (0.0, 0.5, 1.0, 1.5, 1.6)]
    frame = frame_of(seen([*body, (20.2, 3.1), (25.0, 0.2)]))
    in_path = frame.within(-1.2, 1.2, 0.0, math.inf)
    near = frame.obstacle(in_path, depth_m=15.0)
    assert list(near) == [True] * 5 + [False, True]
    assert frame.lateral_m[near].max() == pytest.approx(1.6)
    # a gap just over FACE_JOIN_M ends the face
    apart = frame_of(seen([(20.0, 0.0), (20.0, 1.0 + FACE_JOIN_M + 0.01)]))
    near = apart.obstacle(apart.within(-1.2, 1.2, 0.0, math.inf), depth_m=15.0)
    assert list(near) == [True, False]


def test_small_bodies_tell_a_person_from_a_car():
    person = [(20.0, -0.2), (20.0, 0.0), (20.0, 0.2)]
    car = [(30.0, y) for y in np.linspace(-1.0, 1.0, 7)]
    frame = frame_of(seen(person + car))
    is_person = np.array([True] * 3 + [False] * 7)
    assert frame.small_bodies(is_person, size_m=1.8)
    assert not frame.small_bodies(~is_person, size_m=1.8)  # 2 m across: a car
    assert not frame.small_bodies(np.zeros(10, bool), size_m=1.8)


def test_nearest_gives_the_gap_from_the_front_bumper_and_the_station():
    frame = frame_of(seen([(30.0, 0.0), (12.0, 0.5), (8.0, 3.0)]))
    among = frame.within(-1.0, 1.0, -math.inf, math.inf)
    gap, s = frame.nearest(among, FRONT_M)
    assert gap == pytest.approx(12.0 - FRONT_M) and s == pytest.approx(12.0)
    assert frame.nearest(np.zeros(3, bool), FRONT_M) == (math.inf, None)


# ---- what is ahead ----------------------------------------------------------------

def test_look_ahead_takes_the_lanes_path_and_the_bodys():
    obs = seen([(20.0, 0.0), (12.0, 1.6)])  # 1.6 m left: outside the path along the lane
    ahead = look_ahead(frame_of(obs), obs, PARAMS, offset_m=0.0, swerving=False)
    assert ahead.half_lane_m == pytest.approx(MODEL.width_m / 2 + PARAMS.path_clearance_m)
    assert ahead.gap_lane_m == pytest.approx(20.0 - FRONT_M)
    assert ahead.lane_s_m == pytest.approx(20.0)
    # the body 1.5 m left of the lane's centre: the nearer return is in its path
    left = look_ahead(frame_of(obs), obs, PARAMS, offset_m=1.5, swerving=False)
    assert left.gap_path_m == pytest.approx(12.0 - FRONT_M)
    assert left.gap_lane_m == ahead.gap_lane_m


def test_swerving_its_path_is_what_its_heading_runs_into():
    # 1.2 m right of the car heading straight along its lane, the body 0.5 m right of
    # the lane's centre: in the body's band along the lane, not in front of its heading
    obs = seen([(12.0, -1.2)])
    frame = frame_of(obs)
    straight = look_ahead(frame, obs, PARAMS, offset_m=-0.5, swerving=False)
    swerving = look_ahead(frame, obs, PARAMS, offset_m=-0.5, swerving=True)
    assert straight.gap_path_m == pytest.approx(12.0 - FRONT_M)
    assert swerving.gap_path_m == math.inf and swerving.path_s_m is None
    ahead = seen([(12.0, -0.9)])  # within the body's half width plus the edge tolerance
    assert look_ahead(frame_of(ahead), ahead, PARAMS, -0.5, swerving=True).gap_path_m < math.inf


def test_lane_bands_and_the_maps_lanes_beside():
    (left, lo_l, hi_l), (right, lo_r, hi_r), (own, lo_o, hi_o) = lane_bands(seen(), 0.1)
    assert (left, right, own) == (LEFT, RIGHT, OWN)
    assert (lo_l, hi_l) == pytest.approx((1.85, 5.15))
    assert (lo_r, hi_r) == pytest.approx((-5.15, -1.85))
    assert (lo_o, hi_o) == pytest.approx((-1.65, 1.65))
    assert beside_m(LEFT, seen()) == math.inf  # the map does not say
    mapped = seen(lanes_beside=LanesBeside(40.0, 0.0))
    assert beside_m(LEFT, mapped) == 40.0 and beside_m(RIGHT, mapped) == 0.0


# ---- the lanes watched, the leaders tracked ---------------------------------------

def test_without_a_rear_view_a_lane_opens_after_it_was_watched_empty():
    look = Perception(PARAMS)
    for t in (0.0, 1.0, 2.0, 3.0):
        obs = seen(t_s=t)
        look.watch_lanes(look.frame(obs, STRAIGHT_AHEAD), obs, 0.0)
        assert look.lane_open(LEFT, obs) == (t >= PARAMS.lane_watch_s)
        assert look.lane_open(OWN, obs) == (t >= PARAMS.return_watch_s)
    assert not look.rear_view


def test_traffic_seen_beside_keeps_a_lane_closed_for_the_memory():
    look = Perception(PARAMS)
    beside = seen([(0.0, LANE_W)], t_s=0.0)  # something beside the car, left
    look.watch_lanes(look.frame(beside, STRAIGHT_AHEAD), beside, 0.0)
    later = seen(t_s=10.0, beams=1)
    look.watch_lanes(look.frame(later, STRAIGHT_AHEAD), later, 0.0)
    much_later = seen(t_s=10.0 + PARAMS.traffic_memory_s, beams=1)
    assert not look.lane_open(LEFT, seen(t_s=10.0 + PARAMS.lane_watch_s))
    assert look.lane_open(RIGHT, seen(t_s=10.0 + PARAMS.lane_watch_s))
    assert look.lane_open(LEFT, much_later)


def test_the_rear_view_is_known_from_the_beams():
    look = Perception(PARAMS)
    look.frame(seen([(10.0, 0.0)]), STRAIGHT_AHEAD)
    assert not look.rear_view
    look.frame(seen([(10.0, 0.0)], rear_view=True), STRAIGHT_AHEAD)
    assert look.rear_view


def test_leaders_are_tracked_along_the_lane_and_beside_with_a_rear_view():
    look = Perception(PARAMS)
    for k in range(12):
        t = k * 0.1
        obs = seen([(20.0 + 5.0 * t, 0.0), (30.0 - 10.0 * t, LANE_W)], t_s=t, rear_view=True)
        frame = look.frame(obs, STRAIGHT_AHEAD)
        look.track(frame, obs, look_ahead(frame, obs, PARAMS, 0.0, False))
    assert look.leader.speed_mps() == pytest.approx(5.0)
    assert look.side_leaders[LEFT].comes_toward()
    assert not look.flows_our_way(LEFT) and look.side_leaders[RIGHT].speed_mps() is None
