"""Interference measured, not assumed: the same samples with K egos a world and with
one, outcome by outcome, with clustered 95% intervals.

Two families (``--family``):

- ``town``: the catalog's grid-town sweep (10 x 10 junctions, 2000 cars, 400 s of
  warm-up; ``seed`` and ``lane-keep``);
- ``real``: a real configuration, SUMO's Ingolstadt (tools/game/fkk_in.sumocfg, its
  own demand, 120 s entered; ``lane-keep`` and ``avoid``, as the real-traffic family).

The samples draw their traffic from :data:`WARM_STATES` warm states
(``warm_states``), so that every K runs the same samples on the same traffic and only
the sharing differs: with K = 1 each run has the traffic to itself, with K > 1 a
world's runs (one warm state each) share it, each a body to the others. The warm
states are computed once (the first sweep) and loaded by the others.

Prints, per K, controller and outcome: the runs, the rate and its 95% Wilson
interval (clustered by traffic, as every report's), and whether it overlaps K = 1's;
then, per K and controller, how many runs' verdicts differ from the same run's with
K = 1 (paired: same sample, same warm state); then ``raw.`` lines with the mean
``world_egos`` per K. ``--samples`` and ``--k`` change the experiment (defaults: 64
samples, K = 1, 4, 8).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import pandas as pd

from analysis.measures.run_outcome import OUTCOMES
from analysis.stats.rates import flag_interval
from scenarios import CATALOG_DIR
from scenarios.spec.sweep_spec import load_sweep
from sdc.batch.executors import LocalExecutor
from sdc.batch.progress import QuietReporter
from sdc.batch.sweep_runner import run_sweep

WARM_STATES, WORKERS = 8, 2


FAMILIES = {
    "town": ("grid-town.toml", '["seed", "lane-keep"]',
             ['"ego.speed_mps" = { uniform = [2.5, 8.0] }',
              '"obstacles[0].position_m" = { uniform = [40.0, 150.0] }',
              '"obstacles[0].kind" = { choice = ["car", "barrel"] }']),
    "real": ("real-traffic.toml", '["lane-keep", "avoid"]',
             ['"road.config_file" = { choice = ["sumo:tools/game/fkk_in.sumocfg"] }',
              '"ego.speed_mps" = { uniform = [8.0, 14.0] }']),
}


def write_sweep(tmp: Path, family: str, samples: int, k: int) -> Path:
    base, controllers, params = FAMILIES[family]
    lines = ['[sweep]', 'name = "interference"', f'base = "{CATALOG_DIR / base}"',
             f"samples = {samples}", 'sampler = "sobol"', "seed = 11",
             f"controllers = {controllers}", f"warm_states = {WARM_STATES}",
             f"egos_per_world = {k}", "[sweep.params]", *params]
    path = tmp / f"interference-{k}.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


def outcome_rates(rows: pd.DataFrame) -> dict[tuple[str, str], tuple[int, int, float, float]]:
    """(controller, outcome) -> (runs with it, ok runs, interval low, high)."""
    out = {}
    for controller, group in rows[rows.status == "ok"].groupby("controller"):
        for outcome in OUTCOMES:
            flags = group.outcome == outcome
            (low, high), _ = flag_interval(flags, group, "wilson")
            out[controller, outcome] = (int(flags.sum()), len(group), low, high)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--family", choices=sorted(FAMILIES), default="town")
    parser.add_argument("--samples", type=int, default=64)
    parser.add_argument("--k", type=int, nargs="+", default=[1, 4, 8])
    args = parser.parse_args()
    rates, verdicts, raw = {}, {}, {}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for k in args.k:
            out = tmp / f"k{k}"
            run_sweep(load_sweep(write_sweep(tmp, args.family, args.samples, k)), out,
                      LocalExecutor(WORKERS), QuietReporter(), traces="none")
            rows = pd.read_parquet(out / "results.parquet")
            rates[k] = outcome_rates(rows)
            verdicts[k] = rows.set_index(["sample", "controller"]).outcome
            raw[f"mean_world_egos_k{k}"] = float(rows.world_egos.mean())
    base = rates[args.k[0]]
    print("K  controller  outcome  runs  rate  95% interval  overlaps K=1")
    for k, table in rates.items():
        for (controller, outcome), (hits, n, low, high) in table.items():
            _, _, low1, high1 = base[controller, outcome]
            overlaps = low <= high1 and low1 <= high
            print(f"{k}  {controller}  {outcome}  {hits}/{n}  {hits / n:.1%}  "
                  f"{low:.1%} - {high:.1%}  {'yes' if overlaps else 'NO'}")
    first = verdicts[args.k[0]]
    print("K  controller  verdicts that differ from K=1's (same sample, same traffic)")
    for k, outcome in verdicts.items():
        differ = (outcome != first.reindex(outcome.index)).groupby(level="controller")
        for controller, flags in differ:
            print(f"{k}  {controller}  {int(flags.sum())}/{len(flags)}")
    for name, value in raw.items():
        print(f"raw.{name} {value:.2f}")


if __name__ == "__main__":
    main()
