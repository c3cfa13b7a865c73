"""The compiled kernels equal their numpy references bit for bit (property tests)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_geometry import box_st, ray_scene

from analysis import safety
from sdc import kernels
from sdc.geometry import box_gap_m, boxes_overlap, ray_box_ranges, ray_segment_ranges

PROPS = settings(max_examples=300, deadline=None)
segment_st = st.tuples(*[st.floats(-60.0, 60.0, allow_nan=False)] * 4)
segments_st = st.lists(segment_st, max_size=6).map(
    lambda rows: np.array(rows, float).reshape(-1, 4))


def reference_scan(origin, angles, boxes, segments, max_range_m):
    """The straightforward lidar: every ray against every box and segment."""
    return np.minimum(ray_box_ranges(origin, angles, boxes, max_range_m),
                      ray_segment_ranges(origin, angles, segments, max_range_m))


@PROPS
@given(scene=ray_scene(), segments=segments_st, max_range=st.sampled_from([5.0, 30.0, 80.0]))
def test_the_lidar_kernel_returns_the_straightforward_ranges(scene, segments, max_range):
    """Culling by bounding circle and by segment distance changes nothing: rays from
    inside a box, grazing ones, ones along a segment and cut-offs included."""
    boxes, origin, angles = scene
    np.testing.assert_array_equal(
        kernels.lidar_ranges_m(origin, angles, boxes, segments, max_range),
        reference_scan(origin, angles, boxes, segments, max_range))


def test_the_lidar_kernel_on_a_dense_scan_with_road_edges():
    rng = np.random.default_rng(5)
    boxes = np.column_stack([rng.uniform(-70, 70, (60, 2)), rng.uniform(-3, 3, 60),
                             rng.uniform(0.5, 12, 60), rng.uniform(0.5, 3, 60)])
    edges = np.array([[-500.0, -9.0, 500.0, -9.0], [-500.0, 9.0, 500.0, 9.0],
                      [30.0, -20.0, 31.0, 20.0]])
    angles = np.linspace(np.pi, -np.pi, 720, endpoint=False)
    for origin in (np.zeros(2), boxes[0, :2], np.array([100.0, 0.0])):
        expected = reference_scan(origin, angles, boxes, edges, 80.0)
        np.testing.assert_array_equal(kernels.lidar_ranges_m(origin, angles, boxes, edges, 80.0),
                                      expected)
        assert np.isfinite(expected).any()


def test_no_boxes_and_no_segments_see_nothing():
    ranges = kernels.lidar_ranges_m(np.zeros(2), np.linspace(-1, 1, 5), np.zeros((0, 5)),
                                    np.zeros((0, 4)), 80.0)
    assert np.isinf(ranges).all() and ranges.shape == (5,)


@PROPS
@given(a=box_st, others=st.lists(box_st, max_size=6))
def test_first_overlap_is_the_first_overlapping_box(a, others):
    a, others = np.array(a), np.array(others, float).reshape(-1, 5)
    overlaps = np.flatnonzero(boxes_overlap(a, others))
    assert kernels.first_overlap(a, others) == (overlaps[0] if len(overlaps) else -1)


@PROPS
@given(a=box_st, others=st.lists(box_st, max_size=6))
def test_the_gap_kernel_equals_box_gap_m(a, others):
    a, others = np.array(a), np.array(others, float).reshape(-1, 5)
    np.testing.assert_array_equal(kernels.box_gap_m(a, others), box_gap_m(a, others))


def test_the_gap_kernel_on_near_misses_and_overlaps():
    rng = np.random.default_rng(2)
    ego = np.array([0.0, 0.0, 0.3, 4.85, 1.93])
    others = np.column_stack([rng.uniform(-8, 8, (500, 2)), rng.uniform(-3, 3, 500),
                              rng.uniform(0.5, 6, 500), rng.uniform(0.5, 2.5, 500)])
    gaps = kernels.box_gap_m(ego, others)
    np.testing.assert_array_equal(gaps, box_gap_m(ego, others))
    assert (gaps == 0).sum() > 50 and (gaps > 0).sum() > 50  # both kinds were met


@PROPS
@given(ego=box_st, others=st.lists(box_st, max_size=6), speed=st.floats(0.0, 40.0),
       speeds=st.lists(st.floats(0.0, 40.0), min_size=6, max_size=6))
def test_time_to_collision_kernel_equals_the_reference(ego, others, speed, speeds):
    ego, others = np.array(ego), np.array(others, float).reshape(-1, 5)
    speeds = np.array(speeds[: len(others)])
    assert (kernels.time_to_collision_s(ego, speed, others, speeds)
            == safety.time_to_collision_s(ego, speed, others, speeds))


def test_a_wrong_array_is_refused_with_its_name():
    with pytest.raises(TypeError, match="boxes"):
        kernels._kernels.first_overlap(np.zeros(5), np.zeros(4, np.float32))
