"""The lane path: the lane sensor's polyline of the lane around the car, and the
controller's lane coordinates on it (exact arcs on curves, bends measured)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from scenarios.scene.road_geometry import CurveRoad, RoadGeometry
from scenarios.spec.scenario_tables import RoadSpec
from sdc.car.lane_path import LanePath
from sdc.car.sensors import PATH_TOLERANCE_M, LaneReading, LaneSensor, simplified_polyline


def curve(radius_m: float, length_m: float = 400.0) -> RoadGeometry:
    return CurveRoad.from_spec(RoadSpec(kind="curve", length_m=length_m, lanes=2,
                                        curve_radius_m=radius_m))


def reading_at(road: RoadGeometry, s_m: float, offset_m: float = 0.0, turn_rad: float = 0.0,
               range_m: float = 90.0) -> LaneReading:
    sensor = LaneSensor(road, lane=0, path_range_m=range_m)
    centre = road.xy_at(s_m, sensor.lane_d_m + offset_m)
    return sensor.measure(centre, float(road.heading_at(s_m)) + turn_rad, 5.0)


def test_the_simplified_polyline_stays_within_its_tolerance():
    theta = np.linspace(0, math.pi / 2, 2000)
    arc = 50.0 * np.column_stack([np.sin(theta), 1 - np.cos(theta)])
    keep = simplified_polyline(arc, 0.01)
    assert keep[0] and keep[-1] and 10 < keep.sum() < 200
    kept = arc[keep]
    for point in arc[::37]:  # every point lies within the tolerance of the kept polyline
        a, b = kept[:-1], kept[1:]
        t = np.clip(np.sum((point - a) * (b - a), 1) / np.sum((b - a) ** 2, 1), 0, 1)
        assert np.min(np.hypot(*(a + t[:, None] * (b - a) - point).T)) <= 0.01 + 1e-9


@pytest.mark.parametrize("radius_m", [100.0, -100.0])
def test_the_path_is_the_lane_in_the_cars_frame(radius_m):
    road = curve(radius_m)
    lane = reading_at(road, 200.0, offset_m=0.5, turn_rad=0.1)
    xy, s = lane.path_xy_m, lane.path_s_m
    assert not xy.flags.writeable and np.all(np.diff(s) > 0)
    lane_radius_m = abs(radius_m - LaneSensor(road, 0).lane_d_m)
    assert s[0] < 200 * lane_radius_m / abs(radius_m) - 90 and s[-1] > 200 + 80
    # back to the world: every vertex lies on the lane's circle
    yaw = float(road.heading_at(200.0)) + 0.1
    centre = road.xy_at(200.0, LaneSensor(road, 0).lane_d_m + 0.5)
    c, sn = math.cos(yaw), math.sin(yaw)
    world = centre + np.column_stack([xy[:, 0] * c - xy[:, 1] * sn, xy[:, 0] * sn + xy[:, 1] * c])
    ring = np.hypot(world[:, 0], world[:, 1] - radius_m)
    np.testing.assert_allclose(ring, lane_radius_m, atol=2e-3)


@pytest.mark.parametrize("radius_m", [100.0, -100.0])
def test_lane_coordinates_follow_the_arc(radius_m):
    road = curve(radius_m)
    sensor = LaneSensor(road, lane=0)
    lane = reading_at(road, 200.0, offset_m=-0.3, turn_rad=-0.05)
    path = LanePath.from_reading(lane, 5.0)
    assert path.offset_m == pytest.approx(-0.3, abs=PATH_TOLERANCE_M)
    # a point 60 m further along the lane and 3.5 m left of its centre, in the car's frame
    scale = 1 - sensor.lane_d_m / radius_m  # lane metres per road metre
    yaw = float(road.heading_at(200.0)) - 0.05
    centre = road.xy_at(200.0, sensor.lane_d_m - 0.3)
    target = road.xy_at(260.0, sensor.lane_d_m + 3.5) - centre
    c, s = math.cos(yaw), math.sin(yaw)
    local = np.array([[target[0] * c + target[1] * s, target[1] * c - target[0] * s]])
    s_m, d_m = path.to_lane(local)
    assert d_m[0] == pytest.approx(3.5, abs=0.02)  # the arc's offset, not a chord's
    assert s_m[0] - path.car_s_m == pytest.approx(60.0 * scale, abs=0.02)
    x, y = path.point_at(float(s_m[0]), float(d_m[0]))
    assert (x, y) == pytest.approx(tuple(local[0]), abs=1e-6)


def test_a_hand_made_reading_stands_for_the_arc_of_its_curvature():
    # offset 0.2, heading error 0, preview 5 m ahead bent 5^2 / (2 R) away: R = 50 left
    lane = LaneReading(0.2, 0.0, 0.2 + 25 / 100, 30.0)
    path = LanePath.from_reading(lane, 5.0)
    assert path.offset_m == pytest.approx(0.2, abs=1e-3)
    assert path.turn_speed_mps(3.0, 4.0) == pytest.approx(math.sqrt(3.0 * 50.0), rel=0.01)


def test_bends_ahead_set_a_speed_braking_reaches_them_at():
    line = np.array([[-50.0, 0.0], [0.0, 0.0], [40.0, 0.0]])
    theta = np.linspace(0, math.pi / 2, 60)[1:]  # a right turn of radius 10 m, 40 m ahead
    turn = np.column_stack([40 + 10 * np.sin(theta), -10 * (1 - np.cos(theta))])
    xy = np.vstack([line, turn])
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])
    path = LanePath(xy, s)
    expected = math.sqrt(3.0 * 10.0 + 2 * 4.0 * 40.0)  # sqrt(a R) at the bend, 40 m to brake
    assert path.turn_speed_mps(3.0, 4.0) == pytest.approx(expected, rel=0.03)
    straight = LanePath(line, np.array([0.0, 50.0, 90.0]))
    assert straight.turn_speed_mps(3.0, 4.0) == math.inf


def test_a_route_passing_close_to_itself_is_located_on_the_part_the_car_is_on():
    # out along y = 0, round, and back along y = 6: the return leg is nearer to a car
    # swerved 3.5 m left on the way out
    out = np.column_stack([np.linspace(0, 100, 11), np.zeros(11)])
    theta = np.linspace(-math.pi / 2, math.pi / 2, 20)[1:-1]
    bend = np.column_stack([100 + 3 * np.cos(theta), 3 + 3 * np.sin(theta)])
    back = np.column_stack([np.linspace(100, 0, 11), np.full(11, 6.0)])
    road = RoadGeometry(np.vstack([out, bend, back]), 1, 3.2)
    s_far, _ = road.locate(50.0, 3.6)
    assert s_far > road.length_m / 2  # the nearest segment is the way back
    s_m, d_m = road.locate_near(50.0, 3.6, 48.0)
    assert (s_m, d_m) == pytest.approx((50.0, 3.6))
