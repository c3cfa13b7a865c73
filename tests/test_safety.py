"""Time-to-collision and road-edge gaps on hand-built scenes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from analysis.safety import road_edge_gaps_m, time_to_collision_s
from scenarios.road_geometry import RoadGeometry

EGO = np.array([0.0, 0.0, 0.0, 4.0, 2.0])  # centre at the origin, heading +x


def box(cx, cy, yaw=0.0, length=4.0, width=2.0):
    return np.array([[cx, cy, yaw, length, width]])


def test_ttc_is_gap_over_closing_speed_for_an_object_ahead():
    # front at x = 2, the stopped car's rear at 20 - 2 = 18: 16 m at 8 m/s
    assert time_to_collision_s(EGO, 8.0, box(20.0, 0.0), np.array([0.0])) == pytest.approx(2.0)
    # a car ahead at 6 m/s: closing at 2 m/s
    assert time_to_collision_s(EGO, 8.0, box(20.0, 0.5), np.array([6.0])) == pytest.approx(8.0)


def test_ttc_ignores_what_is_beside_behind_or_faster():
    assert time_to_collision_s(EGO, 8.0, box(20.0, 2.1), np.array([0.0])) == math.inf  # beside
    assert time_to_collision_s(EGO, 8.0, box(-20.0, 0.0), np.array([0.0])) == math.inf  # behind
    assert time_to_collision_s(EGO, 8.0, box(20.0, 0.0), np.array([9.0])) == math.inf  # pulls away
    assert time_to_collision_s(EGO, 8.0, np.zeros((0, 5)), np.zeros(0)) == math.inf


def test_ttc_uses_the_nearest_threat_and_zero_on_contact():
    boxes = np.vstack([box(40.0, 0.0), box(12.0, -1.2, yaw=math.pi / 2, length=0.6, width=0.6)])
    # the barrel overlaps the corridor (1.2 < 1 + 0.3); its near side at 11.7, the front at 2
    assert time_to_collision_s(EGO, 5.0, boxes, np.zeros(2)) == pytest.approx(9.7 / 5)
    assert time_to_collision_s(EGO, 5.0, box(3.5, 0.0), np.array([0.0])) == 0.0


def test_road_edge_gap_of_a_car_on_a_straight_road():
    road = RoadGeometry(np.array([[0.0, 0.0], [100.0, 0.0]]), 2, 3.5)  # edges at y = +-3.5
    boxes = np.vstack([box(50.0, 0.0), box(50.0, 2.0), box(50.0, -3.0), box(-50.0, 0.0)])
    gaps = road_edge_gaps_m(boxes, road)
    assert gaps[:3] == pytest.approx([2.5, 0.5, -0.5])
    assert np.isnan(gaps[3])  # not alongside the road
