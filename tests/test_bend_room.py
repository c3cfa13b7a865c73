"""Room for the body through tight bends (sdc.car.avoid.bend_room), held to a
brute-force oracle: the body's rectangle placed at every pose and every offset,
each kerb point tested against it; and `avoid` through the turns of a default
``netgenerate`` grid in libsumo, where the X5 does not fit the lane's centre."""

from __future__ import annotations

import math
import subprocess

import numpy as np
import pytest

from scenarios import ScenarioSpec
from scenarios.spec.bodies import VEHICLE_MODELS
from scenarios.sumo_net.build import sumo_binary
from sdc.car.avoid.bend_room import bend_room, track
from sdc.car.lane_path import LanePath
from sdc.run.episode import run_episode

MODEL = VEHICLE_MODELS["x5-lesson"]
CLEARANCE_M = 0.25
HALF_LANE_M = 1.6
MIN_RADIUS_M = MODEL.wheelbase_m / math.tan(0.9 * MODEL.max_steer_rad)
#: the turn starts this far ahead of the car's rear axle [m]
TURN_AT_M = 12.0


def right_turn(radius_m: float, offset_m: float = 0.0) -> np.ndarray:
    """A line ``offset_m`` left of a lane that runs straight from behind the car
    to ``TURN_AT_M``, turns right on a quarter circle of ``radius_m`` (its centre
    line's; drawn with a point every 4 m or at least 5, as coarse as SUMO draws a
    junction's turn) and runs on 20 m, in the frame of the car's rear axle: (K, 2)."""
    r = radius_m + offset_m
    theta = np.linspace(math.pi / 2, 0.0, max(5, int(radius_m * math.pi / 2 / 4)))
    arc = np.column_stack([TURN_AT_M + r * np.cos(theta), -radius_m + r * np.sin(theta)])
    before = [[-10.0, offset_m]]
    after = [[TURN_AT_M + r, -radius_m - 20.0]]
    return np.vstack([before, arc, after])


def lane_path(radius_m: float) -> LanePath:
    xy = right_turn(radius_m)
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))]) - 10.0
    return LanePath(xy, s)


def kerb_points(radius_m: float, step_m: float = 0.2, lanes_right: int = 0) -> np.ndarray:
    """Returns along both kerbs of the road: the lane's, ``HALF_LANE_M`` either
    side, with ``lanes_right`` more lanes as wide on its right."""
    out = []
    for side in (-HALF_LANE_M * (1 + 2 * lanes_right), HALF_LANE_M):
        line = right_turn(radius_m, side)
        for a, b in zip(line[:-1], line[1:], strict=True):
            n = max(int(np.hypot(*(b - a)) / step_m), 1)
            out.append(a + np.linspace(0, 1, n, endpoint=False)[:, None] * (b - a))
    return np.vstack(out)


def blocked(route, offset_m: float, points: np.ndarray, pose: int,
            clearance_m: float = CLEARANCE_M - 1e-9) -> bool:
    """Brute force: does any point lie within ``clearance_m`` of the body (the
    rectangle grown by it on every side) with its rear axle ``offset_m`` left of
    the track's point ``pose``, along the track? (By default a point at the
    clearance exactly, to rounding, does not block.)"""
    dx, dy = route.direction[pose]
    axle = route.xy_m[pose] + offset_m * np.array([-dy, dx])
    rel = points - axle
    along, lateral = rel @ np.array([dx, dy]), rel @ np.array([-dy, dx])
    return bool(np.any((along >= -MODEL.rear_overhang_m - clearance_m)
                       & (along <= MODEL.front_ahead_of_rear_axle_m + clearance_m)
                       & (np.abs(lateral) <= MODEL.width_m / 2 + clearance_m)))


def fits(route, offset_m: float, points: np.ndarray, poses: int) -> bool:
    """Brute force: the offset keeps the body clear at poses 0..poses-1 and asks
    no turn there tighter than ``MIN_RADIUS_M`` of the rear axle."""
    for k in range(poses):
        curvature = route.curvature_1pm[k]
        if abs(curvature) > 1e-9 and abs(1 / curvature - offset_m) < MIN_RADIUS_M:
            return False
        if blocked(route, offset_m, points, k):
            return False
    return True


GRID_M = np.round(np.arange(-HALF_LANE_M, HALF_LANE_M + 1e-9, 0.02), 6)
OWN_LANE_M = (-HALF_LANE_M, HALF_LANE_M)


@pytest.mark.parametrize("radius_m", [6.0, 8.0, 12.0, 30.0])
@pytest.mark.parametrize("preferred_m", [0.0, 0.5, -0.5])
@pytest.mark.parametrize("lane", [0, -1], ids=["own-lane", "lane-right"])
def test_the_offset_keeps_the_body_clear_and_is_the_nearest_that_does(radius_m, preferred_m,
                                                                      lane):
    """In the car's own lane, or in the lane on its right (where it passes): the
    offsets held to those of that lane."""
    centre_m = 2 * HALF_LANE_M * lane
    route = track(lane_path(radius_m), 0.0, TURN_AT_M + radius_m * math.pi / 2 + 6.0)
    points = kerb_points(radius_m, lanes_right=-lane)
    room = bend_room(route, points, MODEL, centre_m + preferred_m,
                     (centre_m - HALF_LANE_M, centre_m + HALF_LANE_M), CLEARANCE_M,
                     MIN_RADIUS_M)
    poses = len(route.s_m)
    good = [centre_m + o for o in GRID_M if fits(route, centre_m + o, points, poses)]
    if not good:
        assert math.isnan(room.offset_m)
        return
    assert room.free_m == math.inf
    assert fits(route, room.offset_m, points, poses)
    assert centre_m - HALF_LANE_M <= room.offset_m <= centre_m + HALF_LANE_M
    nearest = min(good, key=lambda o: abs(o - centre_m - preferred_m))
    assert (abs(room.offset_m - centre_m - preferred_m)
            <= abs(nearest - centre_m - preferred_m) + 1e-9)


def test_a_tight_turn_moves_the_car_toward_its_inside_and_a_wide_one_does_not():
    offsets = {}
    for radius_m in (20.0, 60.0):
        route = track(lane_path(radius_m), 0.0, TURN_AT_M + radius_m * math.pi / 2 + 6.0)
        offsets[radius_m] = bend_room(route, kerb_points(radius_m), MODEL, 0.0, OWN_LANE_M,
                                      CLEARANCE_M, MIN_RADIUS_M).offset_m
    assert offsets[60.0] == 0.0
    # the front swings out beyond the rear axle's track: the axle keeps to the inside
    assert offsets[20.0] < -0.1


def test_where_no_offset_fits_it_says_how_far_the_car_may_go():
    radius_m = 10.0
    route = track(lane_path(radius_m), 0.0, TURN_AT_M + radius_m * math.pi / 2 + 6.0)
    points = kerb_points(radius_m)
    # a car standing across the lane in the turn's middle
    theta = math.pi / 4
    middle = np.array([TURN_AT_M + radius_m * math.cos(theta),
                       -radius_m + radius_m * math.sin(theta)])
    across = middle + np.linspace(-2, 2, 41)[:, None] * np.array([math.cos(theta),
                                                                    math.sin(theta)])
    points = np.vstack([points, across])
    room = bend_room(route, points, MODEL, 0.0, OWN_LANE_M, CLEARANCE_M, MIN_RADIUS_M)
    assert math.isnan(room.offset_m)
    first_blocked = next(k for k in range(1, len(route.s_m) + 1)
                         if not any(fits(route, o, points, k) for o in GRID_M)) - 1
    assert room.free_m == pytest.approx(route.s_m[first_blocked] - route.s_m[0], abs=1e-9)
    assert 0 < room.free_m < TURN_AT_M + radius_m * math.pi / 4


GRID_SCENARIO = {
    "scenario": {"name": "grid-turns", "duration_s": 40.0, "step_s": 0.064},
    "road": {"kind": "sumo_net", "length_m": 400.0, "route_turns": "any"},
    "traffic": {"vehicles": 0, "warm_up_s": 0.0},
    "ego": {"lane": 0, "start_m": 10.0},
    "controller": {"name": "avoid"},
}


@pytest.mark.slow
#: samples of benchmarks/avoid_real.py's grid-turns in which avoid hit a kerb in a
#: turn before it checked the room its body sweeps, and one more
@pytest.mark.parametrize("seed, speed_mps", [(621247830, 4.75), (426645830, 7.28),
                                             (1156291070, 8.94), (1589516569, 12.06),
                                             (814157363, 13.65), (3, 12.0)])
def test_avoid_takes_the_turns_of_a_default_grid_without_touching_a_kerb(tmp_path, seed,
                                                                         speed_mps):
    net = tmp_path / "grid.net.xml"
    subprocess.run([sumo_binary("netgenerate"), "--grid", "--output-file", str(net)],
                   check=True, capture_output=True)
    plain = {k: dict(v) for k, v in GRID_SCENARIO.items()}
    plain["scenario"]["seed"] = seed
    plain["road"]["net_file"] = str(net)
    plain["ego"]["speed_mps"] = speed_mps
    row = run_episode(ScenarioSpec.from_plain(plain)).row
    assert row["status"] == "ok"
    assert row["collision_with"] == "none", (row["collision_with"], row["collision_time_s"])
    assert row["outcome"] == "completed"
