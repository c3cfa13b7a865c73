from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from scenarios import RoadSpec
from scenarios.scene import road_kernels
from scenarios.scene.road_geometry import CurveRoad, RoadGeometry, StraightRoad
from scenarios.sumo_net.build import EDGE_ID
from scenarios.sumo_net.road_source import road_source

try:
    from scenarios.scene import _road_kernels as compiled
except ImportError:  # built without a C compiler: only the numpy twins are there
    compiled = None

needs_compiled = pytest.mark.skipif(compiled is None, reason="the C extension was not built")


def curve(radius_m: float, lanes: int = 3) -> RoadSpec:
    return RoadSpec(kind="curve", length_m=200.0, lanes=lanes, curve_radius_m=radius_m)


@pytest.mark.parametrize("radius_m", [60.0, -60.0])
def test_curve_frenet_round_trip(radius_m):
    road = CurveRoad.from_spec(curve(radius_m))
    assert road.length_m == pytest.approx(200.0, abs=0.01)
    s = np.array([0.0, 33.3, 100.0, 199.0])
    d = np.array([-4.0, 0.0, 1.75, 5.0])
    s2, d2 = road.to_frenet(road.xy_at(s, d))
    np.testing.assert_allclose(s2, s, atol=0.02)
    np.testing.assert_allclose(d2, d, atol=0.002)
    # the arc's analytic geometry: distance from the turn centre is |R| - d * sign(R)
    centre = np.array([0.0, radius_m])
    dist = np.hypot(*(road.xy_at(s, d) - centre).T)
    np.testing.assert_allclose(dist, abs(radius_m) - d * math.copysign(1, radius_m), atol=0.002)
    heading = road.heading_at(100.0)
    assert heading == pytest.approx(100.0 / radius_m, abs=0.01)


def polyline(road: RoadGeometry) -> tuple[np.ndarray, ...]:
    """The road's segments as the kernels take them: starts, directions, lengths, s."""
    return road.polyline[:4]


def frenet_by(frenet, road: RoadGeometry, points: np.ndarray) -> np.ndarray:
    """s, d and edge gaps of the points, from one implementation of the kernel."""
    s_m, d_m, gaps_m = found = np.full((3, len(points)), np.nan)
    frenet(np.ascontiguousarray(points, float), *polyline(road), s_m, d_m, road.half_width_m,
           road.length_m, gaps_m)
    return found


def locate_by(locate, road: RoadGeometry, points: np.ndarray) -> np.ndarray:
    """(s, d) of each point, one point at a time, as (2, K)."""
    return np.array([locate(x, y, *polyline(road)) for x, y in points.tolist()]).reshape(-1, 2).T


coordinate = st.floats(-200.0, 200.0, allow_nan=False)
polyline_st = st.lists(st.tuples(coordinate, coordinate), min_size=2, max_size=12).map(
    lambda points: np.array(points)).filter(
    lambda line: np.all(np.hypot(*np.diff(line, axis=0).T) > 1e-3))
points_st = st.lists(st.tuples(coordinate, coordinate), min_size=1, max_size=10).map(np.array)


@settings(max_examples=300, deadline=None)
@given(line=polyline_st, points=points_st)
def test_the_numpy_frenet_projection_equals_the_compiled_one(line, points):
    """Any polyline (one segment: a straight road), points anywhere, vertices and
    segment ends included: the numpy twin and the compiled kernel give the same s, d
    and edge gaps, bit for bit, for many points or one, and so does the road; the
    heading is the segment's at s."""
    points = np.vstack([points, line, (line[:-1] + line[1:]) / 2])
    road = RoadGeometry(line, 2, 3.5)
    twin = frenet_by(road_kernels.frenet_numpy, road, points)
    expected_s, expected_d, expected_gaps = twin
    if compiled is not None:
        assert frenet_by(compiled.frenet, road, points).tobytes() == twin.tobytes()
        assert locate_by(compiled.locate, road, points).tobytes() == twin[:2].tobytes()
    assert locate_by(road_kernels.locate_numpy, road, points).tobytes() == twin[:2].tobytes()
    # the road asks whichever kernels run
    assert np.array(road.to_frenet(points)).tobytes() == twin[:2].tobytes()
    assert road.edge_gaps_m(points).tobytes() == expected_gaps.tobytes()
    located = np.array([road.locate(x, y) for x, y in points.tolist()]).reshape(-1, 2)
    assert located.T.tobytes() == twin[:2].tobytes()
    # the edge gaps: beside the road, the distance to the nearer edge
    alongside = (expected_s >= 0) & (expected_s <= road.length_m)
    assert expected_gaps.tobytes() == np.where(alongside, 3.5 - np.abs(expected_d),
                                               np.inf).tobytes()
    # and the heading, of one position or many
    delta = np.diff(line, axis=0)
    length = np.hypot(delta[:, 0], delta[:, 1])
    heading = np.arctan2(delta[:, 1] / length, delta[:, 0] / length)
    start_s = np.concatenate([[0.0], np.cumsum(length)[:-1]])
    seg = np.clip(np.searchsorted(start_s, expected_s, side="right") - 1, 0, len(line) - 2)
    np.testing.assert_array_equal(road.heading_at(expected_s), heading[seg])
    assert [road.heading_at_s(s) for s in expected_s.tolist()] == heading[seg].tolist()


@needs_compiled
def test_the_numpy_frenet_projection_on_a_long_curve():
    road = CurveRoad.from_spec(RoadSpec(kind="curve", length_m=1000.0, lanes=3,
                                        curve_radius_m=150.0))
    points = np.random.default_rng(4).uniform(-200, 1000, (2000, 2))
    twin = frenet_by(road_kernels.frenet_numpy, road, points)
    assert len(road.center_xy) > 500
    assert frenet_by(compiled.frenet, road, points).tobytes() == twin.tobytes()
    assert np.isfinite(twin[2]).any() and np.isinf(twin[2]).any()


def placed(road: RoadGeometry, boxes: np.ndarray, speeds: np.ndarray,
           lane_scale: float) -> np.ndarray:
    """The ego (the first box), obstacles (the next two) and traffic placed in the road
    frame: boxes and velocities side by side, (N, 7)."""
    out_boxes, out_velocities = np.full((len(boxes), 5), np.nan), np.full((len(boxes), 2), np.nan)
    road_kernels.place_numpy(boxes[0], float(speeds[0]), boxes[1:3], boxes[3:], speeds[3:],
                             *road.polyline, road.curvature_1pm, lane_scale, out_boxes,
                             out_velocities)
    return np.hstack([out_boxes, out_velocities])


@settings(max_examples=300, deadline=None)
@given(line=polyline_st, points=points_st.filter(lambda p: len(p) >= 3),
       curvature=st.sampled_from([0.0, 1 / 150, -1 / 60]), lane_scale=st.floats(0.9, 1.1))
def test_the_road_frame_places_bodies_along_the_lane(line, points, curvature, lane_scale):
    """Bodies anywhere, placed in the road frame: x is s times the lane's scale, y is
    d, and the velocity is split along and across (the compiled placement, part of
    the car's step, is held to this twin in tests/test_kernels.py)."""
    rng = np.random.default_rng(len(points))
    boxes = np.column_stack([points, rng.uniform(-4, 4, len(points)),
                             rng.uniform(0.5, 12, len(points)), rng.uniform(0.5, 2.5, len(points))])
    speeds = rng.uniform(0, 30, len(points))
    road = RoadGeometry(line, 2, 3.5, curvature)
    twin = placed(road, boxes, speeds, lane_scale)
    s_m, d_m = road.to_frenet(boxes[:, :2])
    np.testing.assert_array_equal(twin[:, 0], s_m * lane_scale)
    np.testing.assert_array_equal(twin[:, 1], d_m)
    np.testing.assert_array_equal(twin[:, 3:5], boxes[:, 3:5])
    moving = np.concatenate([speeds[:1], np.zeros(2), speeds[3:]])  # obstacles stand still
    scale = lane_scale / (1 - curvature * d_m) if curvature else 1.0
    np.testing.assert_allclose(np.hypot(twin[:, 5] / scale, twin[:, 6]), moving, rtol=1e-12,
                               atol=1e-12)


@settings(max_examples=300, deadline=None)
@given(line=polyline_st, points=points_st)
def test_any_off_road_is_some_point_beyond_an_edge_before_the_end(line, points):
    """The step's road-edge question, read point by point in plain floats, answers as
    the edge gaps of all the points at once do: some point beyond an edge, alongside
    the road before its end."""
    road = RoadGeometry(line, 2, 3.5)
    s_m, _ = road.to_frenet(points)
    expected = bool((road.off_road(points) & (s_m < road.length_m)).any())
    assert road.any_off_road(points) is expected


def test_the_projection_takes_the_nearest_segment():
    """A right angle: each point on the leg it is nearest to, s and d exact."""
    road = RoadGeometry(np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]]), 2, 3.5)
    points = np.array([[4.0, 1.0], [11.0, 6.0], [-2.0, -1.0], [12.0, 14.0], [9.0, 3.0]])
    for frenet in (road_kernels.frenet_numpy, road_kernels.frenet):
        s_m, d_m, gaps_m = frenet_by(frenet, road, points)
        np.testing.assert_array_equal(s_m, [4.0, 16.0, -2.0, 24.0, 13.0])
        np.testing.assert_array_equal(d_m, [1.0, -1.0, -1.0, -2.0, 1.0])
        np.testing.assert_array_equal(gaps_m, [2.5, 2.5, np.inf, np.inf, 2.5])


def test_straight_road_edges_and_lanes():
    road = StraightRoad.from_spec(RoadSpec(length_m=100.0, lanes=3))
    assert [road.lane_center_d_m(i) for i in range(3)] == [-3.5, 0.0, 3.5]
    np.testing.assert_allclose(road.edge_segments(), [[0, -5.25, 100, -5.25], [0, 5.25, 100, 5.25]])
    s, d = road.to_frenet(np.array([[-3.0, 1.0], [110.0, -2.0]]))
    np.testing.assert_allclose(s, [-3.0, 110.0])  # extended beyond both ends
    np.testing.assert_allclose(d, [1.0, -2.0])


@pytest.mark.parametrize("spec", [RoadSpec(length_m=300.0, lanes=3), curve(80.0), curve(-120.0, 2)],
                         ids=["straight", "left-curve", "right-curve"])
def test_sumo_lanes_match_our_geometry(tmp_path, spec):
    """SUMO's lane road_i is our lane i: its shape lies on our lane centre line."""
    import libsumo

    source = road_source(spec)  # its shape's class: StraightRoad or CurveRoad
    road = source.shape.from_spec(spec)
    net = source.network_file(tmp_path)
    assert source.network_file(tmp_path) == net  # cached by content
    libsumo.start(["sumo", "--net-file", str(net), "--no-step-log", "true"])
    try:
        for lane in range(spec.lanes):
            shape = np.array(libsumo.lane.getShape(f"{EDGE_ID}_{lane}"))
            s, d = road.to_frenet(shape)
            np.testing.assert_allclose(d, road.lane_center_d_m(lane), atol=0.01)
            assert s.min() == pytest.approx(0.0, abs=0.05)
            assert s.max() == pytest.approx(road.length_m, abs=0.05)
            # SUMO measures positions on every lane by the centre line's length
            assert libsumo.lane.getLength(f"{EDGE_ID}_{lane}") == pytest.approx(
                road.length_m, abs=0.01)
    finally:
        libsumo.close()


@needs_compiled
def test_the_compiled_projection_refuses_wrong_arrays_by_name():
    road = StraightRoad.from_spec(RoadSpec(length_m=100.0, lanes=2))
    line = road.polyline[:4]
    points, out = np.zeros((3, 2)), np.empty(3)
    with pytest.raises(TypeError, match="xy"):
        compiled.frenet(np.zeros(3), *line, out, out, 3.5, 100.0, out)
    with pytest.raises(TypeError, match="d_out"):
        compiled.frenet(points, *line, out, np.empty(3, np.float32), 3.5, 100.0, out)
    with pytest.raises(ValueError, match="gaps_out"):
        compiled.frenet(points, *line, out, out, 3.5, 100.0, np.empty(2))
