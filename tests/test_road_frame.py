"""Safety measures along the road: curves read like straight roads, and a clean pass
never reads as contact."""

from __future__ import annotations

import math

import numpy as np
import pytest

from scenarios.scene.road_geometry import CurveRoad, RoadGeometry, StraightRoad
from scenarios.scene.snapshot import NO_BOXES, Snapshot, passenger_classes
from scenarios.spec.scenario_tables import RoadSpec
from sdc.car.geometry_kernels import contacts_numpy
from sdc.car.road_frame import RoadFrame

CAR = (4.5, 1.8)
EGO = (4.85, 1.93)


def curve(radius_m: float, lanes: int = 2) -> RoadGeometry:
    return CurveRoad.from_spec(RoadSpec(kind="curve", curve_radius_m=radius_m,
                                        length_m=400.0, lanes=lanes, lane_width_m=3.5))


def body(road: RoadGeometry, s_m: float, d_m: float, size=CAR, yaw_offset_rad=0.0):
    x, y = road.xy_at(s_m, d_m)
    return np.array([x, y, float(road.heading_at(s_m)) + yaw_offset_rad, *size])


def measure(road, lane_d_m, ego, ego_speed, boxes, speeds):
    """The conflicts with boxes of traffic at speeds."""
    snapshot = Snapshot(0.0, np.array(boxes).reshape(-1, 5), NO_BOXES, np.asarray(speeds, float),
                        passenger_classes(len(speeds)))
    return RoadFrame(road, lane_d_m).measure(ego, ego_speed, snapshot)[1]


@pytest.mark.parametrize("radius_m", [150.0, -150.0, 60.0])
def test_a_stopped_car_ahead_in_the_lane_of_a_curve_is_the_gap_along_the_lane(radius_m):
    """160 m ahead around a curve, where a straight-ahead look sees nothing: the TTC
    is the gap along the ego's lane over its speed, DRAC v^2 / (2 gap)."""
    road = curve(radius_m)
    d_m = road.lane_center_d_m(0)
    ego = body(road, 20.0, d_m, EGO)
    ahead = body(road, 180.0, d_m)
    lane_gap_m = (180.0 - 20.0) * (1 - d_m / radius_m) - (EGO[0] + CAR[0]) / 2
    measured = measure(road, d_m, ego, 15.0, [ahead], [0.0])
    assert measured.ttc_s == pytest.approx(lane_gap_m / 15.0, rel=1e-4)
    assert measured.drac_mps2 == pytest.approx(15.0**2 / (2 * lane_gap_m), rel=1e-4)
    assert measured.headway_s == pytest.approx(measured.ttc_s)
    # a slower car in the lane: the closing speed along the lane
    slower = measure(road, d_m, ego, 15.0, [ahead], [10.0])
    assert slower.ttc_s == pytest.approx(lane_gap_m / 5.0, rel=1e-4)


@pytest.mark.parametrize("radius_m", [80.0, -80.0, 150.0])
@pytest.mark.parametrize("s_m", [20.0, 24.0, 30.0, 40.0])
def test_a_truck_in_the_next_lane_of_a_curve_is_no_conflict(radius_m, s_m):
    """Lane keeping past a truck in the next lane on a curve: 1.2 m apart, never on a
    course to touch (the old straight-ahead box extents read 0)."""
    road = curve(radius_m)
    ego = body(road, s_m, road.lane_center_d_m(0), EGO)
    truck = body(road, 30.0, road.lane_center_d_m(1), (12.0, 2.5))
    measured = measure(road, road.lane_center_d_m(0), ego, 15.0, [truck], [0.0])
    assert measured.ttc_s == math.inf and measured.headway_s == math.inf
    assert measured.drac_mps2 == 0.0


@pytest.mark.parametrize("radius_m", [60.0, -60.0])
def test_zero_exactly_when_the_bodies_touch(radius_m):
    """Bumper to bumper on a tight curve, a few centimetres either side of touching
    (the boxes' inner corners meet about 7 cm before their centres are a body length
    apart along the lane):
    the TTC is 0 exactly when the world's boxes overlap, and small but positive
    otherwise (where the unrolled boxes overlap but the world's do not, the world's
    exact first contact is taken)."""
    road = curve(radius_m)
    d_m = road.lane_center_d_m(0)
    k = 1 - d_m / radius_m
    ego = body(road, 50.0, d_m, EGO)
    seen = set()
    for apart_m in np.linspace(-0.05, 0.15, 41):
        other = body(road, 50.0 + ((EGO[0] + CAR[0]) / 2 + apart_m) / k, d_m)
        overlap = contacts_numpy(ego, np.zeros((0, 5)), other[None])[1] >= 0
        ttc_s = measure(road, d_m, ego, 5.0, [other], [0.0]).ttc_s
        assert (ttc_s == 0.0) == overlap
        assert ttc_s <= 0.15 / 5.0 + 1e-9  # 15 cm at 5 m/s and less
        seen.add(overlap)
    assert seen == {True, False}


def test_traffic_from_behind_closing_in_counts():
    road = StraightRoad.from_spec(RoadSpec(kind="straight", length_m=400.0, lanes=2))
    d_m = road.lane_center_d_m(0)
    ego = body(road, 100.0, d_m, EGO)
    behind = body(road, 70.0, d_m)  # 30 - 4.675 m behind, closing at 5 m/s
    measured = measure(road, d_m, ego, 15.0, [behind], [20.0])
    assert measured.ttc_s == pytest.approx((30.0 - (EGO[0] + CAR[0]) / 2) / 5.0)
    assert measured.headway_s == math.inf  # not a leader of the ego


@pytest.mark.parametrize("radius_m", [80.0, -80.0])
def test_lane_keeping_past_a_truck_on_a_curve_is_a_clean_pass(lesson_plain, radius_m):
    """The real run of the issue: lane keeping past a truck in the next lane on an
    80 m curve, 0.8 to 1.3 m apart. The old straight-ahead extents read a TTC of
    0.001 s on the right-hand curve."""
    from scenarios.spec.scenario_spec import ScenarioSpec
    from sdc.run.episode import run_episode

    lesson_plain["road"].update(kind="curve", curve_radius_m=radius_m, length_m=150.0, lanes=2)
    lesson_plain["obstacles"] = [{"kind": "truck", "lane": 1, "position_m": 60.0}]
    lesson_plain["ego"].update(lane=0, speed_mps=12.0)
    lesson_plain["controller"] = {"name": "lane-keep"}
    lesson_plain["scenario"]["duration_s"] = 10.0
    row = run_episode(ScenarioSpec.from_plain(lesson_plain)).row
    assert row["collision"] is False and 0.8 < row["min_gap_obstacle_m"] < 1.5
    assert row["min_ttc_s"] is None or row["min_ttc_s"] > 0.5
