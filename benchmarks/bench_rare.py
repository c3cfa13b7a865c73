"""Rare failures on the catalog's seed-rare family, against its documented truth.

Prints ``name value`` lines:

- ``estimate_p_collision``, ``estimate_ci_low``, ``estimate_ci_high``, ``truth_p``,
  ``estimate_covers_truth`` (1 or 0): ``sdc estimate`` to RHW 0.3 on 2 local workers;
- ``estimate_runs`` and ``estimate_mc_equivalent_runs`` (plain Monte Carlo runs for the
  same RHW at the estimated p); ``estimate_acceleration`` their ratio (target >= 20);
- ``estimate_wall_s_cold_cache``: the estimate's wall time on 2 workers with an empty
  network cache (each lane width is its own SUMO network, built by netconvert),
  ``estimate_wall_s_warm_cache`` the same estimate again with those networks cached;
- ``search_first_failure_runs_median``: runs until ``sdc search`` finds a first
  collision, the median over ``SEARCHES`` sweep seeds; ``uniform_first_failure_runs``:
  what uniform random sampling needs on average, 1 / truth; ``search_vs_uniform`` their
  ratio (target >= 10).

``SDC_BENCH_SMOKE=1``: the smoke size (benchmarks/smoke.py): estimates of at most 20
runs (batches of 10), one search of at most 20, on 1 worker.
"""

from __future__ import annotations

import dataclasses
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

from smoke import size

from scenarios import CATALOG_DIR
from scenarios.spec.sweep_spec import load_sweep
from sdc.batch.executors.local_executor import LocalExecutor
from sdc.batch.sweeps.adaptive_runner import AdaptiveSettings, run_adaptive
from sdc.batch.sweeps.progress import QuietReporter

FAMILY = CATALOG_DIR / "sweeps" / "seed-rare.toml"
TRUTH = CATALOG_DIR / "sweeps" / "seed-rare.truth.json"
SEARCHES = size(11, 1)
WORKERS = size(2, 1)
#: the estimate's and the search's budgets [runs] and batches
ESTIMATE_RUNS, ESTIMATE_BATCH = size(20_000, 20), size(200, 10)
SEARCH_RUNS, SEARCH_BATCH = size(2000, 20), size(20, 10)


def main() -> None:
    sweep = load_sweep(FAMILY)
    truth = json.loads(TRUTH.read_text())["p_true"]
    with tempfile.TemporaryDirectory() as tmp:
        os.environ["SDC_CACHE_DIR"] = str(Path(tmp) / "cache")  # the workers inherit it
        walls_s = []
        for name in ("cold", "warm"):
            start = time.perf_counter()
            outcome = run_adaptive(sweep, Path(tmp) / f"estimate-{name}", LocalExecutor(WORKERS),
                                   QuietReporter(),
                                   AdaptiveSettings("estimate", "seed", ESTIMATE_RUNS,
                                                    ESTIMATE_BATCH, target_rhw=0.3))
            walls_s.append(time.perf_counter() - start)
        e = outcome.summary
        print(f"estimate_p_collision {e['p_collision']:.4g}")
        print(f"estimate_ci_low {e['ci_low']:.4g}")
        print(f"estimate_ci_high {e['ci_high']:.4g}")
        print(f"truth_p {truth:.4g}")
        print(f"estimate_covers_truth {int(e['ci_low'] <= truth <= e['ci_high'])}")
        print(f"estimate_stopped {e['stopped']}")
        print(f"estimate_runs {e['runs']}")
        print(f"estimate_mc_equivalent_runs {e['mc_equivalent_runs']:.0f}")
        print(f"estimate_acceleration {e['mc_equivalent_runs'] / e['runs']:.1f}")
        print(f"estimate_wall_s_cold_cache {walls_s[0]:.1f}")
        print(f"estimate_wall_s_warm_cache {walls_s[1]:.1f}")

        firsts = []
        settings = AdaptiveSettings("search", "seed", SEARCH_RUNS, SEARCH_BATCH, stop_after=1)
        for seed in range(1, SEARCHES + 1):
            seeded = dataclasses.replace(sweep, seed=seed)
            found = run_adaptive(seeded, Path(tmp) / f"search-{seed}", LocalExecutor(WORKERS),
                                 QuietReporter(), settings).summary["first_failure_run"]
            firsts.append(found if found is not None else settings.max_runs)
        median = statistics.median(firsts)
        print(f"search_first_failure_runs {' '.join(map(str, firsts))}", file=sys.stderr)
        print(f"search_first_failure_runs_median {median:g}")
        print(f"uniform_first_failure_runs {1 / truth:.0f}")
        print(f"search_vs_uniform {1 / truth / median:.1f}")


if __name__ == "__main__":
    main()
