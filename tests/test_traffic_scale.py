"""Traffic around the ego from the first step (warm-up), read only within the sensing radius."""

from __future__ import annotations

import numpy as np
import pytest

from scenarios.road import RoadGeometry
from scenarios.snapshot import in_start_zone, sensing_radius_m
from scenarios.spec import ScenarioSpec
from scenarios.worlds import make_world
from sdc.episode import Simulation, run_episode
from sdc.vehicle import Command

pytestmark = pytest.mark.slow


def busy_road(lesson_plain: dict, backend: str) -> ScenarioSpec:
    plain = lesson_plain
    plain["road"].update(length_m=1500.0, speed_limit_mps=27.78)
    plain["traffic"] = {"flow_vph_per_lane": 1500.0, "speed_mean_mps": 25.0, "warm_up_s": 50.0}
    plain["ego"].update(lane=1, start_m=700.0, speed_mps=18.0)
    plain["lidar"]["max_range_m"] = 60.0
    plain["obstacles"] = []
    plain["scenario"].update(duration_s=8.0, backend=backend)
    plain["controller"] = {"name": "lane-keep"}
    return ScenarioSpec.from_plain(plain)


def every_vehicle_within(world, ego_box, radius_m) -> int:
    """Traffic with its body centre within ``radius_m``, read vehicle by vehicle."""
    vehicle = world._sumo.vehicle
    count = 0
    for vid in vehicle.getIDList():
        if vid == "ego" or vid.startswith("obstacle."):
            continue
        (fx, fy), yaw = vehicle.getPosition(vid), np.radians(90.0 - vehicle.getAngle(vid))
        half_m = vehicle.getLength(vid) / 2
        count += np.hypot(fx - half_m * np.cos(yaw) - ego_box[0],
                          fy - half_m * np.sin(yaw) - ego_box[1]) <= radius_m
    return count


@pytest.mark.parametrize("backend", ["sumo", "highway"])
def test_after_a_warm_up_the_ego_starts_inside_traffic_and_sees_only_its_surroundings(
        lesson_plain, backend):
    spec = busy_road(lesson_plain, backend)
    road = RoadGeometry.from_spec(spec.road)
    with make_world(spec, road) as world:
        sim = Simulation(spec, world, 5.0)
        sim.start()
        first = sim.snapshot.traffic_boxes
        assert len(first) >= 4  # traffic on every side from the first step
        ego_lane = np.abs(first[:, 1] - road.lane_center_d_m(1)) < 1.75
        assert not in_start_zone(spec, road, first[ego_lane, :2]).any()
        radius = sensing_radius_m(spec)
        for _ in range(60):
            distances = np.hypot(*(sim.snapshot.traffic_boxes[:, :2] - sim.box[:2]).T)
            assert np.all(distances <= radius)
            if backend == "sumo":  # the subscription misses nothing within the radius
                assert len(sim.snapshot.traffic_boxes) == every_vehicle_within(world, sim.box,
                                                                                radius)
            sim.advance(Command(0.0))
        assert world.vehicle_count() > 2 * len(sim.snapshot.traffic_boxes)  # the rest unread


def test_a_warmed_up_run_is_deterministic_and_survives_its_start(lesson_plain):
    spec = busy_road(lesson_plain, "sumo")
    first, again = run_episode(spec).row, run_episode(spec).row
    assert first["termination"] == "duration" and not first["collision"]
    assert first["trace_sha256"] == again["trace_sha256"]
