"""Road-edge gaps and the brake-only stop on hand-built scenes."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest

from analysis.measures.safety import road_edge_gaps_m, stop_gap_m, stop_possible
from scenarios.common.errors import SpecError
from scenarios.scene.road_geometry import RoadGeometry
from scenarios.spec.bodies import VEHICLE_MODELS
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.world_backends import make_road


def box(cx, cy, yaw=0.0, length=4.0, width=2.0):
    return np.array([[cx, cy, yaw, length, width]])


def test_road_edge_gap_of_a_car_on_a_straight_road():
    road = RoadGeometry(np.array([[0.0, 0.0], [100.0, 0.0]]), 2, 3.5)  # edges at y = +-3.5
    boxes = np.vstack([box(50.0, 0.0), box(50.0, 2.0), box(50.0, -3.0), box(-50.0, 0.0)])
    gaps = road_edge_gaps_m(boxes, road)
    assert gaps[:3] == pytest.approx([2.5, 0.5, -0.5])
    assert np.isnan(gaps[3])  # not alongside the road


# the brake-only stop: hand-made specs on the seed-lesson road (3 lanes of 3.5 m,
# ego in lane 0 at 10 m; the x5-lesson is 4.85 x 1.93 m and brakes at 8 m/s^2)
X5 = VEHICLE_MODELS["x5-lesson"]


def _spec(plain: dict, obstacles: list[dict], **ego) -> ScenarioSpec:
    plain["obstacles"] = [{"kind": "barrel", "lane": 0, **o} for o in obstacles]
    plain["ego"].update(ego)
    return ScenarioSpec.from_plain(plain)


def _gap(spec: ScenarioSpec, road: RoadGeometry | None = None) -> float | None:
    return stop_gap_m(spec, road or make_road(spec), X5)


def test_the_lesson_can_stop_before_its_barrel(lesson_plain):
    spec = ScenarioSpec.from_plain(lesson_plain)
    gap = _gap(spec)
    assert gap == pytest.approx(40 - 0.3 - (10 + 2.425), abs=1e-12)  # 27.275 m
    assert stop_possible(3.74, X5.max_decel_mps2, gap) is True  # needs 0.87 m
    assert stop_possible(21.0, X5.max_decel_mps2, gap) is False  # needs 27.56 m


def test_stop_possible_exactly_at_the_boundary(lesson_plain):
    spec = _spec(lesson_plain, [{"position_m": 13.725}], speed_mps=4.0)
    assert _gap(spec) == 1.0  # 4^2 / (2 * 8) = 1.0 m exactly
    assert stop_possible(4.0, 8.0, _gap(spec)) is True
    assert stop_possible(math.nextafter(4.0, 5.0), 8.0, 1.0) is False
    assert stop_possible(4.0, 8.0, math.nextafter(1.0, 0.0)) is False
    assert stop_possible(4.0, 8.0, None) is None


def test_an_obstacle_behind_the_ego_is_refused_so_never_in_its_path(lesson_plain):
    """It could never be met (and the run would count as completed): the scenario is
    bad input, alone or beside one ahead."""
    for obstacles in ([{"position_m": 10.0}], [{"position_m": 10.0}, {"position_m": 50.0}]):
        with pytest.raises(SpecError, match=r"^obstacles\[0\]\.position_m: .* behind the ego"):
            _spec(copy.deepcopy(lesson_plain), obstacles, start_m=30.0)
    ahead = _spec(lesson_plain, [{"position_m": 50.0}], start_m=30.0)
    assert _gap(ahead) == pytest.approx(20.0 - 2.725)


@pytest.mark.parametrize(("obstacle", "in_path"), [
    ({"lane": 1}, False),  # the next lane's centre, 3.5 m over
    # a car (1.8 m wide) from lane 1 toward the ego: the band's edge (0.965 m) plus its
    # half width (0.9 m) is 1.865 m, its centre 3.5 - 1.6 = 1.9 m away: beside the path
    ({"kind": "car", "lane": 1, "lateral_offset_m": -1.6}, False),
    ({"kind": "car", "lane": 1, "lateral_offset_m": -1.7}, True),  # 1.8 m: it reaches in
    ({"kind": "car", "lane": 0, "lateral_offset_m": 1.9}, False),  # the ego's lane, offset out
    ({"kind": "car", "lane": 0, "lateral_offset_m": -1.7}, True),  # half off the road
])
def test_the_path_is_the_band_of_the_ego_body(lesson_plain, obstacle, in_path):
    spec = _spec(lesson_plain, [{"position_m": 40.0, **obstacle}])
    gap = _gap(spec)
    assert (gap is not None) == in_path
    if in_path:
        assert gap == pytest.approx(30.0 - (4.85 + 4.5) / 2)


def test_the_nearest_obstacle_in_the_path_counts(lesson_plain):
    spec = _spec(lesson_plain, [
        {"position_m": 60.0},
        {"kind": "truck", "lane": 1, "position_m": 20.0},  # nearer, beside the path
        {"kind": "truck", "position_m": 45.0},  # rear at 39 m
        {"position_m": 42.0, "lateral_offset_m": 0.5},  # rear at 41.7 m
    ])
    assert _gap(spec) == pytest.approx(39.0 - 12.425)


def test_on_a_curve_the_gap_runs_along_the_ego_lane(lesson_plain):
    lesson_plain["road"].update(kind="curve", curve_radius_m=60.0)  # a left curve
    inner = _spec(lesson_plain, [{"lane": 2, "position_m": 40.0}], lane=2)
    outer = _spec(lesson_plain, [{"position_m": 40.0}], lane=0)
    for spec in (inner, outer):
        road = make_road(spec)
        lane_d = road.lane_center_d_m(spec.ego.lane)
        ego_xy, obstacle_xy = road.xy_at([10.0, 40.0], lane_d)
        radius = 60.0 - lane_d  # the ego lane's own radius
        arc = 2 * radius * math.asin(np.hypot(*(obstacle_xy - ego_xy)) / (2 * radius))
        # within the lane polyline's wobble about its arc (offsets along chord normals: mm)
        assert _gap(spec, road) == pytest.approx(arc - 2.725, abs=0.02)
    assert _gap(inner) < 30 - 2.725 < _gap(outer)


def test_the_gap_follows_where_the_road_places_an_obstacle(lesson_plain):
    class MovesAhead(RoadGeometry):  # as a SUMO route moves one off a junction
        def place_s_m(self, s_m, length_m):
            return s_m + 5.0

    spec = ScenarioSpec.from_plain(lesson_plain)
    road = MovesAhead(make_road(spec).center_xy, 3, 3.5)
    assert _gap(spec, road) == pytest.approx(_gap(spec) + 5.0)


class FullBrake:
    phase = "brake"

    def step(self, obs):
        from sdc.car.vehicle import Command

        return Command(0.0, -100.0)


@pytest.mark.parametrize("friction_mu", [0.1, 0.9])
def test_stop_possible_uses_the_road_s_grip_and_braking_agrees(lesson_plain, friction_mu):
    """A barrel 45 m ahead of the front bumper at 15 m/s: on a dry road (mu = 0.9) the
    brakes stop the car in 14 m; on ice (mu = 0.1) braking takes 115 m, so a stop is
    not possible, and a real run braking fully from the first step hits the barrel."""
    from scenarios.world_backends import make_road, make_world
    from sdc.run.episode import Simulation
    from sdc.run.world_loop import run_alone

    lesson_plain["vehicle"] = {"friction_mu": friction_mu}
    spec = _spec(lesson_plain, [{"position_m": 10 + 2.425 + 45 + 0.3}], speed_mps=15.0)
    assert _gap(spec) == pytest.approx(45.0)
    decel = X5.braking_decel_mps2(friction_mu)
    assert stop_possible(15.0, decel, 45.0) is (friction_mu == 0.9)
    road = make_road(spec)
    with make_world(spec, road) as world:
        sim = Simulation(spec, world, controller=FullBrake())
        row = sim.finish(run_alone(world, sim)).row
    assert row["stop_possible"] is (friction_mu == 0.9)
    assert row["collision"] is (friction_mu == 0.1)
