"""The avoid controller on any road: curves, turning town routes, traffic from behind.

Runs the avoid-roads sweep families (scenarios/catalog/sweeps/avoid-roads-*.toml,
each under seed, lane-keep and avoid) and prints, per family and controller,
``name value`` lines (``<family>.<controller>.<figure>``) and a table: runs,
outcomes (completed / collided / stuck / unfinished; error and timeout rows
apart), collisions by what was hit, maneuvers started, the share of them that
ended back in the lane (``returned_to_lane`` among ``maneuver_started``), and
the largest |lane offset| of any run.

The must-shows for avoid, printed last as ``must_show.*`` lines:

- curves (R 100 to 300 m, left and right) and grid (a 4 x 4 town grid, routes
  turning at junctions), no traffic: no collision, and at least 95% of the
  maneuvers return to the lane;
- traffic (two lanes, faster traffic from behind, 360-degree lidar): no
  collision with a vehicle and at least 60% of the runs completed, with
  traffic-front's completed rate (the same samples, 180-degree lidar) beside it.

    python benchmarks/avoid_roads.py [FAMILY ...] [--samples N] [--workers N] [--out DIR]

Each family's sweep directory is DIR/<family>; ``--resume`` finishes (or just
summarizes) sweeps already there.
"""

from __future__ import annotations

import argparse
import os
import tempfile
from pathlib import Path

import pandas as pd

from analysis.stats.rates import wilson_interval
from scenarios import CATALOG_DIR
from scenarios.spec.sweep_spec import load_sweep
from scenarios.world_backends import check_inputs
from sdc.batch.executors.local_executor import LocalExecutor
from sdc.batch.sweeps.progress import QuietReporter
from sdc.batch.sweeps.sweep_runner import run_sweep

FAMILIES = {name: CATALOG_DIR / "sweeps" / f"avoid-roads-{name}.toml"
            for name in ("curves", "grid", "traffic", "traffic-front")}
OUTCOMES = ("completed", "collided", "stuck", "unfinished")
HITS = ("obstacle", "vehicle", "road_edge")


def run_family(name: str, out_dir: Path, samples: int | None, workers: int,
               resume: bool, traces: str) -> pd.DataFrame:
    """Run (or finish) one family's sweep into ``out_dir``; its result rows."""
    sweep = load_sweep(FAMILIES[name])
    if samples is not None:
        sweep = sweep.with_samples(samples)
    check_inputs(sweep.base)
    run_sweep(sweep, out_dir, LocalExecutor(workers), QuietReporter(), traces=traces,
              resume=resume)
    return pd.read_parquet(out_dir / "results.parquet").sort_values("run_index")


def figures(rows: pd.DataFrame) -> dict[str, float]:
    """One controller's figures from its result rows."""
    ok = rows[rows.status == "ok"]
    out: dict[str, float] = {"runs": len(rows), "errors": len(rows) - len(ok)}
    out.update({o: int((ok.outcome == o).sum()) for o in OUTCOMES})
    out.update({f"hit_{h}": int((ok.collision_with == h).sum()) for h in HITS})
    maneuvers = ok[ok.maneuver_started.fillna(False).astype(bool)]
    out["maneuvers"] = len(maneuvers)
    returned = maneuvers.returned_to_lane.fillna(False).astype(bool).sum()
    out["return_rate"] = returned / len(maneuvers) if len(maneuvers) else float("nan")
    out["completed_rate"] = out["completed"] / len(rows) if len(rows) else float("nan")
    out["max_abs_lane_offset_m"] = float(ok.max_abs_lane_offset_m.max())
    return out


def print_family(name: str, table: dict[str, dict[str, float]]) -> None:
    for controller, figs in table.items():
        for key, value in figs.items():
            print(f"{name}.{controller}.{key} {value:.4g}")
    head = (f"{'controller':<10} {'runs':>5} {'err':>4} " + " ".join(f"{o:>10}" for o in OUTCOMES)
            + " " + " ".join(f"{h:>9}" for h in HITS)
            + f" {'maneuvers':>9} {'returned':>8} {'max|off|':>8}")
    print(f"\n{name}\n{head}")
    for controller, f in table.items():
        print(f"{controller:<10} {f['runs']:>5} {f['errors']:>4} "
              + " ".join(f"{f[o]:>10}" for o in OUTCOMES) + " "
              + " ".join(f"{f['hit_' + h]:>9}" for h in HITS)
              + f" {f['maneuvers']:>9} {f['return_rate']:>8.1%} {f['max_abs_lane_offset_m']:>8.2f}")
    print()


def must_show(tables: dict[str, dict[str, dict[str, float]]]) -> None:
    """The avoid controller's targets, on the families that ran."""
    for name in ("curves", "grid"):
        if "avoid" in tables.get(name, {}):
            f = tables[name]["avoid"]
            collisions = sum(f[f"hit_{h}"] for h in HITS)
            print(f"must_show.{name}.avoid_collisions {collisions} (target 0)")
            print(f"must_show.{name}.avoid_errors {f['errors']} (target 0: never safe)")
            low, high = wilson_interval(f["return_rate"] * f["maneuvers"], f["maneuvers"])
            print(f"must_show.{name}.avoid_return_rate {f['return_rate']:.3f} (target >= 0.95; "
                  f"Wilson 95% {low:.3f} - {high:.3f})")
    for name in ("traffic", "traffic-front"):
        if "avoid" in tables.get(name, {}):
            f = tables[name]["avoid"]
            target = " (target 0)" if name == "traffic" else ""
            print(f"must_show.{name}.avoid_vehicle_collisions {f['hit_vehicle']}{target}")
            target = "target >= 0.60" if name == "traffic" else "beside it"
            low, high = wilson_interval(f["completed"], f["runs"])
            print(f"must_show.{name}.avoid_completed_rate {f['completed_rate']:.3f} ({target}; "
                  f"Wilson 95% {low:.3f} - {high:.3f}; errors never count as completed)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("families", nargs="*", metavar="FAMILY",
                        help=f"of {', '.join(FAMILIES)} (default: all)")
    parser.add_argument("--samples", type=int, help="override each sweep's sample count")
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--out", type=Path, help="sweep directories go in DIR/<family> "
                        "(default: a temporary directory)")
    parser.add_argument("--resume", action="store_true",
                        help="finish or summarize the sweeps already in DIR")
    parser.add_argument("--traces", choices=("none", "failures", "all"), default="failures")
    args = parser.parse_args()
    for name in args.families:
        if name not in FAMILIES:
            parser.error(f"unknown family {name!r} (known: {', '.join(FAMILIES)})")
    with tempfile.TemporaryDirectory() as tmp:
        out_root = args.out or Path(tmp)
        tables = {}
        for name in args.families or FAMILIES:
            rows = run_family(name, out_root / name, args.samples, args.workers,
                              args.resume, args.traces)
            tables[name] = {c: figures(rows[rows.controller == c])
                            for c in rows.controller.unique()}
            print_family(name, tables[name])
        must_show(tables)


if __name__ == "__main__":
    main()
