"""The car's cost against SUMO's and highway-env's, as ratios measured in one run.

Prints ``name value`` lines (medians of REPETITIONS paired measurements; of
SHORT_PAIRS for the 100-vehicle overhead, whose runs take a second: this
machine's speed swings between seconds), then the raw timings:

- ``overhead_vs_bare_sumo``: a full closed-loop step (SUMO step, state read,
  lidar, lane offset, control, collision check, ego push) over the bare SUMO
  step, on a 3-lane highway holding about 100 vehicles (traffic warmed up). Bare:
  the same scenario in SUMO alone, measured right after the loop: the ego is a
  SUMO vehicle driving on in its lane at its speed, neither pushed nor
  subscribed to. Traffic changing lanes around that slow car is half of SUMO's
  step, so taking the ego out (``raw.overhead_vs_sumo_without_ego``) measures
  another scenario; ``raw.overhead_vs_sumo_in_loop`` divides by SUMO's step
  inside our loop instead (``libsumo.simulationStep`` alone), and
  ``raw.sumo_in_loop_vs_bare_sumo`` is that step over the bare one: what the context
  subscription and the pushed ego add to SUMO's own step. ``raw.added_ms_100`` is the
  step less the bare step [ms]: the cost the car adds, whatever SUMO's own step costs
  (a traffic model that makes SUMO's step cheaper raises the ratio, not this).
- ``agent_cost_ratio_2000_vs_100``: the agent's own cost per step (everything
  but ``libsumo.simulationStep``) on a 6-lane road
  18 km long holding about 2000 vehicles over its cost on one 900 m long holding
  about 100, at the same traffic density around the ego; traffic is read only
  within the sensing radius.
- ``speedup_vs_highway_env``: our closed-loop steps/s on a 3-lane highway with
  about 20 vehicles over highway-env's (``highway-v0``, 3 lanes, as many
  vehicles, 180-cell LidarObservation, ContinuousAction, one simulation step
  per env step at our step length).
- ``lidar_speedup_vs_highway_env``: a 180-beam, 360-degree scan of 50 boxes in
  range, ours over highway-env's ``LidarObservation.trace`` on the same boxes.

``agent_cost_ratio_2000_vs_100_cold_caches`` is its control: the 100-vehicle
loop again, with every SUMO step followed by a read of 64 MB. A 2000-vehicle
SUMO step sweeps the CPU caches, and the agent's first reads after it miss them;
the control gives the small road the same cold caches, so the ratio shows
whether the agent's own work grows with the network.

The raw timings add:

- ``libsumo_only_ms_100``: a loop doing only the world's part of a closed loop
  (push the ego, step, read the traffic around it), and
  ``libsumo_only_vs_bare_sumo``, its ratio to the bare step: the floor under
  ``overhead_vs_bare_sumo`` whatever the agent's own code costs;
  ``overhead_vs_libsumo_only`` is our step over it;
- ``kernels_only_ms_100``: a loop of only the world step and the compiled calls
  of a step (lidar scan, lane lookups, contacts) back to back, and
  ``kernels_only_vs_bare_sumo``: what ``overhead_vs_bare_sumo`` would be, at
  least, were the whole car's side compiled;
- ``town_2000``: the catalog's ``grid-town`` (a SUMO network of 10 x 10
  junctions, 2000 cars) under lane keeping, where the road edges come from the
  network's drivable area.

``SDC_BENCH_SMOKE=1``: the smoke size (benchmarks/smoke.py): one measurement of each,
20 timed steps, warm-ups of at most 10 s and a town of 100 cars (:func:`town_spec`).
"""

from __future__ import annotations

import math
import statistics
import time
import types
import warnings

import numpy as np
import traci.constants as tc
from smoke import SMOKE, size

from scenarios import CATALOG_DIR
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.spec.scenario_tables import LidarSpec
from scenarios.spec.toml_io import load_spec, read_toml
from scenarios.sumo.routes_xml import EGO_ID
from scenarios.world_backends import make_road, make_world
from sdc.car.controller_plugins import make_controller
from sdc.car.sensors import Lidar
from sdc.run.episode import Simulation
from sdc.run.world_loop import Failed, WorldLoop

REPETITIONS = size(3, 1)
SHORT_PAIRS = size(9, 1)
#: memory read after each SUMO step of the cold-cache control: more than the CPU caches
CACHE_WALK_BYTES = 64 << 20
TIMED_STEPS = size(400, 20)
#: the smoke size's longest warm-up [s]
SMOKE_WARM_UP_S = 10.0


def traffic_spec(lanes: int, length_m: float, flow_vph: float, warm_up_s: float,
                 start_m: float | None = None) -> ScenarioSpec:
    """A straight highway filled with traffic; the ego (from ``start_m``, default
    mid-road) drives slower than all of it."""
    plain = read_toml(CATALOG_DIR / "highway-obstacle.toml")
    plain["road"].update(lanes=lanes, length_m=length_m)
    plain["obstacles"] = []
    plain["traffic"] = {"flow_vph_per_lane": flow_vph, "speed_mean_mps": 25.0,
                        "warm_up_s": size(warm_up_s, min(warm_up_s, SMOKE_WARM_UP_S))}
    plain["ego"].update(lane=1, speed_mps=18.0,
                        start_m=length_m / 2 if start_m is None else start_m)
    plain["scenario"].update(duration_s=TIMED_STEPS * plain["scenario"]["step_s"] + 1.0)
    plain["controller"] = {"name": "lane-keep"}
    return ScenarioSpec.from_plain(plain)


def alone(spec: ScenarioSpec, world, controller=None,
          look_ahead_m: float | None = None) -> tuple[Simulation, WorldLoop]:
    """A run of ``spec`` under ``controller`` alone in ``world``, started (the world's
    first answer sensed): the run, and the loop that steps every run's world
    (``sdc.run.world_loop``)."""
    sim = Simulation(spec, world, look_ahead_m, controller=controller)
    loop = WorldLoop(world, [sim])
    loop.start()
    return sim, loop


def ended(loop: WorldLoop) -> bool:
    """One closed-loop step of the run alone in ``loop`` (it senses, decides, is
    recorded and checked, moves; the world steps): whether the run ended at it (a run
    that raised raises again)."""
    loop.step()
    if loop.ends and isinstance(loop.ends[0], Failed):
        raise loop.ends[0].exception
    return bool(loop.ends)


def closed_loop(spec: ScenarioSpec, cache_walk: np.ndarray | None = None) -> dict:
    """Medians over the timed steps of a step's wall time, of the SUMO step inside
    it, and of their difference, the agent's own cost [ms] (medians: this machine's
    occasional stalls hit single steps). With ``cache_walk``, every SUMO step also
    reads that array, as a big network's step sweeps the CPU caches."""
    controller = make_controller(spec.controller)
    road = make_road(spec)
    import libsumo

    sumo_s = []
    sumo_step = libsumo.simulationStep

    def timed_step(*args):
        start = time.perf_counter()
        sumo_step(*args)
        if cache_walk is not None:
            cache_walk.sum()
        sumo_s.append(time.perf_counter() - start)

    steps_s = []
    with make_world(spec, road) as world:
        _, loop = alone(spec, world, controller)
        vehicles = world.vehicle_count()
        libsumo.simulationStep = timed_step  # the world calls it through the module
        try:
            sumo_s.clear()
            for _ in range(TIMED_STEPS):
                start = time.perf_counter()
                if ended(loop):
                    break
                steps_s.append(time.perf_counter() - start)
        finally:
            libsumo.simulationStep = sumo_step
    step_s, sumo_step_s = np.array(steps_s), np.array(sumo_s[: len(steps_s)])
    return {"step_ms": 1e3 * np.median(step_s), "sumo_ms": 1e3 * np.median(sumo_step_s),
            "agent_ms": 1e3 * np.median(step_s - sumo_step_s), "vehicles": vehicles,
            "steps": len(step_s)}


def bare_sumo_ms(spec: ScenarioSpec, ego: bool = True) -> float:
    """Median SUMO step [ms] of the scenario in SUMO alone: no push, no subscription;
    the ego stays as a SUMO vehicle driving on in its lane at its speed, so traffic
    meets the same slow car (lane changing around it is half of SUMO's step here).
    Without ``ego``, the ego is taken out as well."""
    import libsumo

    road = make_road(spec)
    with make_world(spec, road) as world:
        alone(spec, world, look_ahead_m=0.0)
        slot = world._slots[0]  # the ego's context subscription
        libsumo.vehicle.unsubscribeContext(EGO_ID, tc.CMD_GET_VEHICLE_VARIABLE,
                                           slot.subscribed_m)
        if slot.people_subscribed:
            libsumo.vehicle.unsubscribeContext(EGO_ID, tc.CMD_GET_PERSON_VARIABLE,
                                               slot.subscribed_m)
        if ego:  # its speed mode and lane change mode stay off: it keeps speed and lane
            libsumo.vehicle.setSpeed(EGO_ID, spec.ego.speed_mps)
        else:
            libsumo.vehicle.remove(EGO_ID)
        steps_s = []
        for _ in range(TIMED_STEPS):
            start = time.perf_counter()
            libsumo.simulationStep()
            steps_s.append(time.perf_counter() - start)
        if ego:
            assert libsumo.vehicle.getLaneIndex(EGO_ID) == spec.ego.lane
    return 1e3 * float(np.median(steps_s))


def world_loop_ms(spec: ScenarioSpec, sense: bool = False) -> float:
    """Median step [ms] of a loop that does only the world's part of a closed loop
    (``SumoWorld.step``: push the ego, driving straight on, step SUMO, read the
    traffic around it), without sensing or control. With ``sense``, also the
    compiled calls of sensing, back to back: the lidar scan, the lane sensor's two
    road lookups, the contacts and the conflicts along the road (still no controller,
    trace row or end checks);
    however much of the loop were compiled, a step costs at least this."""
    road = make_road(spec)
    with make_world(spec, road) as world:
        sim, _ = alone(spec, world, look_ahead_m=0.0)
        box, step_m = sim.box.copy(), spec.ego.speed_mps * spec.scenario.step_s
        look_ahead_m, lidar_ahead_m = 5.0, spec.lidar.mount_ahead_m
        steps_s = []
        for _ in range(TIMED_STEPS):
            start = time.perf_counter()
            box[0] += step_m * math.cos(box[2])
            box[1] += step_m * math.sin(box[2])
            snapshot = world.step(box, spec.ego.speed_mps)
            if sense:
                cos_yaw, sin_yaw = math.cos(box[2]), math.sin(box[2])
                sim.lidar.scan((box[0] + lidar_ahead_m * cos_yaw,
                                box[1] + lidar_ahead_m * sin_yaw),
                               box[2], snapshot.obstacle_boxes, snapshot.traffic_boxes)
                road.locate(box[0], box[1])
                road.locate(box[0] + look_ahead_m * cos_yaw, box[1] + look_ahead_m * sin_yaw)
                sim.road_frame.measure(box, spec.ego.speed_mps, snapshot)
            steps_s.append(time.perf_counter() - start)
    return 1e3 * float(np.median(steps_s))


def town_spec() -> ScenarioSpec:
    """The catalog's town of 10 x 10 junctions with 2000 cars, lane keeping, no obstacle."""
    plain = load_spec(CATALOG_DIR / "grid-town.toml").to_plain()
    plain.pop("obstacles")
    plain["controller"] = {"name": "lane-keep"}
    if SMOKE:  # 100 cars, briefly warmed up: the full town's warm-up takes minutes
        plain["traffic"].update(vehicles=100, warm_up_s=SMOKE_WARM_UP_S)
    return ScenarioSpec.from_plain(plain)


def median_of(runs: list[dict], key: str) -> float:
    return statistics.median(run[key] for run in runs)


def highway_v0_steps_per_s(vehicles: int, step_s: float, steps: int = size(150, 20)) -> float:
    import gymnasium
    import highway_env  # noqa: F401  (registers highway-v0)

    frequency = round(1 / step_s)
    config = {"observation": {"type": "LidarObservation", "cells": 180, "maximum_range": 80},
              "action": {"type": "ContinuousAction"}, "vehicles_count": vehicles,
              "lanes_count": 3, "duration": 10_000, "simulation_frequency": frequency,
              "policy_frequency": frequency}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        env = gymnasium.make("highway-v0", config=config)
        env.reset(seed=1)
        start = time.perf_counter()
        for _ in range(steps):
            _, _, terminated, truncated, _ = env.step(np.zeros(2, np.float32))
            if terminated or truncated:
                env.reset()
        elapsed = time.perf_counter() - start
        env.close()
    return steps / elapsed


def lidar_scene(n: int = 50) -> np.ndarray:
    """``n`` car boxes within 80 m around the origin, none on it."""
    rng = np.random.default_rng(3)
    x = rng.uniform(-70, 70, n)
    y = rng.choice([-7.0, -3.5, 3.5, 7.0], n) + rng.normal(0, 0.2, n)
    return np.column_stack([x, y, rng.normal(0, 0.05, n), np.full(n, 5.0), np.full(n, 2.0)])


def lidar_ratio(repeats: int = size(200, 10)) -> tuple[float, float]:
    """(our scan [ms], highway-env's trace [ms]) on the same 50 boxes."""
    from highway_env.envs.common.observation import LidarObservation
    from highway_env.road.lane import StraightLane
    from highway_env.road.road import Road, RoadNetwork
    from highway_env.vehicle.kinematics import Vehicle

    boxes = lidar_scene()
    ours = Lidar(LidarSpec(beams=180, fov_deg=360.0, max_range_m=80.0), np.zeros((0, 4)),
                 np.random.default_rng(0))
    network = RoadNetwork()
    network.add_lane("a", "b", StraightLane([-100.0, 0.0], [100.0, 0.0]))
    road = Road(network)
    ego = Vehicle(road, [0.0, 0.0])
    road.vehicles = [ego] + [Vehicle(road, b[:2], heading=b[2]) for b in boxes]
    env = types.SimpleNamespace(road=road, vehicle=ego)  # what LidarObservation reads
    theirs = LidarObservation(env, cells=180, maximum_range=80.0)
    origin = np.zeros(2)

    def timed(call) -> float:
        call()
        start = time.perf_counter()
        for _ in range(repeats):
            call()
        return 1e3 * (time.perf_counter() - start) / repeats

    ours_ms = timed(lambda: ours.scan(origin, 0.0, boxes))
    theirs_ms = timed(lambda: theirs.trace(origin, np.zeros(2)))
    return ours_ms, theirs_ms


def main() -> None:
    """Each ratio pairs measurements taken one right after the other, and the median
    of those paired ratios is printed: this machine's speed drifts between minutes."""
    hundred, bare, without_ego, floor, kernels = [], [], [], [], []
    for _ in range(SHORT_PAIRS):
        spec = traffic_spec(3, 2500.0, 1100.0, 120.0)
        hundred.append(closed_loop(spec))
        bare.append(bare_sumo_ms(spec))
        without_ego.append(bare_sumo_ms(spec, ego=False))
        floor.append(world_loop_ms(spec))
        kernels.append(world_loop_ms(spec, sense=True))
    short, two_thousand, short_cold = [], [], []
    walk = np.ones(CACHE_WALK_BYTES // 8)
    for _ in range(REPETITIONS):  # each pair waits on a 2000-vehicle warm-up (6 lanes x 18 km)
        short.append(closed_loop(traffic_spec(6, 900.0, 1800.0, 60.0, start_m=200.0)))
        two_thousand.append(closed_loop(traffic_spec(6, 18000.0, 1800.0, 690.0)))
        short_cold.append(closed_loop(traffic_spec(6, 900.0, 1800.0, 60.0, start_m=200.0),
                                      walk))
    step_s = traffic_spec(3, 2500.0, 240.0, 0.0).scenario.step_s
    twenty, reference = [], []
    for _ in range(REPETITIONS):
        twenty.append(closed_loop(traffic_spec(3, 2500.0, 240.0, 100.0)))
        reference.append(highway_v0_steps_per_s(twenty[-1]["vehicles"], step_s))
    town = [closed_loop(town_spec())]
    lidar = [lidar_ratio() for _ in range(REPETITIONS)]

    def paired(ratios) -> float:
        return statistics.median(list(ratios))

    def agent_ratios(small_runs) -> list[float]:
        return [b["agent_ms"] / a["agent_ms"]
                for a, b in zip(small_runs, two_thousand, strict=True)]

    speedups = [1e3 / r["step_ms"] / h for r, h in zip(twenty, reference, strict=True)]
    overheads = [r["step_ms"] / b for r, b in zip(hundred, bare, strict=True)]
    print(f"overhead_vs_bare_sumo {paired(overheads):.2f}")
    print(f"agent_cost_ratio_2000_vs_100 {paired(agent_ratios(short)):.2f}")
    print(f"agent_cost_ratio_2000_vs_100_cold_caches {paired(agent_ratios(short_cold)):.2f}")
    print(f"speedup_vs_highway_env {paired(speedups):.2f}")
    print(f"lidar_speedup_vs_highway_env {paired(theirs / ours for ours, theirs in lidar):.2f}")
    for name, runs in (("100", hundred), ("100_6_lanes", short),
                       ("100_6_lanes_cold_caches", short_cold), ("2000_6_lanes", two_thousand),
                       ("20", twenty), ("town_2000", town)):
        for key in ("vehicles", "steps", "step_ms", "sumo_ms", "agent_ms"):
            print(f"raw.{key}_{name} {median_of(runs, key):.3f}")
    print(f"raw.bare_sumo_ms_100 {statistics.median(bare):.3f}")
    print(f"raw.bare_sumo_without_ego_ms_100 {statistics.median(without_ego):.3f}")
    alone = [r["step_ms"] / b for r, b in zip(hundred, without_ego, strict=True)]
    print(f"raw.overhead_vs_sumo_without_ego {paired(alone):.2f}")
    in_loop = paired(r["step_ms"] / r["sumo_ms"] for r in hundred)
    print(f"raw.overhead_vs_sumo_in_loop {in_loop:.2f}")
    sumo_share = paired(r["sumo_ms"] / b for r, b in zip(hundred, bare, strict=True))
    print(f"raw.sumo_in_loop_vs_bare_sumo {sumo_share:.2f}")
    added_ms = paired(r["step_ms"] - b for r, b in zip(hundred, bare, strict=True))
    print(f"raw.added_ms_100 {added_ms:.3f}")
    print(f"raw.libsumo_only_ms_100 {statistics.median(floor):.3f}")
    floors = [f / b for f, b in zip(floor, bare, strict=True)]
    print(f"raw.libsumo_only_vs_bare_sumo {paired(floors):.2f}")
    over_floor = [r["step_ms"] / f for r, f in zip(hundred, floor, strict=True)]
    print(f"raw.overhead_vs_libsumo_only {paired(over_floor):.2f}")
    print(f"raw.kernels_only_ms_100 {statistics.median(kernels):.3f}")
    compiled = [k / b for k, b in zip(kernels, bare, strict=True)]
    print(f"raw.kernels_only_vs_bare_sumo {paired(compiled):.2f}")
    print(f"raw.highway_v0_steps_per_s {statistics.median(reference):.1f}")
    print(f"raw.lidar_ms_ours {statistics.median(o for o, _ in lidar):.3f}")
    print(f"raw.lidar_ms_highway_env {statistics.median(t for _, t in lidar):.3f}")


if __name__ == "__main__":
    main()
