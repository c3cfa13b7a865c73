"""Road-edge gaps on hand-built scenes."""

from __future__ import annotations

import numpy as np
import pytest

from analysis.safety import road_edge_gaps_m
from scenarios.road_geometry import RoadGeometry


def box(cx, cy, yaw=0.0, length=4.0, width=2.0):
    return np.array([[cx, cy, yaw, length, width]])


def test_road_edge_gap_of_a_car_on_a_straight_road():
    road = RoadGeometry(np.array([[0.0, 0.0], [100.0, 0.0]]), 2, 3.5)  # edges at y = +-3.5
    boxes = np.vstack([box(50.0, 0.0), box(50.0, 2.0), box(50.0, -3.0), box(-50.0, 0.0)])
    gaps = road_edge_gaps_m(boxes, road)
    assert gaps[:3] == pytest.approx([2.5, 0.5, -0.5])
    assert np.isnan(gaps[3])  # not alongside the road
