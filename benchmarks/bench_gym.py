"""Steps per second of our gymnasium environment against highway-env's highway-v0.

Prints ``name value`` lines. ``gym_speedup_vs_highway_v0`` is the steps/s of
``sdc/ObstacleAvoidance-v0`` on SUMO (a 3-lane highway with background traffic,
180-beam lidar) over highway-v0's with a 180-cell ``LidarObservation`` and
``ContinuousAction``, one simulation step per env step, with as many vehicles
as our scene held on average while timed. ``gym_highway_backend_vs_highway_v0``
is the same for our env on the highway-env backend.

``SDC_BENCH_SMOKE=1``: the smoke size (benchmarks/smoke.py): 20 warm-up and 20 timed
steps of each.
"""

from __future__ import annotations

import statistics
import time
import warnings

import gymnasium
import numpy as np
from smoke import size

import sdc.gym  # noqa: F401  (registers the environment)
from scenarios import CATALOG_DIR
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.spec.toml_io import read_toml

WARM_UP_STEPS, TIMED_STEPS, HIGHWAY_V0_STEPS = size(700, 20), size(400, 20), size(150, 20)


def scene_spec(backend: str) -> ScenarioSpec:
    """highway-obstacle without the obstacle, long enough to drive straight through."""
    plain = read_toml(CATALOG_DIR / "highway-obstacle.toml")
    plain["road"]["length_m"] = 2500.0
    plain["obstacles"] = []
    plain["ego"].update(lane=1, speed_mps=20.0)
    plain["scenario"].update(duration_s=120.0, backend=backend)
    return ScenarioSpec.from_plain(plain)


def ours(backend: str) -> tuple[float, float]:
    """(steps/s, mean number of other vehicles) while timed."""
    env = gymnasium.make("sdc/ObstacleAvoidance-v0", spec=scene_spec(backend))
    env.reset(seed=1)
    straight = np.zeros(2, np.float32)
    for _ in range(WARM_UP_STEPS):  # let the traffic fill the road
        env.step(straight)
    counts = []
    start = time.perf_counter()
    for _ in range(TIMED_STEPS):
        _, _, terminated, truncated, _ = env.step(straight)
        counts.append(env.unwrapped._world.vehicle_count())
        assert not (terminated or truncated)
    elapsed = time.perf_counter() - start
    env.close()
    return TIMED_STEPS / elapsed, statistics.mean(counts)


def highway_v0(vehicles: int) -> float:
    import highway_env  # noqa: F401  (registers highway-v0)

    config = {
        "observation": {"type": "LidarObservation", "cells": 180, "maximum_range": 80},
        "action": {"type": "ContinuousAction"},
        "vehicles_count": vehicles, "lanes_count": 3, "duration": 10_000,
        "simulation_frequency": 15, "policy_frequency": 15,
    }
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        env = gymnasium.make("highway-v0", config=config)
        env.reset(seed=1)
        straight = np.zeros(2, np.float32)
        start = time.perf_counter()
        for _ in range(HIGHWAY_V0_STEPS):
            _, _, terminated, truncated, _ = env.step(straight)
            if terminated or truncated:
                env.reset()
        elapsed = time.perf_counter() - start
        env.close()
    return HIGHWAY_V0_STEPS / elapsed


def main() -> None:
    sumo_rate, vehicles = ours("sumo")
    highway_rate, highway_vehicles = ours("highway")
    reference = highway_v0(round(vehicles))
    print(f"gym_speedup_vs_highway_v0 {sumo_rate / reference:.2f}")
    print(f"gym_highway_backend_vs_highway_v0 {highway_rate / reference:.2f}")
    print(f"raw.ours_sumo_steps_per_s {sumo_rate:.1f}")
    print(f"raw.ours_highway_backend_steps_per_s {highway_rate:.1f}")
    print(f"raw.highway_v0_steps_per_s {reference:.1f}")
    print(f"raw.vehicles_sumo {vehicles:.1f}")
    print(f"raw.vehicles_highway_backend {highway_vehicles:.1f}")


if __name__ == "__main__":
    main()
