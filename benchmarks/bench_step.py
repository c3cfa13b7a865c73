"""Step cost of the closed loop against the bare SUMO step, in one process run.

Prints ``name value`` lines. ``overhead_vs_bare_sumo`` is a full closed-loop
step (SUMO step + state read + lidar + lane offset + control + collision check
+ ego push) over a bare SUMO step of the same scenario for the same number of
steps; ``agent_share_vs_bare_sumo`` is the agent's own part (everything but
the SUMO step) over the bare SUMO step. Medians of several repetitions.
"""

from __future__ import annotations

import dataclasses
import statistics
import sys
import tempfile
import time
from pathlib import Path

from scenarios import CATALOG_DIR, load_spec
from scenarios.network import build_network
from scenarios.spec import ScenarioSpec
from scenarios.sumo_world import routes_xml
from sdc.episode import run_episode

REPETITIONS = 5


def bare_sumo_s(spec: ScenarioSpec, steps: int) -> float:
    """Wall time of ``steps`` SUMO steps of the scenario's network and traffic, nothing else."""
    import libsumo

    net = build_network(spec.road)
    with tempfile.TemporaryDirectory() as tmp:
        routes = Path(tmp) / "r.rou.xml"
        routes.write_text(routes_xml(spec))
        libsumo.start(["sumo", "--net-file", str(net), "--route-files", str(routes),
                       "--step-length", repr(spec.scenario.step_s),
                       "--seed", str(spec.scenario.seed), "--no-step-log", "true",
                       "--collision.action", "none", "--time-to-teleport", "-1"])
        start = time.perf_counter()
        for _ in range(steps):
            libsumo.simulationStep()
        elapsed = time.perf_counter() - start
        libsumo.close()
    return elapsed


def closed_loop_s(spec: ScenarioSpec) -> tuple[float, int]:
    """Wall time of a full run's steps (less the start-up, timed on a one-step run)."""
    one_step = dataclasses.replace(
        spec, scenario=dataclasses.replace(spec.scenario, duration_s=spec.scenario.step_s))
    start = time.perf_counter()
    run_episode(one_step)
    setup_s = time.perf_counter() - start
    start = time.perf_counter()
    row = run_episode(spec).row
    # a run of n rows advances SUMO n - 1 times; the one-step run's single advance is
    # subtracted with its start-up, leaving n - 2 timed steps
    return time.perf_counter() - start - setup_s, row["steps"] - 2


def main(name: str = "highway-obstacle") -> None:
    spec = load_spec(CATALOG_DIR / f"{name}.toml")
    run_episode(spec)  # warm up: imports, network cache
    full, bare = [], []
    for _ in range(REPETITIONS):
        wall_s, steps = closed_loop_s(spec)
        full.append(wall_s / steps)
        bare.append(bare_sumo_s(spec, steps) / steps)
    full_ms, bare_ms = statistics.median(full) * 1e3, statistics.median(bare) * 1e3
    print(f"# scenario {name}, {steps} steps, median of {REPETITIONS}")
    print(f"closed_loop_step_ms {full_ms:.4f}")
    print(f"bare_sumo_step_ms {bare_ms:.4f}")
    print(f"overhead_vs_bare_sumo {full_ms / bare_ms:.2f}")
    print(f"agent_share_vs_bare_sumo {(full_ms - bare_ms) / bare_ms:.2f}")


if __name__ == "__main__":
    main(*sys.argv[1:])
