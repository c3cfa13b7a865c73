"""SUMO's own driver in the ego's place: a reference for what the world allows.

The ego's car (its vType, where and how fast the run starts it) driven by SUMO's
car-following and lane-change models instead of a controller, in the same world
(the same warm state, demand and obstacles). Whether it gets past the obstacles
ahead of its start within the run's duration tells what a controller could have
done: where SUMO's driver is stuck as well (a one-lane ramp blocked, a queue that
lets nobody in), a controller that waits is not to blame.
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

from scenarios.spec.bodies import VEHICLE_MODELS
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.world_backends import make_road, make_world
from sdc.car.vehicle import Vehicle
from sdc.run.episode import initial_state

PASSED, COLLIDED, NOT_PAST = "passed", "collided", "not_past"


class SumoDriverRun(NamedTuple):
    outcome: str  # passed | collided (SUMO saw the ego collide) | not_past (time ran out)
    time_s: float  # when it passed, collided, or the duration
    slowest_mps: float  # the lowest speed it drove at


def sumo_drives(spec: ScenarioSpec, cache_dir: Path | None = None) -> SumoDriverRun:
    """Run ``spec`` (the sumo backend) with SUMO's driver as the ego, up to its
    duration: passed once its rear bumper is past the far end of every obstacle
    that stands ahead of its start along the road."""
    road = make_road(spec, cache_dir)
    vehicle = Vehicle(VEHICLE_MODELS[spec.vehicle.model], spec.vehicle.friction_mu)
    length_m = vehicle.model.length_m
    ends_m = [road.place_s_m(o.position_m, o.size_m[0]) + o.size_m[0] / 2
              for o in spec.obstacles if o.position_m > spec.ego.start_m]
    state = initial_state(spec, road, vehicle)
    slowest_mps, t_s = spec.ego.speed_mps, 0.0
    front_s_m = spec.ego.start_m + length_m / 2  # followed along the road, step by step
    with make_world(spec, road, cache_dir) as world:
        world.start(vehicle.body_box(state), state.speed_mps)
        world.hand_ego_to_sumo(spec.ego.speed_mps)
        for k in range(round(spec.scenario.duration_s / spec.scenario.step_s)):
            x_m, y_m, speed_mps, collided = world.step_sumo_ego()
            t_s = (k + 1) * spec.scenario.step_s
            if collided:
                return SumoDriverRun(COLLIDED, t_s, slowest_mps)
            slowest_mps = min(slowest_mps, speed_mps)
            front_s_m = road.locate_near(x_m, y_m, front_s_m)[0]
            if all(front_s_m - length_m >= end for end in ends_m):
                return SumoDriverRun(PASSED, t_s, slowest_mps)
    return SumoDriverRun(NOT_PAST, t_s, slowest_mps)
