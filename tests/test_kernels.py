"""The car's kernels: the numpy twins the package falls back on equal the compiled
code bit for bit (property tests), and the wrappers answer like them."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_geometry import box_st, ray_scene
from test_road import polyline_st

from analysis.measures.world_audit import OVERLAP_TOLERANCE_M, overlapping_pairs
from scenarios.scene.road_geometry import CurveRoad, RoadGeometry, StraightRoad
from scenarios.scene.road_kernels import place_numpy
from scenarios.spec.scenario_tables import RoadSpec
from sdc.car import geometry_kernels as kernels

try:
    from sdc.car import _geometry_kernels as compiled
except ImportError:  # built without a C compiler: only the numpy twins are there
    compiled = None

pytestmark = pytest.mark.filterwarnings("error")  # the twins raise no numpy warnings
needs_compiled = pytest.mark.skipif(compiled is None, reason="the C extension was not built")
PROPS = settings(max_examples=300, deadline=None)
segment_st = st.tuples(*[st.floats(-60.0, 60.0, allow_nan=False)] * 4)
segments_st = st.lists(segment_st, max_size=6).map(
    lambda rows: np.array(rows, float).reshape(-1, 4))


def both_scans(origin, yaw, angles, boxes, more_boxes, segments, max_range_m):
    """The ranges of the numpy twin and of the compiled scan, the same arguments to both."""
    args = (float(origin[0]), float(origin[1]), yaw,
            *(np.ascontiguousarray(a, float) for a in (angles, boxes, more_boxes, segments)),
            max_range_m)
    ranges = []
    for scan in (kernels.scan_numpy, compiled.scan):
        out = np.full(len(angles), -1.0)
        assert scan(*args, out) is None
        ranges.append(out)
    return ranges


def same_bits(found, expected) -> bool:
    """Equal to the last bit (-0.0 is not 0.0), and of the same types."""
    return (np.asarray(found).tobytes() == np.asarray(expected).tobytes()
            and [type(v) for v in found] == [type(v) for v in expected])


@needs_compiled
@PROPS
@given(scene=ray_scene(), segments=segments_st, max_range=st.sampled_from([5.0, 30.0, 80.0]),
       yaw=st.floats(-4.0, 4.0), split=st.integers(0, 5))
def test_the_numpy_scan_equals_the_compiled_one(scene, segments, max_range, yaw, split):
    """The compiled culling by bounding circle and by segment distance changes nothing:
    rays from inside a box, grazing ones, ones along a segment and cut-offs included;
    nor does handing the boxes over as two sets."""
    boxes, origin, angles = scene
    twin, fast = both_scans(origin, yaw, angles - yaw, boxes[:split], boxes[split:], segments,
                            max_range)
    assert twin.tobytes() == fast.tobytes()


@needs_compiled
def test_the_numpy_scan_on_a_dense_scan_with_road_edges():
    rng = np.random.default_rng(5)
    boxes = np.column_stack([rng.uniform(-70, 70, (60, 2)), rng.uniform(-3, 3, 60),
                             rng.uniform(0.5, 12, 60), rng.uniform(0.5, 3, 60)])
    edges = np.array([[-500.0, -9.0, 500.0, -9.0], [-500.0, 9.0, 500.0, 9.0],
                      [30.0, -20.0, 31.0, 20.0]])
    angles = np.linspace(np.pi, -np.pi, 720, endpoint=False)
    for origin in (np.zeros(2), boxes[0, :2], np.array([100.0, 0.0])):
        twin, fast = both_scans(origin, 0.3, angles, boxes[:7], boxes[7:], edges, 80.0)
        assert twin.tobytes() == fast.tobytes()
        assert np.isfinite(twin).any()


@needs_compiled
def test_the_numpy_scan_keeps_the_sign_of_zero_ranges():
    """From the outline of a box or a segment the range is 0.0 or -0.0 as the
    arithmetic falls, and of equal ranges the first box (or the boxes before the
    segments) wins: the numpy twin gives the compiled bits, signs included."""
    boxes = np.array([[-1.0, 0.0, 0.0, 2.0, 2.0], [0.0, 3.0, np.pi / 2, 2.0, 2.0]])
    segments = np.array([[-0.0, 0.0, 0.0, 1.0], [0.0, -1.0, 0.0, 1.0]])
    angles = np.array([np.pi, -np.pi, 0.0, np.pi / 2, -np.pi / 2, 1.0])
    for some_boxes, some_segments in ((boxes, np.zeros((0, 4))), (np.zeros((0, 5)), segments),
                                      (boxes, segments), (boxes[::-1], segments[::-1])):
        twin, fast = both_scans(np.zeros(2), 0.0, angles, some_boxes, np.zeros((0, 5)),
                                some_segments, 30.0)
        assert twin.tobytes() == fast.tobytes()
        assert (twin == 0).all() and np.signbit(twin).any() and not np.signbit(twin).all()


def test_the_lidar_ranges_are_the_nearest_box_or_segment():
    boxes = np.array([[10.0, 0.0, 0.0, 2.0, 2.0], [0.0, 20.0, 0.0, 2.0, 2.0]])
    wall = np.array([[-5.0, -30.0, -5.0, 30.0]])
    angles = np.array([0.0, np.pi / 2, np.pi, -np.pi / 2])
    ranges = kernels.lidar_ranges_m(np.zeros(2), 0.0, angles, boxes[:1], wall, 25.0, boxes[1:])
    np.testing.assert_allclose(ranges, [9.0, 19.0, 5.0, np.inf])
    assert kernels.KERNELS in ("compiled", "numpy")


def test_no_boxes_and_no_segments_see_nothing():
    ranges = kernels.lidar_ranges_m(np.zeros(2), 0.0, np.linspace(-1, 1, 5), np.zeros((0, 5)),
                                    np.zeros((0, 4)), 80.0)
    assert np.isinf(ranges).all() and ranges.shape == (5,)
    assert kernels.step(np.array([0.0, 0.0, 0.0, 4.0, 2.0]), 5.0, np.zeros((0, 5)),
                        np.zeros((0, 5)), np.zeros(0), STRAIGHT, 1.0) == (
        (-1, -1, np.inf), (np.inf, 0.0, np.inf))


#: a straight road along +x through the origin: its road frame is the world's
STRAIGHT = RoadGeometry(np.array([[-500.0, 0.0], [500.0, 0.0]]), 3, 3.5)


@needs_compiled
@PROPS
@given(ego=box_st, speed=st.floats(0.0, 40.0), obstacles=st.lists(box_st, max_size=4),
       traffic=st.lists(box_st, max_size=6),
       speeds=st.lists(st.floats(0.0, 40.0), min_size=6, max_size=6))
def test_the_numpy_step_equals_the_compiled_one_anywhere(ego, speed, obstacles, traffic,
                                                         speeds):
    """Boxes anywhere at any heading: first overlaps (boxes_overlap), obstacle gap
    (box_gap_m), time to collision (first_contact_s), DRAC and headway
    (leader_measures) of the numpy twin equal the compiled answers bit for bit."""
    obstacles, traffic = (np.array(b, float).reshape(-1, 5) for b in (obstacles, traffic))
    twin, fast = both_steps(np.array(ego), speed, obstacles, traffic,
                            np.array(speeds[: len(traffic)]), STRAIGHT, 1.0)
    assert same_bits(twin, fast)


@needs_compiled
@PROPS
@given(line=polyline_st, crowd=st.lists(box_st, min_size=2, max_size=7),
       speeds=st.lists(st.floats(0.0, 40.0), min_size=7, max_size=7),
       curvature=st.sampled_from([0.0, 1 / 150, -1 / 60]), lane_scale=st.floats(0.9, 1.1))
def test_the_numpy_step_equals_the_compiled_one_on_any_polyline(line, crowd, speeds, curvature,
                                                                lane_scale):
    """Any polyline road, bodies anywhere placed in its road frame (segment ends and
    the extended first and last segments included): the numpy twin and the compiled
    step agree bit for bit."""
    crowd = np.array(crowd, float)
    crowd[:, :2] = line[0] + (crowd[:, :2] - crowd[0, :2]) * 0.3  # near the road and the ego
    road = RoadGeometry(line, 2, 3.5, curvature)
    twin, fast = both_steps(crowd[0], speeds[0], crowd[1:2], crowd[2:],
                            np.array(speeds[2: len(crowd)]), road, lane_scale)
    assert same_bits(twin, fast)


@needs_compiled
def test_the_numpy_kernels_on_near_misses_overlaps_and_leaders():
    rng = np.random.default_rng(2)
    ego = np.array([0.0, 0.0, 0.3, 4.85, 1.93])
    others = np.column_stack([rng.uniform(-8, 8, (500, 2)), rng.uniform(-3, 3, 500),
                              rng.uniform(0.5, 6, 500), rng.uniform(0.5, 2.5, 500)])
    speeds = rng.uniform(0, 20, 500)
    met = {"overlap": 0, "gap": 0, "ttc": 0, "drac": 0, "headway": 0}
    for k in range(0, 500, 5):
        twin, fast = both_steps(ego, 6.0, others[k: k + 2], others[k + 2: k + 5],
                                speeds[k + 2: k + 5], STRAIGHT, 1.0)
        assert same_bits(twin, fast)
        met["overlap" if twin[2] == 0 else "gap"] += 1
        met["ttc"] += 0 < twin[3] < np.inf
        met["drac"] += twin[4] > 0
        met["headway"] += 0 < twin[5] < np.inf
    assert min(met.values()) > 10  # each kind was met


@needs_compiled
def test_a_wrong_array_is_refused_with_its_name():
    polyline = STRAIGHT.polyline
    with pytest.raises(TypeError, match="traffic"):
        compiled.step(np.zeros(5), 0.0, np.zeros((0, 5)), np.zeros(4, np.float32), np.zeros(0),
                      *polyline, 0.0, 1.0)
    with pytest.raises(TypeError, match="headings"):
        compiled.step(np.zeros(5), 0.0, np.zeros((0, 5)), np.zeros((0, 5)), np.zeros(0),
                      *polyline[:4], polyline[4].astype(np.float32), 0.0, 1.0)
    with pytest.raises(ValueError, match="a speed per traffic box"):
        compiled.step(np.zeros(5), 0.0, np.zeros((0, 5)), np.zeros((1, 5)), np.zeros(2),
                      *polyline, 0.0, 1.0)


def both_steps(ego, speed, obstacles, traffic, speeds, road, lane_scale):
    """A step's contacts and conflicts from the numpy twin and the compiled code, the
    same arguments to both."""
    args = [np.ascontiguousarray(a, float) for a in (ego, obstacles, traffic, speeds)]
    extra = (*road.polyline, road.curvature_1pm, lane_scale)
    return [s(args[0], float(speed), *args[1:], *extra)
            for s in (kernels.step_numpy, compiled.step)]


@needs_compiled
@pytest.mark.parametrize("radius_m", [None, 60.0, -150.0])
def test_the_numpy_step_equals_the_compiled_one(radius_m):
    """Crowds of boxes around the ego on a straight road and on curves, many of them
    touching or bumper to bumper (where the world frame's first contact stands in):
    the fused compiled step and its numpy composition agree bit for bit, and equal
    the contacts, placement and conflicts they are made of."""
    road = (StraightRoad.from_spec(RoadSpec(kind="straight", length_m=400.0, lanes=3))
            if radius_m is None else
            CurveRoad.from_spec(RoadSpec(kind="curve", curve_radius_m=radius_m, length_m=400.0,
                                         lanes=3)))
    rng = np.random.default_rng(7)
    met = {"touching": 0, "world": 0, "finite": 0, "leader": 0}
    for _ in range(300):
        s_m = rng.uniform(20, 380, 7)
        d_m = rng.choice([-3.5, 0.0, 3.5], 7) + rng.normal(0, 0.3, 7)
        s_m[1:4] = s_m[0] + rng.choice([-1, 1], 3) * rng.uniform(4.5, 5.0, 3)  # bumper to bumper
        d_m[1:4] = d_m[0]
        xy = road.xy_at(s_m, d_m)
        boxes = np.column_stack([xy, road.heading_at(s_m) + rng.normal(0, 0.05, 7),
                                 np.full(7, 4.6), np.full(7, 1.9)])
        speeds = rng.uniform(0, 25, 7)
        lane_scale = 1 - road.curvature_1pm * d_m[0]
        twin, fast = both_steps(boxes[0], float(speeds[0]), boxes[1:3], boxes[3:], speeds[3:],
                                road, lane_scale)
        assert same_bits(twin, fast)
        assert twin[:3] == kernels.contacts_numpy(boxes[0], boxes[1:3], boxes[3:])
        placed, velocity = np.empty((7, 5)), np.empty((7, 2))
        place_numpy(boxes[0], float(speeds[0]), boxes[1:3], boxes[3:], speeds[3:],
                    *road.polyline, road.curvature_1pm, lane_scale, placed, velocity)
        along = kernels.conflicts_numpy(placed[0], velocity[0], placed[1:], velocity[1:])
        touching = twin[0] >= 0 or twin[1] >= 0
        met["touching"] += touching
        met["world"] += not touching and along[0] == 0.0
        met["finite"] += 0 < twin[3] < np.inf
        met["leader"] += twin[4] > 0
        assert (twin[3] == 0.0) == touching
        assert twin[4:] == along[1:]
        if not touching and along[0] > 0.0:
            assert twin[3] == along[0]
    assert min(met["touching"], met["finite"], met["leader"]) > 10
    if radius_m is not None:
        assert met["world"] > 0  # the fallback was exercised


@st.composite
def crowd_st(draw):
    """Traffic boxes crowded together (some touching, some through each other), then a
    few obstacles; some of them persons, two traffic boxes maybe pieces of one body."""
    boxes = np.array(draw(st.lists(box_st, min_size=1, max_size=9)), float)
    boxes[:, :2] = boxes[0, :2] + (boxes[:, :2] - boxes[0, :2]) * draw(st.sampled_from(
        [0.05, 0.2, 1.0]))
    n_traffic = draw(st.integers(0, len(boxes)))
    kinds = draw(st.lists(st.sampled_from(["passenger", "pedestrian"]), min_size=len(boxes),
                          max_size=len(boxes)))
    bodies = list(range(n_traffic))
    if n_traffic >= 2 and draw(st.booleans()):
        bodies[1] = 0  # two pieces of one body
    return boxes, n_traffic, kinds, bodies


def gate(boxes, n_traffic, kinds, bodies, people_known=True) -> bool:
    """The compiled gate, asked as the in-run audit asks it (people not known: its first
    question)."""
    people = np.array([kind == "pedestrian" for kind in kinds], float)
    return compiled.bodies_may_overlap(
        np.ascontiguousarray(boxes[:n_traffic], float), np.ascontiguousarray(boxes[n_traffic:],
                                                                             float),
        people if people_known else None, np.array(bodies, float), OVERLAP_TOLERANCE_M)


def audit_pairs(boxes, n_traffic, kinds, bodies) -> list:
    """The audit's own question: the overlapping pairs (analysis/measures/world_audit.py)."""
    return overlapping_pairs(boxes[:n_traffic], boxes[n_traffic:], kinds[:n_traffic],
                             tuple(kinds[n_traffic:]), np.array(bodies, np.intp))


@needs_compiled
@PROPS
@given(crowd=crowd_st())
def test_the_compiled_overlap_gate_never_hides_a_pair(crowd):
    """The in-run audit's gate (sdc/run/world_witness.py) lets every step through where
    the audit's own question finds a pair: it errs only to letting one through."""
    if audit_pairs(*crowd):
        assert gate(*crowd) is True and gate(*crowd, people_known=False) is True


@needs_compiled
def test_the_compiled_overlap_gate_shuts_where_no_pair_is():
    car = [0.0, 0.0, 0.0, 4.5, 1.8]
    through = [2.0, 0.5, 0.3, 4.5, 1.8]
    touching = [4.5 + 0.005, 0.0, 0.0, 4.5, 1.8]  # within the audit's tolerance
    apart = [30.0, 0.0, 0.0, 4.5, 1.8]
    two = ["passenger", "passenger"]
    crowd = ["pedestrian"] * 2
    # each case: whether the gate opens, and whether it opens not knowing the people
    for boxes, n, kinds, bodies, open_, open_blind in (
            ([car, through], 2, two, [0, 1], True, True),
            ([car, through], 1, two, [0], True, True),  # traffic through an obstacle
            ([car, through], 0, two, [], False, False),  # two obstacles: the spec's doing
            ([car, through], 2, crowd, [0, 1], False, True),  # a crowd, told only by people
            ([car, through], 2, two, [0, 0], False, False),  # pieces of one body
            ([car, touching], 2, two, [0, 1], False, False),
            ([car, apart], 2, two, [0, 1], False, False)):
        boxes = np.array(boxes, float)
        assert gate(boxes, n, kinds, bodies) is open_, (boxes, n, kinds, bodies)
        assert gate(boxes, n, kinds, bodies, people_known=False) is open_blind
        assert bool(audit_pairs(boxes, n, kinds, bodies)) is open_
