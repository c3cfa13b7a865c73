from __future__ import annotations

import math

import numpy as np
import pytest

from scenarios import LidarSpec, RoadSpec
from scenarios.scene.road_geometry import CurveRoad, StraightRoad
from sdc.car.sensors import LaneSensor, Lidar, beam_angles_rad

NO_EDGES = np.zeros((0, 4))


def lidar(noise_std_m=0.0, edges=NO_EDGES, seed=0, **spec) -> Lidar:
    return Lidar(LidarSpec(noise_std_m=noise_std_m, **spec), edges, np.random.default_rng(seed))


def test_beam_layout_follows_the_lesson():
    angles = beam_angles_rad(180, 180.0)
    assert angles[0] == pytest.approx(math.pi / 2)  # index 0 leftmost
    assert angles[90] == 0.0  # the middle index looks straight ahead
    assert np.all(np.diff(angles) < 0)  # sweeping to the right
    assert angles[85] == pytest.approx(math.radians(5)) and angles[95] == pytest.approx(
        math.radians(-5))


def test_barrel_straight_ahead_gives_the_analytic_range_on_the_central_beams():
    barrel = np.array([[10.0, 0.0, 0.0, 0.6, 0.6]])
    ranges = lidar().scan(np.array([0.0, 0.0]), 0.0, barrel)
    angles = beam_angles_rad(180, 180.0)
    expected = np.full(180, np.inf)
    hits = np.abs(9.7 * np.tan(angles)) <= 0.3
    expected[hits] = 9.7 / np.cos(angles[hits])
    assert hits.sum() == 3  # beams 89, 90, 91
    np.testing.assert_allclose(ranges, expected, atol=0.01)


def test_sensor_pose_rotates_the_scan():
    box = np.array([[0.0, 20.0, 0.0, 4.5, 1.8]])  # 20 m to the left of the origin
    ranges = lidar().scan(np.array([0.0, 0.0]), math.pi / 2, box)  # facing +y
    assert ranges[90] == pytest.approx(20 - 0.9)
    ranges = lidar().scan(np.array([0.0, 0.0]), 0.0, box)  # facing +x: seen by beam 0
    assert ranges[0] == pytest.approx(20 - 0.9) and np.isinf(ranges[90])


def test_road_edges_are_seen_and_can_be_hidden():
    road = StraightRoad.from_spec(RoadSpec(length_m=200.0, lanes=3))
    origin = np.array([50.0, road.lane_center_d_m(0)])
    with_edges = lidar(edges=road.edge_segments()).scan(origin, 0.0, np.zeros((0, 5)))
    assert with_edges[0] == pytest.approx(5.25 + 3.5)  # left edge, straight to the left
    assert with_edges[179] == pytest.approx(1.75 / math.cos(math.radians(1)))
    blind = lidar().scan(origin, 0.0, np.zeros((0, 5)))
    assert np.all(np.isinf(blind))


def test_out_of_range_is_inf_and_the_nearer_box_wins():
    boxes = np.array([[30.0, 0.0, 0.0, 4.5, 1.8], [90.0, 0.0, 0.0, 4.5, 1.8]])
    ranges = lidar().scan(np.array([0.0, 0.0]), 0.0, boxes[::-1])
    assert ranges[90] == pytest.approx(27.75)
    assert np.isinf(lidar().scan(np.array([0.0, 0.0]), 0.0, boxes[1:])[90])


def test_noise_is_seeded_and_leaves_misses_alone():
    box = np.array([[10.0, 0.0, 0.0, 4.5, 4.0]])
    a = lidar(0.05, seed=3).scan(np.zeros(2), 0.0, box)
    b = lidar(0.05, seed=3).scan(np.zeros(2), 0.0, box)
    np.testing.assert_array_equal(a, b)
    clean = lidar().scan(np.zeros(2), 0.0, box)
    assert np.array_equal(np.isinf(a), np.isinf(clean))
    hit = np.isfinite(clean)
    diff = a[hit] - clean[hit]
    assert 0 < np.std(diff) < 0.1


def test_point_cloud_is_in_the_sensor_frame():
    sensor = lidar()
    ranges = sensor.scan(np.array([5.0, 5.0]), math.pi, np.array([[-5.0, 5.0, 0.0, 2.0, 2.0]]))
    points = sensor.points(ranges)
    assert len(points) == np.isfinite(ranges).sum() > 0
    # 10 m ahead of the sensor, 1 m half-size, the sensor 3.85 m ahead of the rear axle
    np.testing.assert_allclose(points[:, 0].min(), 3.85 + 9.0, atol=1e-9)
    assert np.all(np.abs(points[:, 1]) <= 1.0 + 1e-9)


@pytest.mark.parametrize("radius_m", [None, 100.0, -100.0])
def test_lane_offset_sign_heading_error_and_look_ahead(radius_m):
    spec = RoadSpec(length_m=150.0, lanes=3, kind="curve" if radius_m else "straight",
                    curve_radius_m=radius_m)
    road = (CurveRoad if radius_m else StraightRoad).from_spec(spec)
    sensor = LaneSensor(road, lane=0)
    s = 60.0
    heading = float(road.heading_at(s))
    left_of_centre = road.xy_at(s, road.lane_center_d_m(0) + 0.4)
    reading = sensor.measure(left_of_centre, heading, look_ahead_m=0.0)
    assert reading.offset_m == pytest.approx(0.4, abs=1e-3)
    assert reading.heading_error_rad == pytest.approx(0.0, abs=0.01)
    assert reading.s_m == pytest.approx(s, abs=0.01)
    # pointing 0.1 rad left of the lane: the look-ahead point is further left
    on_centre = road.xy_at(s, road.lane_center_d_m(0))
    turned = sensor.measure(on_centre, heading + 0.1, look_ahead_m=5.0)
    assert turned.heading_error_rad == pytest.approx(0.1, abs=0.01)
    bend_m = 5.0**2 / (2 * radius_m) if radius_m else 0.0  # how far the lane curves away
    assert turned.preview_offset_m == pytest.approx(5.0 * math.sin(0.1) - bend_m, abs=0.02)
    assert sensor.measure(road.xy_at(-5.0, 0.0), heading, 5.0) is None  # before the road
