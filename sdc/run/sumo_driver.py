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

from scenarios.scene.road_geometry import RoadGeometry
from scenarios.scene.snapshot import Pose, Snapshot
from scenarios.spec.bodies import VEHICLE_MODELS
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.world_backends import WitnessWorld, make_road, make_world
from sdc.car.vehicle import Vehicle
from sdc.run.episode import initial_state
from sdc.run.world_loop import run_alone

PASSED, COLLIDED, NOT_PAST = "passed", "collided", "not_past"


class SumoDriverRun(NamedTuple):
    outcome: str  # passed | collided (SUMO saw the ego collide) | not_past (time ran out)
    time_s: float  # when it passed, collided, or the duration
    slowest_mps: float  # the lowest speed it drove at


class _SumoDrives:
    """The driver of the ego's slot (:class:`sdc.run.world_loop.Driver`) that hands the
    ego to SUMO's driver at the first step and watches it: passed once its rear
    bumper is past the far end of every obstacle that stands ahead of its start along
    the road."""

    def __init__(self, spec: ScenarioSpec, road: RoadGeometry, world: WitnessWorld):
        self.spec, self.road, self.world = spec, road, world
        self.vehicle = Vehicle(VEHICLE_MODELS[spec.vehicle.model], spec.vehicle.friction_mu)
        self.ends_m = [road.place_s_m(o.position_m, o.size_m[0]) + o.size_m[0] / 2
                       for o in spec.obstacles if o.position_m > spec.ego.start_m]
        self.n_steps = round(spec.scenario.duration_s / spec.scenario.step_s)
        self.k, self.time_s, self.slowest_mps = 0, 0.0, spec.ego.speed_mps
        # followed along the road, step by step
        self.front_s_m = spec.ego.start_m + self.vehicle.model.length_m / 2
        self.end: str | None = None

    def place(self) -> Pose:
        state = initial_state(self.spec, self.road, self.vehicle)
        return self.vehicle.body_box(state), state.speed_mps

    def begin(self, snapshot: Snapshot) -> None:
        pass

    def wants_more(self) -> bool:
        return True  # until it ends

    def turn(self) -> None:
        if self.k:
            self._watch()
        if self.end is None and self.k == self.n_steps:
            self.end = NOT_PAST
        elif self.k == 0:
            self.world.hand_ego_to_sumo(0, self.spec.ego.speed_mps)
        return None  # SUMO's driver moves it

    def _watch(self) -> None:
        x_m, y_m, speed_mps, collided = self.world.sumo_ego(0)
        self.time_s = self.k * self.spec.scenario.step_s
        if collided:
            self.end = COLLIDED
            return
        self.slowest_mps = min(self.slowest_mps, speed_mps)
        self.front_s_m = self.road.locate_near(x_m, y_m, self.front_s_m)[0]
        length_m = self.vehicle.model.length_m
        if all(self.front_s_m - length_m >= end for end in self.ends_m):
            self.end = PASSED

    def arrive(self, snapshot: Snapshot) -> None:
        self.k += 1


def sumo_drives(spec: ScenarioSpec, cache_dir: Path | None = None) -> SumoDriverRun:
    """Run ``spec`` (the sumo backend) with SUMO's driver as the ego, up to its
    duration: passed once its rear bumper is past the far end of every obstacle
    that stands ahead of its start along the road."""
    road = make_road(spec, cache_dir)
    with make_world(spec, road, cache_dir) as world:
        driver = _SumoDrives(spec, road, world)
        outcome = run_alone(world, driver)
    return SumoDriverRun(outcome, driver.time_s, driver.slowest_mps)
