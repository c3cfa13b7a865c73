"""The read of SUMO's traffic: the numpy twin the package falls back on equals the
compiled code bit for bit (the Frenet projection's are in test_road.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from scenarios.scene import road_kernels
from scenarios.scene.lane_bodies import PIECE_TOLERANCE_M, STRETCH_MIN_M, LanePath

try:
    from scenarios.scene import _road_kernels as compiled
except ImportError:  # built without a C compiler: only the numpy twins are there
    compiled = None

#: libsumo's position, angle, speed, lateral offset, lane position and lane variables
KEYS = (0x42, 0x43, 0x40, 0xb8, 0x56, 0x51)
IDS = ["ego", "obstacle.0", "obstacle.1", "traffic.0", "traffic.1", "traffic.2", "traffic.13",
       "t.obstacle.", "7"]
#: vehicle id -> (length, width, class index): cars, a truck, a bicycle
SIZES = {vid: (4.5, 1.8, 0.0) for vid in IDS} | {"traffic.1": (16.5, 2.55, 1.0),
                                                  "7": (1.6, 0.65, 2.0)}
coordinate = st.floats(-80.0, 80.0, allow_nan=False)
person_st = st.fixed_dictionaries({KEYS[0]: st.tuples(coordinate, coordinate),
                                   KEYS[1]: st.floats(-360.0, 360.0, allow_nan=False),
                                   KEYS[2]: st.floats(0.0, 40.0, allow_nan=False)})
#: lanes the read knows: a straight one and a bend of 25 m radius drawn in 3 m
#: segments (a lane not among them is left to Python to lay)
_ARC = np.linspace(0.0, math.pi / 2, 14)
LANES = {"e1_0": LanePath([(np.array([[-50.0, -3.2], [90.0, -3.2]]), 140.0)]).flat,
         "e1_1": LanePath([(np.column_stack([25.0 * np.sin(_ARC), 25.0 * (1 - np.cos(_ARC))]),
                            40.0)]).flat}
vehicle_st = st.builds(
    lambda body, lateral, pos, lane: {**body, KEYS[3]: lateral, KEYS[4]: pos, KEYS[5]: lane},
    person_st, st.sampled_from([0.0, 0.0, 0.4, -1.3]), st.floats(0.0, 60.0),
    st.sampled_from(["e1_0", "e1_1", ":j3_0_0", ""]))
nearby_st = st.dictionaries(st.sampled_from(IDS), vehicle_st | person_st, max_size=9)


def read_by(traffic, nearby: dict, radius_m: float, sizes: dict = SIZES, with_laid=False):
    """How many vehicles, their boxes, speeds and class indexes (and which are left to
    lay in Python, how many), read by one implementation."""
    n = len(nearby)
    boxes, speeds, kinds = np.full((n, 5), np.nan), np.full(n, np.nan), np.full(n, np.nan)
    laid = np.full(n, np.nan)
    count, left = traffic(nearby, KEYS, "ego", "obstacle.", sizes, LANES, 3.0, -2.0, radius_m,
                          PIECE_TOLERANCE_M, STRETCH_MIN_M, boxes, speeds, kinds, laid)
    if with_laid:
        return count, boxes, speeds, kinds, laid[:count], left
    return count, boxes, speeds, kinds


@settings(max_examples=300, deadline=None)
@given(nearby=nearby_st, radius_m=st.sampled_from([0.0, 20.0, 60.0, 200.0]))
def test_the_numpy_traffic_read_equals_the_compiled_one(nearby, radius_m):
    """Ego and obstacles left out, the radius about the body centre, the dict's order,
    the bodies laid along known lanes: the same count, boxes, speeds and bodies left
    to lay, to the last bit."""
    count, boxes, speeds, kinds, laid, left = read_by(
        road_kernels.traffic_numpy, nearby, radius_m, with_laid=True)
    others = [vid for vid in nearby if vid != "ego" and not vid.startswith("obstacle.")]
    assert count <= len(others)
    assert left == np.count_nonzero(laid >= 0)
    if compiled is None:
        pytest.skip("the C extension was not built")
    fast_count, fast_boxes, fast_speeds, fast_kinds, fast_laid, fast_left = read_by(
        compiled.traffic, nearby, radius_m, with_laid=True)
    assert (fast_count, fast_left) == (count, left)
    assert fast_laid.tobytes() == laid.tobytes()
    assert fast_boxes[:count].tobytes() == boxes[:count].tobytes()
    assert fast_speeds[:count].tobytes() == speeds[:count].tobytes()
    assert fast_kinds[:count].tobytes() == kinds[:count].tobytes()


def test_a_vehicle_is_laid_along_its_lane_whatever_angle_sumo_gives_it():
    """Changing lanes 0.4 m left of its lane's centre, SUMO's angle 25 degrees off the
    lane: its box lies along the lane, shifted, not turned; a person keeps SUMO's box;
    a truck on the bend, one reaching back off its lane and one on a lane not read yet
    are left to lay in pieces or along the lanes before."""
    def vehicle(pos_m, lane, angle_deg=65.0, lateral_m=0.4):
        return {KEYS[0]: (10.0, -2.8), KEYS[1]: angle_deg, KEYS[2]: 1.0, KEYS[3]: lateral_m,
                KEYS[4]: pos_m, KEYS[5]: lane}
    person = {KEYS[0]: (10.0, 1.0), KEYS[1]: 90.0, KEYS[2]: 1.0}
    for traffic in (road_kernels.traffic_numpy, road_kernels.traffic):
        count, boxes, _, _, laid, left = read_by(
            traffic, {"traffic.0": vehicle(60.0, "e1_0"), "t.obstacle.": person}, 80.0,
            with_laid=True)
        assert (count, left) == (2, 0) and list(laid) == [-1.0, -1.0]
        np.testing.assert_allclose(boxes[0], [7.75, -2.8, 0.0, 4.5, 1.8], atol=1e-12)
        np.testing.assert_allclose(boxes[1], [7.75, 1.0, 0.0, 4.5, 1.8], atol=1e-12)
        for name, values in {"traffic.1": vehicle(30.0, "e1_1"),  # 16.5 m on the bend
                             "traffic.0": vehicle(3.0, "e1_0"),  # reaching back
                             "traffic.2": vehicle(30.0, ":j3_0_0")}.items():  # not read yet
            count, boxes, _, _, laid, left = read_by(traffic, {name: values}, 80.0,
                                                     with_laid=True)
            assert (count, left) == (1, 1) and list(laid) == [0.0], name
        count, _, _, _, laid, left = read_by(traffic, {"traffic.0": vehicle(30.0, "e1_1")},
                                             80.0, with_laid=True)
        assert (count, left) == (1, 0)  # a car on that bend: one box


def test_a_vehicle_box_is_centred_half_a_length_behind_its_front_bumper():
    nearby = {"ego": {KEYS[0]: (3.0, -2.0), KEYS[1]: 90.0, KEYS[2]: 5.0},
              "obstacle.0": {KEYS[0]: (5.0, -2.0), KEYS[1]: 90.0, KEYS[2]: 0.0},
              "traffic.1": {KEYS[0]: (10.0, 0.0), KEYS[1]: 0.0, KEYS[2]: 7.0},  # a truck north
              "traffic.0": {KEYS[0]: (100.0, 0.0), KEYS[1]: 90.0, KEYS[2]: 9.0}}  # too far
    for traffic in (road_kernels.traffic_numpy, road_kernels.traffic):
        count, boxes, speeds, kinds = read_by(traffic, nearby, 30.0)
        assert count == 1 and speeds[0] == 7.0 and kinds[0] == 1.0
        np.testing.assert_allclose(boxes[0], [10.0, -8.25, np.pi / 2, 16.5, 2.55], atol=1e-12)


def test_a_vehicle_not_met_yet_is_a_key_error_of_its_id():
    nearby = {"traffic.99": {KEYS[0]: (10.0, 0.0), KEYS[1]: 0.0, KEYS[2]: 7.0}}
    for traffic in (road_kernels.traffic_numpy, road_kernels.traffic):
        with pytest.raises(KeyError) as raised:
            read_by(traffic, nearby, 30.0)
        assert raised.value.args == ("traffic.99",)
