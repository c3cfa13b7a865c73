"""Town-scale sweeps: runs per hour with shared warm states, as ratios measured in
one process run.

The sweep: the catalog's grid-town (10 x 10 junctions, 2000 cars, its settled
``traffic.warm_up_s``), the obstacle's position swept, under ``seed``, on 2 workers.
Prints ``name value`` lines:

- ``town_runs_per_hour_shared_vs_own_local``: runs per hour of the sweep drawing its
  samples from 8 warm states (``sweep.warm_states = 8``), the 8 computed in the
  sweep (a cold cache: their cost included), over runs per hour of the same sweep
  where every sample warms its traffic up itself (no ``warm_states``: what a run
  cost before warm states, plus one save and one load). Both on the local executor.
- ``town_runs_per_hour_shared_vs_own_ray``: the same ratio on a local Ray with 2 CPUs,
  one session held for both sweeps (as a notebook holds one): Ray's start is neither's.
- ``town_runs_per_hour_cached_vs_own_local``: the shared sweep again on the filled
  cache (no warm-up left to compute) over the own-warm-up one.

The own-warm-up sweep runs :data:`OWN_SAMPLES` samples, the shared one
:data:`SHARED_SAMPLES`; a rate is runs over the sweep's wall time.

``SDC_BENCH_SMOKE=1``: the smoke size (benchmarks/smoke.py): 2 warm states, 2 shared
samples and 1 own of 1 s runs on 1 worker, in a town of 20 cars warmed up 2 s
(:data:`SMOKE_TOWN`).
"""

from __future__ import annotations

import contextlib
import os
import tempfile
import time
from pathlib import Path

from smoke import SMOKE, size

from scenarios import CATALOG_DIR
from scenarios.spec.sweep_spec import load_sweep
from scenarios.spec.toml_io import load_spec
from sdc.batch.executors.local_executor import LocalExecutor
from sdc.batch.executors.ray_executor import RayExecutor, start_session
from sdc.batch.sweeps.progress import QuietReporter
from sdc.batch.sweeps.sweep_runner import run_sweep

WARM_STATES, SHARED_SAMPLES, OWN_SAMPLES = size(8, 2), size(40, 2), size(4, 1)
WORKERS = size(2, 1)
#: the smoke size's town: the grid with fewer cars, warmed up briefly, shorter runs
SMOKE_TOWN = ['"traffic.vehicles" = { choice = [20] }',
              '"traffic.warm_up_s" = { choice = [2.0] }',
              '"scenario.duration_s" = { choice = [1.0] }']


def write_sweep(tmp: Path, samples: int, warm_states: int | None) -> Path:
    lines = ['[sweep]', 'name = "town-bench"', f'base = "{CATALOG_DIR / "grid-town.toml"}"',
             f"samples = {samples}", "seed = 11", 'controllers = ["seed"]']
    if warm_states is not None:
        lines.append(f"warm_states = {warm_states}")
    lines += ["[sweep.params]", '"obstacles[0].position_m" = { uniform = [40.0, 120.0] }',
              *(SMOKE_TOWN if SMOKE else [])]
    path = tmp / f"town-{samples}-{warm_states}.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


def runs_per_hour(sweep_file: Path, out_dir: Path, executor) -> float:
    start = time.perf_counter()
    outcome = run_sweep(load_sweep(sweep_file), out_dir, executor, QuietReporter(),
                        traces="none")
    wall_s = time.perf_counter() - start
    assert outcome.counts["ok"] == outcome.runs, outcome.counts
    return outcome.runs / wall_s * 3600


@contextlib.contextmanager
def held_ray():
    """A local Ray session of :data:`WORKERS` CPUs this process holds: its executors
    use it and leave it running (its workers take ``SDC_CACHE_DIR`` as it is now)."""
    import ray

    start_session(WORKERS)
    try:
        yield
    finally:
        ray.shutdown()


def main() -> None:
    figures, raw = {}, {}
    raw["grid_town_warm_up_s"] = size(load_spec(CATALOG_DIR / "grid-town.toml").traffic.warm_up_s,
                                      2.0)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        own = write_sweep(tmp, OWN_SAMPLES, None)
        shared = write_sweep(tmp, SHARED_SAMPLES, WARM_STATES)
        for name, make in (("local", lambda: LocalExecutor(WORKERS)),
                           ("ray", lambda: RayExecutor(WORKERS))):
            os.environ["SDC_CACHE_DIR"] = str(tmp / f"cache-{name}")  # cold: nothing warm
            with held_ray() if name == "ray" else contextlib.nullcontext():
                raw[f"own_runs_per_hour_{name}"] = runs_per_hour(own, tmp / f"own-{name}",
                                                                 make())
                raw[f"shared_runs_per_hour_{name}"] = runs_per_hour(
                    shared, tmp / f"shared-{name}", make())
            figures[f"town_runs_per_hour_shared_vs_own_{name}"] = (
                raw[f"shared_runs_per_hour_{name}"] / raw[f"own_runs_per_hour_{name}"])
            if name == "local":  # the states are cached now: runs only
                raw["cached_runs_per_hour_local"] = runs_per_hour(shared, tmp / "cached",
                                                                  make())
                figures["town_runs_per_hour_cached_vs_own_local"] = (
                    raw["cached_runs_per_hour_local"] / raw["own_runs_per_hour_local"])
    for name, value in figures.items():
        print(f"{name} {value:.3f}")
    for name, value in raw.items():
        print(f"raw.{name} {value:.1f}")


if __name__ == "__main__":
    main()
