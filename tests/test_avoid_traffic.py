"""``avoid`` among traffic: it follows a moving leader, waits behind a queue, stops
for red and passes only what stands (sdc.car.avoid.leader_watch, the stop line in the
observation). Closed loops on the fake straight road of test_avoid: the boxes
move, the car moves under its own commands."""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_avoid import FRONT_AHEAD_M, LANE_W, MODEL, STEP_S, FakeRoad, car_at

from scenarios.spec.controller_params import AvoidParams
from sdc.car.avoid.controller import AVOID_LEFT, AVOID_RIGHT, CRUISE, WAIT, AvoidController
from sdc.car.avoid.leader_watch import LeaderWatch
from sdc.car.controller_api import GREEN, NO_SIGNAL, RED, YELLOW, LanesBeside, StopLine
from sdc.car.vehicle import Vehicle, VehicleState

PASSING = (AVOID_LEFT, AVOID_RIGHT)


def drive(boxes_at, seconds: float, speed_mps: float, line_at=None, beside_at=None,
          **params):
    """The car from x = 0 at ``speed_mps`` for ``seconds`` on a two-lane road;
    ``boxes_at(t)`` the boxes at time t, ``line_at(t, front_x)`` the stop line
    then (or None), ``beside_at(x)`` the map's lanes beside at the body centre's x
    (default: not known). Per step:
    (t, phase, speed, gap from the front bumper to the nearest box in the own
    lane, the car's rear-axle x)."""
    controller, vehicle = AvoidController(params), Vehicle(MODEL, 0.9)
    state = VehicleState(0.0, 0.0, 0.0, speed_mps, 0.0)
    rows = []
    for k in range(round(seconds / STEP_S)):
        t = k * STEP_S
        boxes = boxes_at(t)
        obs = FakeRoad(boxes, lanes_left=1, lanes_right=0).observe(state, t)
        front_x = state.x_m + FRONT_AHEAD_M
        if line_at is not None:
            obs = obs._replace(stop_line=line_at(t, front_x))
        if beside_at is not None:
            obs = obs._replace(lanes_beside=beside_at(obs.lane.s_m))
        command = controller.step(obs)
        ahead = [b[0] - b[3] / 2 - front_x for b in boxes if abs(b[1]) < LANE_W / 2]
        rows.append((t, controller.phase, state.speed_mps, min(ahead, default=math.inf),
                     state.x_m))
        state = vehicle.step(state, command, STEP_S)
    return rows


def test_leader_speed_is_its_stations_change_and_a_jump_starts_afresh():
    watch = LeaderWatch(AvoidParams())
    for k in range(10):
        watch.update(k * 0.1, 50.0 + 8.0 * k * 0.1)
    assert watch.speed_mps() == pytest.approx(8.0)
    assert watch.is_traffic(0.9) and watch.moved
    watch.update(1.0, 20.0)  # something else, much nearer
    assert watch.speed_mps() is None and not watch.moved


def test_a_car_seen_moving_then_stopping_stays_traffic_for_the_patience():
    params = AvoidParams(stand_patience_s=5.0)
    watch = LeaderWatch(params)
    s = 50.0
    for k in range(40):  # 10 m/s for 1 s, then it stands
        s += (10.0 if k < 10 else 0.0) * 0.1
        watch.update(k * 0.1, s)
    assert watch.speed_mps() == pytest.approx(0.0) and watch.is_traffic(3.9)
    assert not watch.is_traffic(watch.standing_since_s + 5.0)
    never_moved = LeaderWatch(params)
    for k in range(10):
        never_moved.update(k * 0.1, 50.0)
    assert not never_moved.is_traffic(0.9)  # a standing obstacle: to pass


@pytest.mark.parametrize("leader_mps", [4.0, 8.0, 12.0])
def test_a_slower_moving_leader_is_followed_at_the_time_gap_never_passed(leader_mps):
    params = AvoidParams()
    rows = drive(lambda t: [car_at(40.0 + leader_mps * t, 0.0)], 40.0, 15.0)
    assert not any(phase in PASSING for _, phase, *_ in rows)
    t, _, speed, gap, _ = rows[-1]
    assert speed == pytest.approx(leader_mps, abs=0.2)
    # the intelligent driver model's steady gap at the leader's speed, cruising at 15
    wanted = ((params.wait_gap_m + leader_mps * params.follow_time_gap_s)
              / math.sqrt(1 - (leader_mps / 15.0) ** 4))
    assert gap == pytest.approx(wanted, rel=0.05)
    assert min(r[3] for r in rows) > params.wait_gap_m  # never closer than standing


def test_a_leader_that_brakes_hard_to_a_stop_is_not_hit_nor_passed():
    def boxes(t):  # 12 m/s, then braking at 6 m/s^2 from t = 5 s to a stop
        x = 30.0 + 12.0 * min(t, 5.0)
        if t > 5.0:
            dt = min(t - 5.0, 2.0)
            x += 12.0 * dt - 3.0 * dt**2
        return [car_at(x, 0.0)]

    rows = drive(boxes, 20.0, 12.0, stand_patience_s=60.0)
    assert min(r[3] for r in rows) > 1.0
    assert not any(phase in PASSING for _, phase, *_ in rows)
    assert rows[-1][2] == pytest.approx(0.0, abs=0.05)  # it waits behind the queue


def test_what_stood_from_the_start_is_passed_once_seen():
    rows = drive(lambda t: [car_at(60.0, 0.0)], 12.0, 12.0, lane_watch_s=0.0)
    assert any(phase == AVOID_LEFT for _, phase, *_ in rows)


def test_no_pass_where_the_map_shows_no_lane_of_ours_and_oncoming_traffic_is_out_of_sight():
    """The lane left holds the other direction (the map: ``left_m`` 0). Passing the
    car standing in the own lane there needs that lane seen free as far as a car
    coming the other way at 20 m/s would come before the car is back: more than
    the 80 m the lidar sees, even from a standstill behind it. avoid waits; with
    a lane of its own direction on past the car it passes."""
    standing = [car_at(60.0, 0.0)]

    def left_until(end_x: float):
        return lambda x: LanesBeside(max(end_x - x, 0.0), 0.0)

    rows = drive(lambda t: standing, 20.0, 12.0, beside_at=left_until(0.0), lane_watch_s=0.0)
    assert not any(phase in PASSING for _, phase, *_ in rows)
    assert rows[-1][2] == pytest.approx(0.0, abs=0.05)
    rows = drive(lambda t: standing, 12.0, 12.0, beside_at=left_until(200.0), lane_watch_s=0.0)
    assert any(phase == AVOID_LEFT for _, phase, *_ in rows)
    # a lane of its own direction that ends beside the car ahead is no lane to pass in
    rows = drive(lambda t: standing, 20.0, 12.0, beside_at=left_until(64.0), lane_watch_s=0.0)
    assert not any(phase in PASSING for _, phase, *_ in rows)
    # where a car coming the other way would come slower, the lane seen free will do
    rows = drive(lambda t: standing, 20.0, 12.0, beside_at=left_until(0.0), lane_watch_s=0.0,
                 oncoming_speed_mps=5.0)
    assert any(phase == AVOID_LEFT for _, phase, *_ in rows)


@pytest.mark.parametrize("gap_m, lateral_m", [(6.0, 0.0), (6.0, 0.4), (7.0, 0.0)])
def test_from_a_standstill_behind_a_truck_the_swerve_clears_its_corner(gap_m, lateral_m):
    """Standing 6-7 m behind a 2.5 m wide truck, the car swerves out at the tightest
    turn: its heading then runs clear of the truck's near corner, which still lies
    within its body's width along the lane. Before, that band held it at 0 m/s with
    the corner beside it, for good."""
    truck = [FRONT_AHEAD_M + gap_m + 6.0, lateral_m, 0.0, 12.0, 2.5]
    rows = drive(lambda t: [truck], 20.0, 0.0, lane_watch_s=0.0, cruise_speed_mps=5.0)
    assert max(x for *_, x in rows) > truck[0] + 6.0 + 2.0  # rear axle past its far end
    assert rows[-1][1] not in PASSING


def cross_traffic(give_way: bool, foe_speed_mps: float, from_left_m: float = 50.0,
                  seconds: float = 14.0):
    """avoid at 10 m/s toward a line at x = 60 (``give_way`` there or not), with a car
    crossing its road at x = 68 from ``from_left_m`` left of it at ``foe_speed_mps``, the kerbs
    open where the other road meets its own. Per step: (t, speed, front x, whether
    the bodies overlap)."""
    controller, vehicle = AvoidController({}), Vehicle(MODEL, 0.9)
    state = VehicleState(0.0, 0.0, 0.0, 10.0, 0.0)
    rows = []
    for k in range(round(seconds / STEP_S)):
        t = k * STEP_S
        foe = [68.0, from_left_m - foe_speed_mps * t, -math.pi / 2, 4.5, 1.8]
        road = FakeRoad([foe], lanes_left=1, lanes_right=0)
        road.edges = np.array([[x0, y, x1, y] for y in road.edges[:, 1]
                               for x0, x1 in ((-100.0, 55.0), (80.0, 400.0))])
        front_x = state.x_m + FRONT_AHEAD_M
        line = StopLine(60.0 - front_x, NO_SIGNAL, give_way) if front_x < 60.0 else None
        command = controller.step(road.observe(state, t)._replace(stop_line=line))
        centre_x = state.x_m + FRONT_AHEAD_M - MODEL.length_m / 2
        overlap = (abs(centre_x - foe[0]) < (MODEL.length_m + foe[4]) / 2
                   and abs(state.y_m - foe[1]) < (MODEL.width_m + foe[3]) / 2)
        rows.append((t, state.speed_mps, front_x, overlap))
        state = vehicle.step(state, command, STEP_S)
    return rows


def test_at_a_line_where_it_gives_way_it_waits_for_a_car_crossing_then_goes():
    rows = cross_traffic(give_way=True, foe_speed_mps=8.0)
    assert not any(overlap for *_, overlap in rows)
    stopped = [front_x for _, speed, front_x, _ in rows if speed < 0.1]
    assert stopped and max(stopped) < 60.0  # it stood before the line
    assert rows[-1][2] > 90.0  # and went on once the car had crossed


def test_a_car_standing_beside_the_junction_is_no_foe():
    rows = cross_traffic(give_way=True, foe_speed_mps=0.0, from_left_m=10.0)
    assert min(speed for t, speed, *_ in rows if t < 6.0) > 9.9


def test_red_is_stopped_for_before_its_line_and_green_goes():
    line_x = 60.0

    def line(colour):
        return lambda t, front_x: StopLine(line_x - front_x, colour, False)

    for colour in (RED, YELLOW):
        rows = drive(lambda t: [], 15.0, 12.0, line_at=line(colour))
        fronts = [x + FRONT_AHEAD_M for *_, x in rows]
        assert max(fronts) < line_x  # stopped short of it
        assert max(fronts) > line_x - 3 * AvoidParams().stop_margin_m
        assert rows[-1][1] == WAIT  # the phase says what it does there
    for colour in (GREEN, NO_SIGNAL):
        rows = drive(lambda t: [], 15.0, 12.0, line_at=line(colour))
        assert rows[-1][4] + FRONT_AHEAD_M > line_x + 50.0
        assert {phase for _, phase, *_ in rows} == {CRUISE}


def test_a_red_too_close_to_stop_for_is_crossed_and_a_late_yellow_too():
    rows = drive(lambda t: [], 3.0, 20.0,
                 line_at=lambda t, front_x: StopLine(15.0 - front_x, RED, False)
                 if t > 0 else None)  # 25 m needed to stop at 20 m/s: 15 m given
    assert rows[-1][4] + FRONT_AHEAD_M > 15.0
    rows = drive(lambda t: [], 3.0, 15.0,
                 line_at=lambda t, front_x: StopLine(20.0 - front_x, YELLOW, False))
    assert rows[-1][4] + FRONT_AHEAD_M > 20.0  # 28 m to stop comfortably


def test_what_stands_before_a_red_light_is_a_queue_waited_behind_not_passed():
    queue = [car_at(55.0, 0.0)]  # the last car of a queue 3 m before the line
    line = lambda t, front_x: StopLine(60.0 - front_x, RED, False)  # noqa: E731
    rows = drive(lambda t: queue, 30.0, 12.0, line_at=line, lane_watch_s=0.0)
    assert not any(phase in PASSING for _, phase, *_ in rows)
    assert rows[-1][2] == 0.0 and rows[-1][3] == pytest.approx(AvoidParams().wait_gap_m, 0.2)
    assert rows[-1][1] == WAIT
    green = lambda t, front_x: StopLine(60.0 - front_x, GREEN, False)  # noqa: E731
    rows = drive(lambda t: queue, 30.0, 12.0, line_at=green, lane_watch_s=0.0)
    assert any(phase in PASSING for _, phase, *_ in rows)  # it stands through green: passed


def test_red_is_stopped_for_while_braking_for_an_obstacle_beyond_the_line():
    # the barrel 30 m past the line (beyond the junction), seen 3.4 s ahead at 25 m/s
    barrel_x, line_x = 90.0, 60.0
    rows = drive(lambda t: [[barrel_x, 0.0, 0.0, 0.6, 0.6]], 15.0, 25.0,
                 line_at=lambda t, front_x: StopLine(line_x - front_x, RED, False))
    assert "brake" in {phase for _, phase, *_ in rows}  # the obstacle's plan held it
    assert max(x + FRONT_AHEAD_M for *_, x in rows) < line_x


def test_too_close_to_stop_at_the_waiting_gap_it_stops_as_far_back_as_it_can_then_passes():
    """A car standing 25 m ahead at 17.4 m/s: the waiting gap (7 m) is out of reach
    and the lane beside not yet watched for ``lane_watch_s``. At its hardest
    braking the car stops about 6 m short, room to steer round from there; easing
    off to stop 1.5 m short had left it there for good (seed-envelope, 6 runs)."""
    standing = [car_at(FRONT_AHEAD_M + 25.0 + 2.25, 0.0)]
    rows = drive(lambda t: standing, 12.0, 17.4)
    stopped = [gap for _, phase, speed, gap, _ in rows if speed < 1e-6 and gap < math.inf]
    assert stopped and min(stopped) > 5.0
    assert any(phase == AVOID_LEFT for _, phase, *_ in rows)
    assert max(x for *_, x in rows) > standing[0][0] + 2.25 + 2.0  # rear axle past it


def test_passing_in_a_lane_that_ends_it_stops_short_of_the_end():
    """A queue standing in the own lane from 40 m to 160 m; the lane left, of the
    car's direction, ends at x = 100 m (a merge). The car passes in it, finds the
    queue going on, and stops short of the lane's end rather than run off it."""
    queue = [car_at(40.0 + 6.0 * k, 0.0) for k in range(21)]
    end_x = 100.0
    rows = drive(lambda t: queue, 25.0, 12.0, lane_watch_s=0.0,
                 beside_at=lambda x: LanesBeside(max(end_x - x, 0.0), 0.0))
    assert any(phase == AVOID_LEFT for _, phase, *_ in rows)
    front_x = max(x for *_, x in rows) + FRONT_AHEAD_M
    assert end_x - 5.0 < front_x <= end_x
    assert rows[-1][2] == pytest.approx(0.0, abs=0.05)
