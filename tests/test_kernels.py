"""The compiled kernels equal their numpy references bit for bit (property tests)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_geometry import box_st, ray_scene

from analysis import safety
from sdc.car import geometry_kernels as kernels
from sdc.car.geometry import box_gap_m, boxes_overlap, ray_box_ranges, ray_segment_ranges

PROPS = settings(max_examples=300, deadline=None)
segment_st = st.tuples(*[st.floats(-60.0, 60.0, allow_nan=False)] * 4)
segments_st = st.lists(segment_st, max_size=6).map(
    lambda rows: np.array(rows, float).reshape(-1, 4))


def reference_scan(origin, yaw, angles, boxes, segments, max_range_m):
    """The straightforward lidar: every ray against every box and segment."""
    world = yaw + angles
    return np.minimum(ray_box_ranges(origin, world, boxes, max_range_m),
                      ray_segment_ranges(origin, world, segments, max_range_m))


@PROPS
@given(scene=ray_scene(), segments=segments_st, max_range=st.sampled_from([5.0, 30.0, 80.0]),
       yaw=st.floats(-4.0, 4.0), split=st.integers(0, 5))
def test_the_lidar_kernel_returns_the_straightforward_ranges(scene, segments, max_range, yaw,
                                                              split):
    """Culling by bounding circle and by segment distance changes nothing: rays from
    inside a box, grazing ones, ones along a segment and cut-offs included; nor does
    handing the boxes over as two sets."""
    boxes, origin, angles = scene
    np.testing.assert_array_equal(
        kernels.lidar_ranges_m(origin, yaw, angles - yaw, boxes[:split], segments, max_range,
                               boxes[split:]),
        reference_scan(origin, yaw, angles - yaw, boxes, segments, max_range))


def test_the_lidar_kernel_on_a_dense_scan_with_road_edges():
    rng = np.random.default_rng(5)
    boxes = np.column_stack([rng.uniform(-70, 70, (60, 2)), rng.uniform(-3, 3, 60),
                             rng.uniform(0.5, 12, 60), rng.uniform(0.5, 3, 60)])
    edges = np.array([[-500.0, -9.0, 500.0, -9.0], [-500.0, 9.0, 500.0, 9.0],
                      [30.0, -20.0, 31.0, 20.0]])
    angles = np.linspace(np.pi, -np.pi, 720, endpoint=False)
    for origin in (np.zeros(2), boxes[0, :2], np.array([100.0, 0.0])):
        expected = reference_scan(origin, 0.3, angles, boxes, edges, 80.0)
        np.testing.assert_array_equal(
            kernels.lidar_ranges_m(origin, 0.3, angles, boxes[:7], edges, 80.0, boxes[7:]),
            expected)
        assert np.isfinite(expected).any()


def test_no_boxes_and_no_segments_see_nothing():
    ranges = kernels.lidar_ranges_m(np.zeros(2), 0.0, np.linspace(-1, 1, 5), np.zeros((0, 5)),
                                    np.zeros((0, 4)), 80.0)
    assert np.isinf(ranges).all() and ranges.shape == (5,)


def reference_contacts(ego, speed, obstacles, traffic, speeds) -> kernels.Contacts:
    """The ego's contacts from the numpy functions, one question at a time."""
    def first(mask):
        return int(np.flatnonzero(mask)[0]) if mask.any() else -1

    return kernels.Contacts(
        first(boxes_overlap(ego, obstacles)), first(boxes_overlap(ego, traffic)),
        float(np.min(box_gap_m(ego, obstacles), initial=np.inf)),
        safety.time_to_collision_s(ego, speed, np.vstack([obstacles, traffic]),
                                   np.concatenate([np.zeros(len(obstacles)), speeds])))


@PROPS
@given(ego=box_st, obstacles=st.lists(box_st, max_size=4), traffic=st.lists(box_st, max_size=6),
       speed=st.floats(0.0, 40.0),
       speeds=st.lists(st.floats(0.0, 40.0), min_size=6, max_size=6))
def test_the_contacts_kernel_equals_the_numpy_functions(ego, obstacles, traffic, speed, speeds):
    """First overlaps (boxes_overlap), obstacle gap (box_gap_m) and time to collision
    (analysis.safety) equal the numpy answers bit for bit."""
    ego = np.array(ego)
    obstacles, traffic = (np.array(b, float).reshape(-1, 5) for b in (obstacles, traffic))
    speeds = np.array(speeds[: len(traffic)])
    found = kernels.contacts(ego, speed, obstacles, traffic, speeds)
    expected = reference_contacts(ego, speed, obstacles, traffic, speeds)
    assert found == expected
    assert np.array(found).tobytes() == np.array(expected).tobytes()  # -0.0 is not 0.0


def test_the_contacts_kernel_on_near_misses_and_overlaps():
    rng = np.random.default_rng(2)
    ego = np.array([0.0, 0.0, 0.3, 4.85, 1.93])
    others = np.column_stack([rng.uniform(-8, 8, (500, 2)), rng.uniform(-3, 3, 500),
                              rng.uniform(0.5, 6, 500), rng.uniform(0.5, 2.5, 500)])
    speeds = rng.uniform(0, 20, 500)
    met = {"overlap": 0, "gap": 0}
    for k in range(0, 500, 5):
        obstacles, traffic = others[k: k + 2], others[k + 2: k + 5]
        found = kernels.contacts(ego, 6.0, obstacles, traffic, speeds[k + 2: k + 5])
        assert found == reference_contacts(ego, 6.0, obstacles, traffic, speeds[k + 2: k + 5])
        met["overlap" if found.obstacle_gap_m == 0 else "gap"] += 1
    assert min(met.values()) > 10  # both kinds were met


def test_a_wrong_array_is_refused_with_its_name():
    with pytest.raises(TypeError, match="traffic"):
        kernels._kernels.contacts(np.zeros(5), 0.0, np.zeros((0, 5)), np.zeros(4, np.float32),
                                  np.zeros(0))
