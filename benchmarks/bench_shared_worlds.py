"""Several egos in one world: runs per hour of a town sweep by egos per world, as
ratios measured in one process run.

The sweep: the catalog's grid-town (10 x 10 junctions, 2000 cars, 400 s of warm-up,
each sample its own warm state unless it shares a world), the obstacle's position
swept, under ``seed``, on 2 local workers, traces off. Prints ``name value`` lines:

- ``town_runs_per_hour_k<K>_vs_k1``: runs per hour of the sweep with
  ``egos_per_world = K`` over the same sweep with one ego a world, each on a cold
  cache (a world computes its warm state in the sweep, one for its K runs).
- ``town_runs_per_hour_cached_k<K>_vs_k1``: the same on the filled cache (no warm-up
  left to compute): what sharing SUMO's step alone buys.
- ``raw.town_mean_world_egos_k<K>``: how many egos a run shared its SUMO simulation
  with, on average (the placement rule may seat fewer than K).

A rate is runs over the sweep's wall time; K = 1 runs :data:`SAMPLES` [1] samples
(each a warm-up of its own), the others enough for whole worlds.
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd

from scenarios import CATALOG_DIR
from scenarios.spec.sweep_spec import load_sweep
from sdc.batch.executors import LocalExecutor
from sdc.batch.progress import QuietReporter
from sdc.batch.sweep_runner import run_sweep

#: samples of the sweep by egos per world
SAMPLES = {1: 4, 4: 8, 8: 16, 16: 16}
WORKERS = 2


def write_sweep(tmp: Path, samples: int, egos_per_world: int) -> Path:
    lines = ['[sweep]', 'name = "shared-worlds-bench"',
             f'base = "{CATALOG_DIR / "grid-town.toml"}"', f"samples = {samples}",
             "seed = 11", 'controllers = ["seed"]', f"egos_per_world = {egos_per_world}",
             "[sweep.params]", '"obstacles[0].position_m" = { uniform = [40.0, 120.0] }']
    path = tmp / f"town-{egos_per_world}.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


def runs_per_hour(sweep_file: Path, out_dir: Path) -> tuple[float, float]:
    """The sweep's runs per hour, and the mean egos a run shared its world with."""
    start = time.perf_counter()
    outcome = run_sweep(load_sweep(sweep_file), out_dir, LocalExecutor(WORKERS),
                        QuietReporter(), traces="none")
    wall_s = time.perf_counter() - start
    assert outcome.counts["ok"] == outcome.runs, outcome.counts
    rows = pd.read_parquet(out_dir / "results.parquet")
    return outcome.runs / wall_s * 3600, float(rows.world_egos.mean())


def main() -> None:
    """``python benchmarks/bench_shared_worlds.py [K ...]``: those K only (1 always)."""
    wanted = {1, *map(int, sys.argv[1:])} if len(sys.argv) > 1 else set(SAMPLES)
    figures, raw = {}, {}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for k, samples in SAMPLES.items():
            if k not in wanted:
                continue
            sweep = write_sweep(tmp, samples, k)
            os.environ["SDC_CACHE_DIR"] = str(tmp / f"cache-{k}")  # cold: nothing warm
            raw[f"town_runs_per_hour_k{k}"], raw[f"town_mean_world_egos_k{k}"] = (
                runs_per_hour(sweep, tmp / f"cold-{k}"))
            raw[f"town_runs_per_hour_cached_k{k}"], _ = runs_per_hour(sweep, tmp / f"warm-{k}")
    for k in SAMPLES:
        if k > 1 and k in wanted:
            figures[f"town_runs_per_hour_k{k}_vs_k1"] = (raw[f"town_runs_per_hour_k{k}"]
                                                         / raw["town_runs_per_hour_k1"])
            figures[f"town_runs_per_hour_cached_k{k}_vs_k1"] = (
                raw[f"town_runs_per_hour_cached_k{k}"] / raw["town_runs_per_hour_cached_k1"])
    for name, value in figures.items():
        print(f"{name} {value:.3f}")
    for name, value in raw.items():
        print(f"raw.{name} {value:.1f}")


if __name__ == "__main__":
    main()
