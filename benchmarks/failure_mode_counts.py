"""How many failure modes are listed, against the true regions found, seed by seed.

Part one, without SUMO: every problem of :mod:`analysis.rare.rare_bank` and the
emulated seed-modes family, an estimate (target RHW 0.3) and a 1000-run search
(:func:`analysis.rare.rare_bank.mode_count`) over ``--seeds`` seeds. Part two, with
``--sumo``: the catalog's seed-modes family for real, an estimate and a search
(``--search-runs``) for each sweep seed 1..N, each failure placed in its true
region by the truth file's boundaries (low-speed failures, 0.016 % of P, are
no region of their own: they join an obstacle region or ``other``).

A seed counts as right when the modes listed (``other`` aside) are exactly the
regions holding a failure (of at least 1 % of P). Prints a table per part and
``name value`` lines: ``modes_<problem>_<search|estimate>_right`` (the share of
seeds) and the same with ``sumo_seed_modes_``.

    python benchmarks/failure_mode_counts.py --seeds 30
    python benchmarks/failure_mode_counts.py --seeds 10 --sumo --no-bank
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from analysis.rare.failure_modes import OTHER  # noqa: E402
from analysis.rare.rare_bank import BANK, SEED_MODES_EMULATED, mode_count  # noqa: E402
from scenarios import CATALOG_DIR  # noqa: E402

FAMILY = CATALOG_DIR / "sweeps" / "seed-modes.toml"
TRUTH = CATALOG_DIR / "sweeps" / "seed-modes.truth.json"


def bank_part(seeds: int) -> dict[str, float]:
    figures = {}
    print(f"{'problem':22s} {'mode':8s} right  counts (listed:found) that differ")
    for case in (*BANK, SEED_MODES_EMULATED):
        for mode, runs in (("search", 1000), ("estimate", 20_000)):
            start = time.perf_counter()
            counts = [mode_count(case, mode, seed, runs) for seed in range(seeds)]
            right = sum(listed == found for listed, found in counts)
            wrong = " ".join(f"{a}:{b}" for a, b in counts if a != b)
            print(f"{case.name:22s} {mode:8s} {right:2d}/{seeds}  {wrong}  "
                  f"({time.perf_counter() - start:.0f} s)", flush=True)
            figures[f"modes_{case.name}_{mode}_right"] = right / seeds
    return figures


def _regions_found(rows: pd.DataFrame, truth: dict) -> set[str]:
    """The truth's regions (speed, left, right) that hold a failed row."""
    failed = rows[rows.score <= 0]
    seen = np.mean(truth["boundaries"]["left_offset_m"])
    offset = failed["p.obstacles[0].lateral_offset_m"]
    regions = np.select([failed.collision_with == "road_edge", offset > seen, offset < -seen],
                        ["speed", "left", "right"], "")
    return set(regions) - {""}


def sumo_part(seeds: int, search_runs: int) -> dict[str, float]:
    from scenarios.spec.sweep_spec import load_sweep
    from sdc.batch.executors.local_executor import LocalExecutor
    from sdc.batch.sweeps.adaptive_runner import AdaptiveSettings, run_adaptive
    from sdc.batch.sweeps.progress import QuietReporter

    truth = json.loads(TRUTH.read_text())
    sweep = load_sweep(FAMILY)
    figures = {}
    print(f"\nseed-modes with SUMO, sweep seeds 1-{seeds}: modes listed / regions found")
    for mode, settings in (("search", AdaptiveSettings("search", "seed", search_runs, 20)),
                           ("estimate", AdaptiveSettings("estimate", "seed", 20_000, 500,
                                                         target_rhw=0.3))):
        right, cells = 0, []
        for seed in range(1, seeds + 1):
            with tempfile.TemporaryDirectory() as out:
                summary = run_adaptive(dataclasses.replace(sweep, seed=seed), Path(out),
                                       LocalExecutor(2), QuietReporter(), settings,
                                       traces="none").summary
                rows = pd.read_parquet(Path(out) / "results.parquet")
            listed = sum(m["outcome"] != OTHER for m in summary["failure_modes"])
            found = len(_regions_found(rows, truth))
            right += listed == found
            cells.append(f"{listed}:{found}")
            print(f"  {mode} seed {seed}: {listed} listed, {found} found ({len(rows)} runs)",
                  flush=True)
        print(f"{mode}: {right}/{seeds} right  {' '.join(cells)}")
        figures[f"sumo_seed_modes_{mode}_right"] = right / seeds
    return figures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--sumo", action="store_true", help="also the real seed-modes family")
    parser.add_argument("--no-bank", action="store_true", help="skip the bank part")
    parser.add_argument("--search-runs", type=int, default=1000)
    args = parser.parse_args()
    figures = {} if args.no_bank else bank_part(args.seeds)
    if args.sumo:
        figures.update(sumo_part(args.seeds, args.search_runs))
    for name, value in figures.items():
        print(f"{name} {value:.3f}")


if __name__ == "__main__":
    main()
