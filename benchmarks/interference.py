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
interval (clustered by traffic, as every report's), whether it overlaps K = 1's, and
the paired comparison: of the same runs (same sample, same warm state), how many
gained the outcome with K and how many lost it, with the exact McNemar test's
p-value; then ``raw.`` lines with the mean ``world_egos`` per K. ``--samples`` and
``--k`` change the experiment (defaults: 64 samples, K = 1, 4, 8); ``--out`` keeps the
sweeps (and reads those already there).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import pandas as pd
from scipy.stats import binomtest

from analysis.measures.run_outcome import OUTCOMES
from analysis.stats.rates import flag_interval
from scenarios import CATALOG_DIR
from scenarios.spec.sweep_spec import load_sweep
from sdc.batch.executors.local_executor import LocalExecutor
from sdc.batch.sweeps.progress import QuietReporter
from sdc.batch.sweeps.sweep_runner import run_sweep

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
    path = tmp / f"interference-{family}-{k}.toml"
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


def paired_changes(rows: pd.DataFrame, first: pd.DataFrame, outcome: str
                   ) -> tuple[int, int, float]:
    """Of the runs both sweeps ran ok (same sample and controller), how many have
    ``outcome`` with K but not with K = 1, how many the reverse, and the exact
    McNemar test's two-sided p-value of the two being equally likely."""
    mine = rows[rows.status == "ok"].set_index(["sample", "controller"]).outcome
    theirs = first[first.status == "ok"].set_index(["sample", "controller"]).outcome
    both = mine.index.intersection(theirs.index)
    now, before = mine[both] == outcome, theirs[both] == outcome
    gained, lost = int((now & ~before).sum()), int((before & ~now).sum())
    p_value = binomtest(min(gained, lost), gained + lost).pvalue if gained + lost else 1.0
    return gained, lost, float(p_value)


def print_table(results: dict[int, pd.DataFrame]) -> None:
    """The table of ``results`` (K -> its sweep's rows; the first K the reference)."""
    first_k = next(iter(results))
    first = results[first_k]
    base = outcome_rates(first)
    print(f"K  controller  outcome  runs  rate  95% interval  overlaps K={first_k}  "
          f"paired: gained/lost  McNemar p")
    for k, rows in results.items():
        for (controller, outcome), (hits, n, low, high) in outcome_rates(rows).items():
            _, _, low1, high1 = base[controller, outcome]
            overlaps = low <= high1 and low1 <= high
            gained, lost, p_value = paired_changes(rows[rows.controller == controller],
                                                   first, outcome)
            print(f"{k}  {controller}  {outcome}  {hits}/{n}  {hits / n:.1%}  "
                  f"{low:.1%} - {high:.1%}  {'yes' if overlaps else 'NO'}  "
                  f"+{gained}/-{lost}  {p_value:.2f}")
    for k, rows in results.items():
        print(f"raw.mean_world_egos_k{k} {rows.world_egos.mean():.2f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--family", choices=sorted(FAMILIES), default="town")
    parser.add_argument("--samples", type=int, default=64)
    parser.add_argument("--k", type=int, nargs="+", default=[1, 4, 8])
    parser.add_argument("--out", type=Path, help="keep the sweeps here (default: a "
                        "temporary folder); a sweep already there is read, not re-run")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = args.out or Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        results = {}
        for k in args.k:
            out = folder / f"{args.family}-k{k}"
            if not (out / "results.parquet").is_file():
                run_sweep(load_sweep(write_sweep(folder, args.family, args.samples, k)),
                          out, LocalExecutor(WORKERS), QuietReporter(), traces="none")
            results[k] = pd.read_parquet(out / "results.parquet")
        print_table(results)


if __name__ == "__main__":
    main()
