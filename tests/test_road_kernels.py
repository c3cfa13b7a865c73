"""The read of SUMO's traffic: the numpy twin the package falls back on equals the
compiled code bit for bit (the Frenet projection's are in test_road.py)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from scenarios import road_kernels

try:
    from scenarios import _road_kernels as compiled
except ImportError:  # built without a C compiler: only the numpy twins are there
    compiled = None

KEYS = (0x42, 0x43, 0x40)  # libsumo's position, angle and speed variables
IDS = ["ego", "obstacle.0", "obstacle.1", "traffic.0", "traffic.1", "traffic.2", "traffic.13",
       "t.obstacle.", "7"]
#: vehicle id -> (length, width, class index): cars, a truck, a bicycle
SIZES = {vid: (4.5, 1.8, 0.0) for vid in IDS} | {"traffic.1": (16.5, 2.55, 1.0),
                                                  "7": (1.6, 0.65, 2.0)}
coordinate = st.floats(-80.0, 80.0, allow_nan=False)
vehicle_st = st.fixed_dictionaries({KEYS[0]: st.tuples(coordinate, coordinate),
                                    KEYS[1]: st.floats(-360.0, 360.0, allow_nan=False),
                                    KEYS[2]: st.floats(0.0, 40.0, allow_nan=False)})
nearby_st = st.dictionaries(st.sampled_from(IDS), vehicle_st, max_size=9)


def read_by(traffic, nearby: dict, radius_m: float, sizes: dict = SIZES
            ) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
    """How many vehicles, their boxes, speeds and class indexes, read by one
    implementation."""
    n = len(nearby)
    boxes, speeds, kinds = np.full((n, 5), np.nan), np.full(n, np.nan), np.full(n, np.nan)
    count = traffic(nearby, KEYS, "ego", "obstacle.", sizes, 3.0, -2.0, radius_m, boxes,
                    speeds, kinds)
    return count, boxes, speeds, kinds


@settings(max_examples=300, deadline=None)
@given(nearby=nearby_st, radius_m=st.sampled_from([0.0, 20.0, 60.0, 200.0]))
def test_the_numpy_traffic_read_equals_the_compiled_one(nearby, radius_m):
    """Ego and obstacles left out, the radius about the body centre, the dict's order:
    the same count, boxes and speeds to the last bit."""
    count, boxes, speeds, kinds = read_by(road_kernels.traffic_numpy, nearby, radius_m)
    others = [vid for vid in nearby if vid != "ego" and not vid.startswith("obstacle.")]
    assert count <= len(others)
    assert np.all(np.hypot(boxes[:count, 0] - 3.0, boxes[:count, 1] + 2.0) <= radius_m + 1e-9)
    if compiled is None:
        pytest.skip("the C extension was not built")
    fast_count, fast_boxes, fast_speeds, fast_kinds = read_by(compiled.traffic, nearby,
                                                              radius_m)
    assert fast_count == count
    assert fast_boxes[:count].tobytes() == boxes[:count].tobytes()
    assert fast_speeds[:count].tobytes() == speeds[:count].tobytes()
    assert fast_kinds[:count].tobytes() == kinds[:count].tobytes()


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
