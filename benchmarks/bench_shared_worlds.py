"""Several egos in one world: runs per hour by egos per world, and the world's step.

Runs per hour of a town sweep and of a real configuration's by egos per world, and
the step of a world holding K egos against SUMO's own, as ratios measured in one
process run.

The sweeps, on 2 local workers, traces off (:data:`FAMILIES`):

- ``town``: the catalog's grid-town (10 x 10 junctions, 2000 cars, 400 s of warm-up,
  each sample its own warm state unless it shares a world), the obstacle's position
  swept, under ``seed``;
- ``real``: SUMO's Ingolstadt (tools/game/fkk_in.sumocfg, its own demand entered at
  120 s, each sample its own entry unless it shares a world), the ego's speed swept,
  under ``lane-keep``.

Prints ``name value`` lines:

- ``<family>_runs_per_hour_k<K>_vs_k1``: runs per hour of the sweep with
  ``egos_per_world = K`` over the same sweep with one ego a world, each on a cold
  cache (a world computes its warm state in the sweep, one for its K runs).
- ``<family>_runs_per_hour_cached_k<K>_vs_k1``: the same on the filled cache (no
  warm-up left to compute): what sharing SUMO's step alone buys.
- ``raw.<family>_egos_per_step_k<K>``: how many egos a SUMO step of the sweep's worlds
  carried on average (the report's figure: the placement rule may seat fewer than K).
  A world serves ``max(K, samples / workers)`` runs (``runs_per_world``), so every
  worker has a world while there are runs for it.
- ``town_world_step_vs_bare_sumo_k<K>``: the median step of one world holding K egos
  (each sensing, deciding under lane-keep, checked, pushed; then SUMO's one step),
  over SUMO's own step of the same town without an ego (the floor: what the world
  costs were our egos free); ``town_ego_step_vs_bare_sumo_k<K>``: that step shared
  by its K egos, over the floor (below 1: a run's step costs less than SUMO's own).
  The K egos are the first seeds the placement rule seats in one world
  (``raw.town_seated_k<K>`` of them, when the town holds fewer).

``python benchmarks/bench_shared_worlds.py [--family town|real] [--steps] [K ...]``
measures those K only (and 1), those families' sweeps, or the step alone.

A rate is runs over the sweep's wall time, which includes the sweep's own start (a
few seconds): the sweeps of one family run the same samples (:data:`SAMPLES`), so that
start weighs alike in each.

``SDC_BENCH_SMOKE=1``: the smoke size (benchmarks/smoke.py): 2 samples of 1 s runs on
1 worker, K of 1 and 2, a town of 20 cars warmed up 2 s and Ingolstadt entered at
10 s (:data:`SMOKE_PARAMS`), bench_perf's smoke size of timed steps.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import tempfile
import time
from pathlib import Path

import bench_perf
import numpy as np
from smoke import SMOKE, size

from scenarios import CATALOG_DIR
from scenarios.spec.sweep_spec import load_sweep
from scenarios.world_backends import make_road, make_shared_world
from sdc.batch.executors.local_executor import LocalExecutor
from sdc.batch.sweeps.progress import QuietReporter
from sdc.batch.sweeps.sweep_runner import run_sweep
from sdc.car.controller_plugins import make_controller
from sdc.run.episode import Simulation
from sdc.run.shared_world import Seats

#: the samples of every sweep
SAMPLES = size(16, 2)
#: the egos per world measured
EGOS_PER_WORLD = size((1, 4, 8, 16), (1, 2))
WORKERS = size(2, 1)
#: the smoke size's runs: shorter, their warm-ups too (the town 20 cars for 2 s)
SMOKE_PARAMS = {"town": ['"traffic.vehicles" = { choice = [20] }',
                         '"traffic.warm_up_s" = { choice = [2.0] }'],
                "real": ['"traffic.enter_s" = { choice = [10.0] }']}


#: each family's base, controller and swept parameters
FAMILIES = {
    "town": ("grid-town.toml", "seed",
             ['"obstacles[0].position_m" = { uniform = [40.0, 120.0] }']),
    "real": ("real-traffic.toml", "lane-keep",
             ['"road.config_file" = { choice = ["sumo:tools/game/fkk_in.sumocfg"] }',
              '"ego.speed_mps" = { uniform = [8.0, 14.0] }']),
}


def write_sweep(tmp: Path, family: str, samples: int, egos_per_world: int) -> Path:
    base, controller, params = FAMILIES[family]
    lines = ['[sweep]', 'name = "shared-worlds-bench"', f'base = "{CATALOG_DIR / base}"',
             f"samples = {samples}", "seed = 11", f'controllers = ["{controller}"]',
             f"egos_per_world = {egos_per_world}",
             *([f"runs_per_world = {max(egos_per_world, samples // WORKERS)}"]
               if egos_per_world > 1 else []),
             "[sweep.params]", *params]
    if SMOKE:
        lines += ['"scenario.duration_s" = { choice = [1.0] }', *SMOKE_PARAMS[family]]
    path = tmp / f"{family}-{egos_per_world}.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


def runs_per_hour(sweep_file: Path, out_dir: Path) -> tuple[float, float]:
    """The sweep's runs per hour, and the egos a SUMO step of its worlds carried."""
    start = time.perf_counter()
    outcome = run_sweep(load_sweep(sweep_file), out_dir, LocalExecutor(WORKERS),
                        QuietReporter(), traces="none")
    wall_s = time.perf_counter() - start
    assert outcome.counts["ok"] == outcome.runs, outcome.counts
    manifest = json.loads((out_dir / "manifest.json").read_text())
    return outcome.runs / wall_s * 3600, manifest.get("shared_worlds", {}).get(
        "egos_per_step", 1.0)


def seated_town(k: int, candidates: int = 400) -> list[tuple]:
    """Up to ``k`` town runs (lane-keep, no obstacle, one warm seed) that the placement
    rule seats in one world: the first seeds that fit, each a spec and its road."""
    base = bench_perf.town_spec()
    seated: list[tuple] = []
    for seed in range(1, candidates + 1):
        spec = base.with_seed(seed)
        spec = dataclasses.replace(spec, traffic=dataclasses.replace(spec.traffic,
                                                                     warm_seed=1))
        ego = (spec, make_road(spec))
        together = list(range(len(seated) + 1))
        if Seats([*seated, ego], len(together)).entering(together, {}, 0) == together:
            seated.append(ego)
        if len(seated) == k:
            break
    return seated


def world_step_ms(egos: list[tuple], steps: int = bench_perf.TIMED_STEPS) -> float:
    """Median step [ms] of one world holding ``egos``: each senses, decides, is
    recorded, checked and moved, then SUMO steps once (the shared loop, timed)."""
    world = make_shared_world(egos, None, None)
    sims = [Simulation(spec, world, road=road, slot=i) for i, (spec, road) in enumerate(egos)]
    controllers = [make_controller(spec.controller) for spec, _ in egos]
    with world:
        for sim in sims:
            sim.place()
        snapshots = world.start_all({i: (sim.box, sim.state.speed_mps)
                                     for i, sim in enumerate(sims)})
        for sim, snapshot in zip(sims, snapshots.values(), strict=True):
            sim.begin(snapshot)
        steps_s = []
        for _ in range(steps):
            start = time.perf_counter()
            moves = {}
            for i, sim in enumerate(sims):
                command, phase = sim.decide(controllers[i])
                sim.record(command, phase)
                sim.end_reason()
                sim.move(command)
                moves[i] = (sim.box, sim.state.speed_mps)
            snapshots = world.step_all(moves)
            for i in moves:
                sims[i].arrive(snapshots[i])
            steps_s.append(time.perf_counter() - start)
    return 1e3 * float(np.median(steps_s))


def step_figures(wanted: set[int], figures: dict, raw: dict) -> None:
    """The world's step by egos in it, over SUMO's own (the floor)."""
    bare_ms = bench_perf.bare_sumo_ms(seated_town(1)[0][0], ego=False)
    raw["town_bare_sumo_step_ms"] = bare_ms
    for k in sorted(wanted):
        egos = seated_town(k)
        raw[f"town_seated_k{k}"] = len(egos)
        step_ms = world_step_ms(egos)
        raw[f"town_world_step_ms_k{k}"] = step_ms
        figures[f"town_world_step_vs_bare_sumo_k{k}"] = step_ms / bare_ms
        figures[f"town_ego_step_vs_bare_sumo_k{k}"] = step_ms / len(egos) / bare_ms


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("k", type=int, nargs="*", help="the K to measure (1 always; "
                        f"default: {EGOS_PER_WORLD})")
    parser.add_argument("--family", choices=sorted(FAMILIES), action="append",
                        help="the sweeps' families (default: all)")
    parser.add_argument("--steps", action="store_true",
                        help="the world's step only, no sweep")
    args = parser.parse_args()
    wanted = {1, *args.k} if args.k else set(EGOS_PER_WORLD)
    figures, raw = {}, {}
    if not args.steps:
        sweep_figures(wanted, args.family or list(FAMILIES), figures, raw)
    step_figures(wanted, figures, raw)  # on the user's cache: its warm state is kept
    for name, value in figures.items():
        print(f"{name} {value:.3f}")
    for name, value in raw.items():
        print(f"raw.{name} {value:.1f}")


def sweep_figures(wanted: set[int], families: list[str], figures: dict, raw: dict) -> None:
    """Runs per hour of each family's sweep by egos per world, cold and cached."""
    users_cache = os.environ.get("SDC_CACHE_DIR")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for family in families:
            for k in sorted(wanted):
                name = f"{family}_runs_per_hour"
                sweep = write_sweep(tmp, family, SAMPLES, k)
                os.environ["SDC_CACHE_DIR"] = str(tmp / f"cache-{family}-{k}")  # cold
                raw[f"{name}_k{k}"], raw[f"{family}_egos_per_step_k{k}"] = (
                    runs_per_hour(sweep, tmp / f"cold-{family}-{k}"))
                raw[f"{name}_cached_k{k}"], _ = runs_per_hour(sweep,
                                                              tmp / f"warm-{family}-{k}")
                if k > 1:
                    figures[f"{name}_k{k}_vs_k1"] = raw[f"{name}_k{k}"] / raw[f"{name}_k1"]
                    figures[f"{name}_cached_k{k}_vs_k1"] = (raw[f"{name}_cached_k{k}"]
                                                            / raw[f"{name}_cached_k1"])
    os.environ.pop("SDC_CACHE_DIR")
    if users_cache is not None:
        os.environ["SDC_CACHE_DIR"] = users_cache


if __name__ == "__main__":
    main()
