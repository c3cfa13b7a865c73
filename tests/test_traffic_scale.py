"""Traffic around the ego from the first step (warm-up), read only within the sensing radius."""

from __future__ import annotations

import numpy as np
import pytest
import traci.constants as tc

from scenarios.scene import road_kernels
from scenarios.scene.lane_bodies import PIECE_TOLERANCE_M, STRETCH_MIN_M
from scenarios.scene.snapshot import in_start_zone, sensing_radius_m
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.world_backends import make_road, make_world
from sdc.car.vehicle import Command
from sdc.run.episode import Simulation, run_episode
from sdc.run.world_loop import WorldLoop

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


def traffic_read_by(traffic, world, ego_box, radius_m) -> tuple[np.ndarray, ...]:
    """The traffic boxes, speeds and class indexes of the subscription's results (and
    which must be laid along their lanes), read by one implementation of the kernel."""
    nearby = world._sumo.vehicle.getContextSubscriptionResults("ego")
    n = len(nearby)
    boxes, speeds, kinds = np.full((n, 5), np.nan), np.full(n, np.nan), np.full(n, np.nan)
    laid = np.full(n, np.nan)
    count, _ = traffic(nearby, (tc.VAR_POSITION, tc.VAR_ANGLE, tc.VAR_SPEED,
                                tc.VAR_LANEPOSITION_LAT, tc.VAR_LANEPOSITION, tc.VAR_LANE_ID),
                       "ego", "obstacle.", world._types.sizes, dict(world._reader.paths.flat),
                       float(ego_box[0]), float(ego_box[1]), radius_m, PIECE_TOLERANCE_M,
                       STRETCH_MIN_M, boxes, speeds, kinds, laid)
    return boxes[:count], speeds[:count], kinds[:count], laid[:count]


@pytest.mark.parametrize("backend", ["sumo", "highway"])
def test_after_a_warm_up_the_ego_starts_inside_traffic_and_sees_only_its_surroundings(
        lesson_plain, backend):
    spec = busy_road(lesson_plain, backend)
    road = make_road(spec)
    with make_world(spec, road) as world:
        sim = Simulation(spec, world, 5.0)
        WorldLoop(world, [sim]).start()
        first = sim.snapshot.traffic_boxes
        assert len(first) >= 4  # traffic on every side from the first step
        ego_lane = np.abs(first[:, 1] - road.lane_center_d_m(1)) < 1.75
        assert not in_start_zone(spec, road, first[ego_lane, :2], first[ego_lane, 3]).any()
        radius = sensing_radius_m(spec)
        for _ in range(60):
            snapshot = sim.snapshot
            bodies = (np.arange(len(snapshot.traffic_boxes)) if snapshot.traffic_bodies is None
                      else snapshot.traffic_bodies)
            # chosen by the body centre SUMO's angle gives; one laid along its lane
            # lies within its length of that
            distances = np.hypot(*(snapshot.traffic_boxes[:, :2] - sim.box[:2]).T)
            assert np.all(distances <= radius + snapshot.traffic_boxes[:, 3])
            if backend == "sumo":  # the subscription misses nothing within the radius
                assert len(np.unique(bodies)) == every_vehicle_within(world, sim.box, radius)
                # and the read of its results is the numpy twin's, bit for bit
                boxes, speeds, kinds, laid = traffic_read_by(road_kernels.traffic_numpy, world,
                                                             sim.box, radius)
                fast = traffic_read_by(road_kernels.traffic, world, sim.box, radius)
                for mine, theirs in zip((boxes, speeds, kinds, laid), fast, strict=True):
                    assert mine.tobytes() == theirs.tobytes()
                first = np.flatnonzero(np.diff(bodies, prepend=-1))  # each body's first box
                read = laid < 0  # laid by the read itself (the rest in Python)
                assert snapshot.traffic_boxes[first][read].tobytes() == boxes[read].tobytes()
                assert snapshot.traffic_speeds_mps[first].tobytes() == speeds.tobytes()
                assert list(snapshot.traffic_classes[first]) == list(world._types.names(kinds))
            sim.move(Command(0.0))
            sim.arrive(world.step(*sim.pose()))
        assert world.vehicle_count() > 2 * len(sim.snapshot.traffic_boxes)  # the rest unread


def test_a_warmed_up_run_is_deterministic_and_survives_its_start(lesson_plain):
    spec = busy_road(lesson_plain, "sumo")
    first, again = run_episode(spec).row, run_episode(spec).row
    assert first["termination"] == "duration" and not first["collision"]
    assert first["trace_sha256"] == again["trace_sha256"]
