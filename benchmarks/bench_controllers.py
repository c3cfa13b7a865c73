"""Controllers' own cost per step, and what the plug-in protocol adds to it.

Prints ``name value`` lines, medians over REPETITIONS rounds of per-call times
[microseconds], measured in one process on the observations of real runs:

- ``<controller>_us_per_step``: ``step(obs)`` alone, replayed over the
  observations recorded along a run of highway-obstacle (3 lanes, traffic, a
  broken-down car ahead), for each built-in controller;
- ``protocol_us_per_step``: what ``Simulation.decide`` adds around a
  controller's ``step`` (building the ``Observation``, checking the returned
  ``Command``, reading the phase), measured with a controller whose step does
  nothing but return a constant command;
- ``plugin_minus_builtin_us_per_step``: ``Simulation.decide`` with lane keeping
  loaded as a file plug-in (``sdc/car/controllers.py:LaneKeepController``) minus
  the same with the built-in ``lane-keep``: a plug-in's call goes through the
  same code, so this is noise around zero.

``SDC_BENCH_SMOKE=1``: the smoke size (benchmarks/smoke.py): one round of 100 calls.
"""

from __future__ import annotations

import statistics
import time
from pathlib import Path

import numpy as np
from smoke import size

from scenarios import CATALOG_DIR
from scenarios.spec.controller_ref import BUILTIN_CONTROLLERS
from scenarios.spec.toml_io import load_spec
from scenarios.world_backends import make_road, make_world
from sdc.car.controller_api import Command
from sdc.car.controller_plugins import make_controller
from sdc.run.episode import Simulation
from sdc.run.world_loop import Failed, WorldLoop

REPETITIONS = size(5, 1)
CALLS = size(2000, 100)
CONTROLLERS_PY = Path(__file__).resolve().parent.parent / "sdc" / "car" / "controllers.py"


class Constant:
    """A controller that only answers: the floor of any controller's call."""

    phase = "lane_keep"

    def step(self, obs) -> Command:
        return Command(0.0)


def recorded_observations(name: str) -> list:
    """The observations a run of highway-obstacle under ``name`` saw, step by step."""
    spec = load_spec(CATALOG_DIR / "highway-obstacle.toml").with_controller(name)
    seen = []
    with make_world(spec, make_road(spec)) as world:
        sim = Simulation(spec, world, controller=make_controller(spec.controller))
        loop = WorldLoop(world, [sim])
        loop.start()
        while not loop.ends:
            seen.append(sim.observation())
            loop.step()
    if isinstance(loop.ends[0], Failed):
        raise loop.ends[0].exception
    return seen


def step_us(name: str, observations: list) -> float:
    """Median over rounds of the mean time of ``step(obs)`` along the run [us]."""
    spec = load_spec(CATALOG_DIR / "highway-obstacle.toml").with_controller(name)
    rounds = []
    for _ in range(REPETITIONS):
        controller = make_controller(spec.controller)
        start = time.perf_counter()
        for obs in observations:
            controller.step(obs)
        rounds.append((time.perf_counter() - start) / len(observations))
    return 1e6 * statistics.median(rounds)


def call_us(call) -> float:
    """Median over rounds of the mean time of ``call()`` over CALLS calls [us]."""
    rounds = []
    for _ in range(REPETITIONS):
        start = time.perf_counter()
        for _ in range(CALLS):
            call()
        rounds.append((time.perf_counter() - start) / CALLS)
    return 1e6 * statistics.median(rounds)


def decide_us(sim: Simulation, controller) -> float:
    """``sim.decide(controller)``: the controller's step inside the protocol [us]."""
    return call_us(lambda: sim.decide(controller))


def bare_us(sim: Simulation, controller) -> float:
    """``controller.step`` alone, on an observation made beforehand [us]."""
    obs = sim.observation()
    return call_us(lambda: controller.step(obs))


def main() -> None:
    for name in BUILTIN_CONTROLLERS:
        observations = recorded_observations(name)
        print(f"{name.replace('-', '_')}_us_per_step {step_us(name, observations):.2f}")
    spec = load_spec(CATALOG_DIR / "highway-obstacle.toml").with_controller("lane-keep")
    plugin = make_controller(spec.with_controller(
        f"{CONTROLLERS_PY}:LaneKeepController").controller)
    builtin = make_controller(spec.controller)
    with make_world(spec, make_road(spec)) as world:
        sim = Simulation(spec, world)
        WorldLoop(world, [sim]).start()
        protocol = np.median([decide_us(sim, Constant()) - bare_us(sim, Constant())
                              for _ in range(3)])
        difference = np.median([decide_us(sim, plugin) - decide_us(sim, builtin)
                                for _ in range(3)])
    print(f"protocol_us_per_step {protocol:.2f}")
    print(f"plugin_minus_builtin_us_per_step {difference:.2f}")


if __name__ == "__main__":
    main()
