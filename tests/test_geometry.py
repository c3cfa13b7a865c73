"""Tests for sdc.car.geometry: analytic cases plus hypothesis properties against brute force."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st

from analysis.measures.world_audit import overlap_depth_m
from sdc.car.geometry import (
    box_corners,
    box_edges,
    box_gap_m,
    boxes_overlap,
    first_contact_s,
    leader_measures,
    one_box_corners,
    point_segment_distance,
    ray_box_ranges,
    ray_segment_ranges,
)

pytestmark = pytest.mark.filterwarnings("error")  # numpy RuntimeWarnings fail the tests

ORIGIN = np.zeros(2)
BEAMS_RAD = np.deg2rad(90 - np.arange(180))  # +90 deg .. -89 deg, 1 deg apart
SQRT2 = math.sqrt(2.0)

PROPS = settings(max_examples=200, deadline=None)
coord = st.floats(-50.0, 50.0, allow_nan=False)
yaw = st.floats(-10.0, 10.0, allow_nan=False)
box_st = st.tuples(coord, coord, yaw, st.floats(0.5, 15.0), st.floats(0.5, 3.0))
boxes_st = st.lists(box_st, min_size=1, max_size=5).map(lambda rows: np.array(rows, float))
angles_st = st.lists(st.floats(-4.0, 4.0, allow_nan=False), min_size=1, max_size=20).map(np.array)
origin_st = st.tuples(st.floats(-5.0, 5.0), st.floats(-5.0, 5.0)).map(np.array)


@st.composite
def ray_scene(draw):
    """Boxes, an origin and beam angles: random ones plus ones aimed near each box centre."""
    boxes, origin, angles = draw(boxes_st), draw(origin_st), draw(angles_st)
    jitter = np.array(
        draw(st.lists(st.floats(-0.3, 0.3), min_size=len(boxes), max_size=len(boxes)))
    )
    aimed = np.arctan2(boxes[:, 1] - origin[1], boxes[:, 0] - origin[0]) + jitter
    return boxes, origin, np.concatenate([angles, aimed])


def unit_dirs(angles_rad: np.ndarray) -> np.ndarray:
    return np.stack([np.cos(angles_rad), np.sin(angles_rad)], axis=-1)


def face_range(near_face_m: float, half_width_m: float, angles_rad: np.ndarray) -> np.ndarray:
    """Analytic range to a face x = near_face_m, |y| <= half_width_m, seen from the origin."""
    out = np.full(angles_rad.shape, np.inf)
    for i, a in enumerate(angles_rad):
        if math.cos(a) > 0 and abs(near_face_m * math.tan(a)) <= half_width_m:
            out[i] = near_face_m / math.cos(a)
    return out


# ---------------------------------------------------------------- box_corners
def test_box_corners_order_and_rotation():
    corners = box_corners(np.array([[1.0, 2.0, 0.0, 4.0, 2.0], [0.0, 0.0, np.pi / 2, 4.0, 2.0]]))
    assert corners.shape == (2, 4, 2)
    np.testing.assert_allclose(corners[0], [[3, 3], [-1, 3], [-1, 1], [3, 1]])
    # yaw 90 deg: front points to +y, left to -x
    np.testing.assert_allclose(corners[1], [[-1, 2], [-1, -2], [1, -2], [1, 2]], atol=1e-12)
    # counter-clockwise: positive shoelace area = length * width
    x, y = corners[..., 0], corners[..., 1]
    area = 0.5 * np.sum(x * np.roll(y, -1, axis=1) - np.roll(x, -1, axis=1) * y, axis=1)
    np.testing.assert_allclose(area, [8.0, 8.0])


# ---------------------------------------------------------------- ray_box_ranges
def test_axis_aligned_box_180_beams():
    ranges = ray_box_ranges(ORIGIN, BEAMS_RAD, np.array([[20.0, 0.0, 0.0, 4.5, 1.8]]), 200.0)
    assert ranges.shape == (180,)
    assert abs(ranges[90] - 17.75) < 1e-9  # beam i=90 is 0 deg
    expected = face_range(17.75, 0.9, BEAMS_RAD)
    assert np.isfinite(expected).sum() == 5  # -2..2 deg
    np.testing.assert_array_equal(np.isinf(ranges), np.isinf(expected))
    np.testing.assert_allclose(
        ranges[np.isfinite(ranges)], expected[np.isfinite(expected)], rtol=0, atol=1e-6
    )


def test_box_rotated_90_deg():
    box = np.array([[20.0, 0.0, np.pi / 2, 4.5, 1.8]])  # now 1.8 along x, 4.5 along y
    ranges = ray_box_ranges(ORIGIN, BEAMS_RAD, box, 200.0)
    assert abs(ranges[90] - 19.1) < 1e-9
    expected = face_range(19.1, 2.25, BEAMS_RAD)
    np.testing.assert_array_equal(np.isinf(ranges), np.isinf(expected))
    np.testing.assert_allclose(
        ranges[np.isfinite(ranges)], expected[np.isfinite(expected)], rtol=0, atol=1e-6
    )


def test_square_rotated_45_deg_corner_and_face():
    box = np.array([[10.0, 0.0, np.pi / 4, 2.0, 2.0]])  # corners at (10 +- sqrt2, 0), (10, +-sqrt2)
    angles = np.deg2rad([0.0, 5.0, -5.0])
    ranges = ray_box_ranges(ORIGIN, angles, box, 50.0)
    assert abs(ranges[0] - (10.0 - SQRT2)) < 1e-9
    # face through (10 - sqrt2, 0) and (10, sqrt2): y = x - (10 - sqrt2)
    a = np.deg2rad(5.0)
    face = (10.0 - SQRT2) / (math.cos(a) - math.sin(a))
    np.testing.assert_allclose(ranges[1:], [face, face], rtol=0, atol=1e-9)


def test_nearer_box_wins_regardless_of_order():
    near, far = [20.0, 0.0, 0.0, 4.5, 1.8], [40.0, 0.0, 0.3, 10.0, 3.0]
    for boxes in ([near, far], [far, near]):
        ranges = ray_box_ranges(ORIGIN, np.array([0.0, 0.02]), np.array(boxes), 200.0)
        np.testing.assert_allclose(ranges, [17.75, 17.75 / math.cos(0.02)], rtol=0, atol=1e-9)


def test_max_range_cut_off():
    box = np.array([[100.0, 0.0, 0.0, 4.5, 1.8]])  # near face at 97.75
    beam = np.array([0.0])
    assert np.isinf(ray_box_ranges(ORIGIN, beam, box, 80.0)[0])
    assert np.isinf(ray_box_ranges(ORIGIN, beam, box, 97.7)[0])
    assert ray_box_ranges(ORIGIN, beam, box, 97.75)[0] == 97.75  # exactly at the cut-off counts


def test_origin_inside_box_gives_zero():
    boxes = np.array([[1.0, 0.5, 0.4, 4.5, 1.8], [20.0, 0.0, 0.0, 4.5, 1.8]])
    ranges = ray_box_ranges(ORIGIN, BEAMS_RAD, boxes, 200.0)
    np.testing.assert_array_equal(ranges, np.zeros(180))


def test_closed_box_conventions():
    box = np.array([[20.0, 0.0, 0.0, 4.0, 2.0]])  # corners at x = 18, 22 and y = -1, 1
    # origin on the outline is inside: 0 even for a ray pointing away from the box
    assert ray_box_ranges([18.0, 0.0], [np.pi], box, 50.0)[0] == 0.0
    # a ray that only touches the corner (18, 1) and leaves again still hits it
    grazing = ray_box_ranges([13.0, -4.0], [np.pi / 4], box, 50.0)[0]
    assert grazing == pytest.approx(5.0 * SQRT2, abs=1e-9)


def test_no_boxes_and_no_segments_give_inf():
    assert np.all(np.isinf(ray_box_ranges(ORIGIN, BEAMS_RAD, np.empty((0, 5)), 100.0)))
    assert np.all(np.isinf(ray_segment_ranges(ORIGIN, BEAMS_RAD, np.empty((0, 4)), 100.0)))
    assert ray_box_ranges(ORIGIN, BEAMS_RAD, np.empty((0, 5)), 100.0).shape == (180,)


def test_exact_zero_direction_components_no_warnings():
    boxes = np.array(
        [
            [20.0, 0.0, 0.0, 4.5, 1.8],  # beam 0 deg: local sin is exactly 0
            [0.0, 10.0, np.pi / 2, 4.0, 2.0],  # beam 90 deg: local angle exactly 0
            [-30.0, 0.0, np.pi, 4.0, 2.0],  # beam 180 deg: local angle exactly 0
        ]
    )
    angles = np.array([0.0, np.pi / 2, np.pi, -np.pi / 2])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ranges = ray_box_ranges(ORIGIN, angles, boxes, 100.0)
        grazing = ray_box_ranges([0.0, 0.9], [0.0], boxes[:1], 100.0)
    assert not np.any(np.isnan(ranges))
    np.testing.assert_allclose(ranges[:3], [17.75, 8.0, 28.0], rtol=0, atol=1e-9)
    assert np.isinf(ranges[3])
    assert grazing[0] == 17.75  # a ray running exactly along an edge hits (closed boxes)


# ---------------------------------------------------------------- ray_segment_ranges
def test_wall_segment():
    ranges = ray_segment_ranges(ORIGIN, BEAMS_RAD, np.array([[10.0, -5.0, 10.0, 5.0]]), 100.0)
    expected = face_range(10.0, 5.0, BEAMS_RAD)
    assert np.isfinite(expected).sum() == 53  # -26..26 deg
    np.testing.assert_array_equal(np.isinf(ranges), np.isinf(expected))
    np.testing.assert_allclose(
        ranges[np.isfinite(ranges)], expected[np.isfinite(expected)], rtol=0, atol=1e-9
    )


def test_segment_parallel_behind_and_cut_off():
    segs = np.array(
        [
            [5.0, 0.0, 15.0, 0.0],  # collinear with the 0-deg ray: parallel, no hit
            [-10.0, -1.0, -10.0, 1.0],  # behind the origin
        ]
    )
    assert np.all(np.isinf(ray_segment_ranges(ORIGIN, [0.0], segs, 100.0)))
    wall = np.array([[10.0, -5.0, 10.0, 5.0], [20.0, -5.0, 20.0, 5.0]])
    assert ray_segment_ranges(ORIGIN, [0.0], wall[::-1], 100.0)[0] == pytest.approx(10.0)
    assert np.isinf(ray_segment_ranges(ORIGIN, [0.0], wall, 9.99)[0])


# ---------------------------------------------------------------- overlap and gap, known cases
UNIT = np.array([0.0, 0.0, 0.0, 1.0, 1.0])


@pytest.mark.parametrize(
    ("other", "overlap", "gap"),
    [
        ([3.0, 0.0, 0.0, 1.0, 1.0], False, 2.0),
        ([0.0, -3.0, 0.0, 1.0, 1.0], False, 2.0),
        ([0.3, 0.2, 0.0, 1.0, 1.0], True, 0.0),
        ([1.0, 0.0, 0.0, 1.0, 1.0], True, 0.0),  # touching faces: overlap by convention
        ([3.0, 0.0, np.pi / 4, 1.0, 1.0], False, 2.5 - SQRT2 / 2),
        ([1.2, 0.0, np.pi / 4, 1.0, 1.0], True, 0.0),
        ([1.3, 0.0, np.pi / 4, 1.0, 1.0], False, 0.8 - SQRT2 / 2),
        # bounding boxes overlap but a diagonal axis separates them
        ([1.1, 1.1, np.pi / 4, 1.0, 1.0], False, 1.1 * SQRT2 - 0.5 - SQRT2 / 2),
        ([0.0, 0.0, 0.3, 0.2, 0.2], True, 0.0),  # fully inside
    ],
)
def test_overlap_and_gap_known_cases(other, overlap, gap):
    other = np.array([other])
    assert boxes_overlap(UNIT, other)[0] == overlap
    assert box_gap_m(UNIT, other)[0] == pytest.approx(gap, abs=1e-12)
    assert box_gap_m(other[0], UNIT[None])[0] == pytest.approx(gap, abs=1e-12)


def test_two_45_deg_squares_corner_to_corner_and_vectorised():
    a = np.array([0.0, 0.0, np.pi / 4, 1.0, 1.0])
    others = np.array(
        [
            [3.0, 0.0, np.pi / 4, 1.0, 1.0],
            [1.0, 0.0, np.pi / 4, 1.0, 1.0],
            [0.0, 5.0, 0.0, 1.0, 1.0],
        ]
    )
    np.testing.assert_allclose(
        box_gap_m(a, others), [3.0 - SQRT2, 0.0, 4.5 - SQRT2 / 2], rtol=0, atol=1e-12
    )
    np.testing.assert_array_equal(boxes_overlap(a, others), [False, True, False])
    assert box_gap_m(a, np.empty((0, 5))).shape == (0,)
    assert boxes_overlap(a, np.empty((0, 5))).shape == (0,)


def test_point_segment_distance():
    points = np.array([[0.0, 1.0], [-3.0, 0.0], [5.0, 4.0]])
    segs = np.array([[-1.0, 0.0, 1.0, 0.0], [2.0, 2.0, 2.0, 2.0]])  # second is a point
    d = point_segment_distance(points, segs)
    assert d.shape == (3, 2)
    np.testing.assert_allclose(
        d, [[1.0, math.hypot(2, 1)], [2.0, math.hypot(5, 2)], [math.hypot(4, 4), math.hypot(3, 2)]]
    )


# ---------------------------------------------------------------- brute-force references
def inside_convex(point: np.ndarray, corners: np.ndarray) -> bool:
    """Point in a CCW convex polygon, outline included."""
    edges = np.roll(corners, -1, axis=0) - corners
    rel = point - corners
    return bool(np.all(edges[:, 0] * rel[:, 1] - edges[:, 1] * rel[:, 0] >= 0.0))


def _orient(p, q, r) -> float:
    return (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])


def _on_segment(p, q, r) -> bool:  # r collinear with p-q: is it within the bounding box?
    return min(p[0], q[0]) <= r[0] <= max(p[0], q[0]) and min(p[1], q[1]) <= r[1] <= max(p[1], q[1])


def segments_intersect(p1, p2, p3, p4) -> bool:
    d1, d2 = _orient(p3, p4, p1), _orient(p3, p4, p2)
    d3, d4 = _orient(p1, p2, p3), _orient(p1, p2, p4)
    if ((d1 > 0 > d2) or (d1 < 0 < d2)) and ((d3 > 0 > d4) or (d3 < 0 < d4)):
        return True
    return (
        (d1 == 0 and _on_segment(p3, p4, p1))
        or (d2 == 0 and _on_segment(p3, p4, p2))
        or (d3 == 0 and _on_segment(p1, p2, p3))
        or (d4 == 0 and _on_segment(p1, p2, p4))
    )


def brute_overlap(a: np.ndarray, b: np.ndarray) -> bool:
    ca, cb = box_corners(a[None])[0], box_corners(b[None])[0]
    if any(inside_convex(p, cb) for p in ca) or any(inside_convex(p, ca) for p in cb):
        return True
    return any(
        segments_intersect(ca[i], ca[(i + 1) % 4], cb[j], cb[(j + 1) % 4])
        for i in range(4)
        for j in range(4)
    )


def resized(box: np.ndarray, delta_m: float) -> np.ndarray:
    out = box.copy()
    out[3:5] += 2.0 * delta_m
    return out


# ---------------------------------------------------------------- properties
@PROPS
@given(scene=ray_scene())
def test_ray_box_matches_edges_brute_force(scene):
    boxes, origin, angles = scene
    outline = box_edges(boxes).reshape(-1, 4)
    assume(point_segment_distance(origin[None], outline).min() > 1e-9)  # not on an outline
    ranges = ray_box_ranges(origin, angles, boxes, 80.0)
    assert ranges.shape == angles.shape and not np.any(np.isnan(ranges))
    corners = box_corners(boxes)
    if any(inside_convex(origin, c) for c in corners):
        np.testing.assert_array_equal(ranges, 0.0)
        return
    dirs = unit_dirs(angles)
    # (a) every finite range ends on a box outline
    finite = np.isfinite(ranges)
    hits = origin + ranges[finite, None] * dirs[finite]
    if finite.any():
        assert point_segment_distance(hits, outline).min(axis=1).max() < 1e-6
    # (b) equals the nearest of the 4N edge segments; rays through a corner are ambiguous
    rel = corners.reshape(-1, 2) - origin
    perp = np.abs(dirs[:, None, 0] * rel[None, :, 1] - dirs[:, None, 1] * rel[None, :, 0])
    ahead = dirs @ rel.T > -1e-9
    clear = ~np.any((perp < 1e-9) & ahead, axis=1)
    reference = ray_segment_ranges(origin, angles, outline, 80.0)
    np.testing.assert_array_equal(np.isinf(ranges[clear]), np.isinf(reference[clear]))
    both = clear & np.isfinite(reference)
    np.testing.assert_allclose(ranges[both], reference[both], rtol=0, atol=1e-6)


@PROPS
@given(
    a=box_st, b=box_st, offset=st.tuples(st.floats(-12, 12), st.floats(-12, 12)), near=st.booleans()
)
def test_overlap_and_gap_properties(a, b, offset, near):
    a, b = np.array(a), np.array(b)
    if near:  # put b close to a so that overlaps are frequent
        b[:2] = a[:2] + np.array(offset)
    overlap = boxes_overlap(a, b[None])[0]
    assert boxes_overlap(b, a[None])[0] == overlap
    # (c) brute force; exactly touching boxes are ambiguous (rounding may decide either way),
    # so compare with the boxes shrunk and grown by 1 nm
    surely_overlap = brute_overlap(resized(a, -1e-9), resized(b, -1e-9))
    surely_apart = not brute_overlap(resized(a, 1e-9), resized(b, 1e-9))
    if surely_overlap:
        assert overlap
    if surely_apart:
        assert not overlap
    # (d) gap: symmetric, zero iff overlap (touching: zero up to rounding), bounded by corner
    # distances from above and by the separating-axis projections from below
    gap = box_gap_m(a, b[None])[0]
    assert gap == pytest.approx(box_gap_m(b, a[None])[0], abs=1e-9)
    if overlap:
        assert gap == 0.0
    elif surely_apart:
        assert gap > 0.0
    else:
        assert gap < 1e-8
    ca, cb = box_corners(a[None])[0], box_corners(b[None])[0]
    assert gap <= np.min(np.linalg.norm(ca[:, None] - cb[None], axis=-1)) + 1e-9
    axes = np.array(
        [[math.cos(t), math.sin(t)] for t in (a[2], a[2] + np.pi / 2, b[2], b[2] + np.pi / 2)]
    )
    pa, pb = ca @ axes.T, cb @ axes.T  # (4 corners, 4 axes)
    axis_gap = np.maximum(pb.min(0) - pa.max(0), pa.min(0) - pb.max(0)).max()
    assert gap >= axis_gap - 1e-9


@PROPS
@given(a=box_st, others=boxes_st)
def test_overlap_and_gap_vectorised_match_single(a, others):
    a = np.array(a)
    overlap, gap = boxes_overlap(a, others), box_gap_m(a, others)
    assert overlap.shape == gap.shape == (len(others),)
    for i, b in enumerate(others):
        assert boxes_overlap(a, b[None])[0] == overlap[i]
        assert box_gap_m(a, b[None])[0] == gap[i]


@PROPS
@given(a=box_st, b=box_st)
def test_axis_aligned_gap_closed_form(a, b):
    a, b = np.array(a), np.array(b)
    a[2] = b[2] = 0.0
    sep_x = abs(a[0] - b[0]) - 0.5 * (a[3] + b[3])
    sep_y = abs(a[1] - b[1]) - 0.5 * (a[4] + b[4])
    gap = math.hypot(max(0.0, sep_x), max(0.0, sep_y))
    assert box_gap_m(a, b[None])[0] == pytest.approx(gap, abs=1e-9)
    if max(sep_x, sep_y) > 1e-9 or max(sep_x, sep_y) < -1e-9:  # skip exactly touching
        assert boxes_overlap(a, b[None])[0] == (max(sep_x, sep_y) < 0.0)


@PROPS
@given(box=box_st)
def test_one_box_corners_equal_box_corners_bit_for_bit(box):
    box = np.array(box)
    np.testing.assert_array_equal(one_box_corners(box), box_corners(box[None])[0])


# ---------------------------------------------------------------- time_to_collision_s
EGO = np.array([0.0, 0.0, 0.0, 4.0, 2.0])  # centre at the origin, heading +x


def box(cx, cy, yaw=0.0, length=4.0, width=2.0):
    return np.array([[cx, cy, yaw, length, width]])


def ahead_at(speeds_mps) -> np.ndarray:
    """Velocities of boxes moving along +x."""
    return np.column_stack([np.atleast_1d(speeds_mps), np.zeros(np.size(speeds_mps))])


def ttc(boxes, speed_mps=8.0, velocities=None) -> float:
    velocities = ahead_at(np.zeros(len(boxes))) if velocities is None else velocities
    return float(np.min(first_contact_s(EGO, np.array([speed_mps, 0.0]), boxes, velocities),
                        initial=np.inf))


def test_ttc_is_gap_over_closing_speed_for_an_object_ahead():
    # front at x = 2, the stopped car's rear at 20 - 2 = 18: 16 m at 8 m/s
    assert ttc(box(20.0, 0.0)) == pytest.approx(2.0)
    # a car ahead at 6 m/s: closing at 2 m/s
    assert ttc(box(20.0, 0.5), velocities=ahead_at(6.0)) == pytest.approx(8.0)


def test_ttc_ignores_what_is_beside_behind_or_faster():
    assert ttc(box(20.0, 2.1)) == math.inf  # beside: 0.1 m of clearance all the way
    assert ttc(box(-20.0, 0.0)) == math.inf  # behind, standing still
    assert ttc(box(20.0, 0.0), velocities=ahead_at(9.0)) == math.inf  # pulls away
    assert ttc(np.zeros((0, 5))) == math.inf


def test_ttc_sees_a_faster_car_from_behind_and_a_crossing_one():
    # 12 m behind (rear at -2, its front at -10), 10 m/s against 8: 8 m at 2 m/s
    assert ttc(box(-12.0, 0.0), velocities=ahead_at(10.0)) == pytest.approx(4.0)
    # crossing from the right at 5 m/s: its front (y = -10) enters the path's band
    # (y >= -1) after 1.8 s, but the ego's front (x = 2) reaches its near side (x = 19)
    # only after 17 / 8 s, when the crossing car spans y = -3.4 .. 0.6, across the path
    crossing = box(20.0, -12.0, yaw=math.pi / 2, length=4.0, width=2.0)
    assert ttc(crossing, velocities=np.array([[0.0, 5.0]])) == pytest.approx(17 / 8)


def test_ttc_uses_the_nearest_threat_and_zero_only_on_contact():
    boxes = np.vstack([box(40.0, 0.0), box(12.0, -1.2, yaw=math.pi / 2, length=0.6, width=0.6)])
    # the barrel overlaps the corridor (1.2 < 1 + 0.3); its near side at 11.7, the front at 2
    assert ttc(boxes, 5.0) == pytest.approx(9.7 / 5)
    assert ttc(box(3.5, 0.0), 5.0) == 0.0
    assert ttc(box(4.0, 0.0), 0.0) == 0.0  # touching counts, standing still


def test_a_box_rotated_beside_the_path_is_not_touching():
    """The old in-path test took a rotated box's axis-aligned extent in the ego's
    frame: a truck turned 15 degrees, 1.24 m clear of the ego's side, reached 2.76 m
    to its side of centre, into the path, and overlapped the ego's front: TTC 0."""
    truck = np.array([6.0, 5.0, math.radians(15), 12.0, 2.5])
    assert box_gap_m(EGO, truck[None])[0] == pytest.approx(1.24, abs=0.005)
    assert first_contact_s(EGO, np.array([8.0, 0.0]), truck[None], ahead_at(8.0))[0] == math.inf
    assert first_contact_s(EGO, np.array([8.0, 0.0]), truck[None], ahead_at(0.0))[0] == math.inf


#: a sampled overlap no deeper than this is rounding, not contact [m]: two boxes exactly
#: touching while one slides along the other with a yaw of 1e-19 rad overlap to
#: boxes_overlap (touching counts, the 1e-19 m rounded away) while the exact first
#: contact sees the rotated side move away from the other at 1e-19 m/s (never)
ROUNDING_DEPTH_M = 1e-9


def brute_first_contact_s(a, va, b, vb, horizon_s, dt_s) -> float:
    """The first of the times 0, dt, 2 dt, ... up to horizon at which the boxes overlap
    deeper than rounding (:data:`ROUNDING_DEPTH_M`). Only ``b`` moves, by the relative
    velocity: contact depends on nothing else, and moving both boxes by the same amount
    can round two boxes 1e-15 m apart into touching (boxes at equal velocities that
    never meet)."""
    times = np.arange(0.0, horizon_s, dt_s)
    moved_b = np.repeat(b[None], times.size, axis=0)  # b at every step, each on its own
    moved_b[:, :2] += times[:, None] * (vb - va)
    overlap = overlap_depth_m(np.repeat(a[None], times.size, axis=0), moved_b) > ROUNDING_DEPTH_M
    return float(times[overlap.argmax()]) if overlap.any() else math.inf


velocity_st = st.tuples(st.floats(-20, 20), st.floats(-20, 20)).map(np.array)


@settings(max_examples=300, deadline=None)
@given(a=box_st, b=box_st, va=velocity_st, vb=velocity_st,
       offset=st.tuples(st.floats(-30, 30), st.floats(-30, 30)))
@example(a=(0.0, 0.0, 0.0, 1.0, 1.0), b=(0.0, 0.0, 9.657658699336352e-20, 1.0, 1.0),
         va=np.array([0.0, 0.0]), vb=np.array([0.0, 1.0]), offset=(1.0, -2.0))  # sliding
def test_first_contact_against_a_brute_force_sweep_of_small_time_steps(a, b, va, vb, offset):
    """Oriented boxes of any angle at constant velocities: the exact first contact is
    never after the first small time step at which they overlap, they do not overlap
    at any step before it, and they touch at it (their gap is nil there)."""
    a, b = np.array(a), np.array(b)
    b[:2] = a[:2] + np.array(offset)  # near enough to meet often
    dt_s, horizon_s = 0.002, 4.0
    t = first_contact_s(a, va, b[None], vb[None])[0]
    brute = brute_first_contact_s(a, va, b, vb, horizon_s, dt_s)
    if brute < math.inf:
        assert t <= brute + 1e-9
    assert (t == 0.0) == bool(boxes_overlap(a, b[None])[0])  # 0 exactly on contact
    if t < horizon_s:
        before = np.arange(0.0, t - 1e-6, dt_s)
        for when in before[-3:]:  # the last steps before it are clear
            moved_a, moved_b = a.copy(), b.copy()
            moved_a[:2] += when * va
            moved_b[:2] += when * vb
            assert not boxes_overlap(moved_a, moved_b[None])[0]
        moved_a, moved_b = a.copy(), b.copy()
        moved_a[:2] += t * va
        moved_b[:2] += t * vb
        assert box_gap_m(moved_a, moved_b[None])[0] < 1e-6  # they touch at t


@settings(max_examples=300, deadline=None)
@given(a=box_st, others=st.lists(box_st, min_size=1, max_size=6),
       speed=st.floats(0.0, 30.0))
def test_no_zero_ttc_without_overlap_over_random_rotated_boxes(a, others, speed):
    a, others = np.array(a), np.array(others, float)
    others[:, :2] = a[:2] + (others[:, :2] - a[:2]) * 0.2  # crowd them around the box
    velocities = np.column_stack([np.cos(others[:, 2]), np.sin(others[:, 2])]) * 5.0
    times = first_contact_s(a, speed * np.array([math.cos(a[2]), math.sin(a[2])]), others,
                            velocities)
    np.testing.assert_array_equal(times == 0.0, boxes_overlap(a, others))


def test_leader_measures_follow_ssm_definitions():
    """Of a leader in the path ahead: TTC = gap / closing, DRAC = closing^2 / (2 gap),
    headway = gap / speed."""
    ego_v = np.array([10.0, 0.0])
    leader = box(24.0, 0.3)  # gap 24 - 2 - 2 = 20 m
    ttc_s, drac, headway = leader_measures(EGO, ego_v, leader, ahead_at(6.0))
    assert ttc_s == pytest.approx(5.0) and drac == pytest.approx(4.0**2 / 40)
    assert headway == pytest.approx(2.0)
    assert leader_measures(EGO, ego_v, leader, ahead_at(12.0)) == (math.inf, 0.0,
                                                                   pytest.approx(2.0))
    beside = box(24.0, 2.1)
    assert leader_measures(EGO, ego_v, beside, ahead_at(0.0)) == (math.inf, 0.0, math.inf)
    behind = box(-24.0, 0.0)
    assert leader_measures(EGO, ego_v, behind, ahead_at(20.0)) == (math.inf, 0.0, math.inf)
    # the nearer leader sets the headway, the faster-closed-on one the DRAC and TTC
    both = np.vstack([box(14.0, 0.0), box(44.0, 0.0)])  # gaps 10 and 40 m
    ttc_s, drac, headway = leader_measures(EGO, ego_v, both, ahead_at([10.0, 0.0]))
    assert ttc_s == pytest.approx(4.0) and drac == pytest.approx(100 / 80)
    assert headway == pytest.approx(1.0)
    stopped = leader_measures(EGO, np.zeros(2), box(14.0, 0.0), ahead_at(0.0))
    assert stopped == (math.inf, 0.0, math.inf)
    # no gap left: headway 0, and contact is first_contact_s's to say
    assert leader_measures(EGO, ego_v, box(3.9, 0.0), ahead_at(0.0)) == (math.inf, 0.0, 0.0)
