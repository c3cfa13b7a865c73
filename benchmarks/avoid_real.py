"""The avoid controller in real traffic: following, red lights, turns, stopped cars.

Runs the families of the issue on `avoid` in real traffic, each beside the
control group, and prints ``name value`` lines (``<family>.<controller>.<figure>``),
a table per family, and the must-shows last as ``must_show.*`` lines with Wilson
95% intervals:

- real-traffic (sweeps/real-traffic.toml: eight of SUMO's real scenarios with
  their own demand, no obstacle, 180-degree lidar): avoid completes at least 95%,
  no road-edge collision, nothing hit with its front;
- real-motorway-stop (sweeps/real-motorway-stop.toml: a stopped car in the ego's
  lane on the A10 with its demand, 360-degree lidar): no collision where a stop
  was possible, at least 80% completed; beside it SUMO's own driver in the ego's
  place (sdc.run.sumo_driver): in how many runs the world lets a car past, and
  what avoid completes of those;
- grid-turns (a default ``netgenerate --grid`` network, routes turning at random,
  generated here): no road-edge collision;
- give-way-grid (the same with 150 cars: priority junctions where the car gives
  way on minor links): avoid's vehicle collisions beside lane-keep's;
- signal-grid (sweeps/grid-town.toml: a signalised 10 x 10 grid with 2000 cars):
  avoid crosses no red light; seed and lane-keep counted beside it;
- envelope (sweeps/seed-envelope.toml without traffic): no stuck run where the
  lane beside the obstacle is free, no collision where a stop was possible.

    python benchmarks/avoid_real.py [FAMILY ...] [--samples N] [--workers N] [--out DIR]
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import subprocess
import tempfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import pandas as pd
from avoid_roads import HITS, OUTCOMES  # beside this script
from avoid_roads import figures as road_figures

from analysis.stats.rates import wilson_interval
from scenarios import CATALOG_DIR
from scenarios.spec.sweep_plan import expand
from scenarios.spec.sweep_spec import SweepSpec, load_sweep
from scenarios.sumo_net.build import sumo_binary
from scenarios.world_backends import check_inputs
from sdc.batch.executors.local_executor import LocalExecutor
from sdc.batch.sweeps.progress import QuietReporter
from sdc.batch.sweeps.sweep_runner import run_sweep
from sdc.run.sumo_driver import COLLIDED, NOT_PAST, PASSED, sumo_drives

SWEEPS = CATALOG_DIR / "sweeps"

GRID_SCENARIO = """\
[scenario]
name = "grid-turns"
duration_s = 40.0
step_s = 0.064
seed = 1

[road]
kind = "sumo_net"
net_file = "{net}"
length_m = 400.0
route_turns = "any"

[traffic]
vehicles = {vehicles}
warm_up_s = {warm_up_s}

[ego]
lane = 0
start_m = 10.0
speed_mps = 8.0

[controller]
name = "avoid"
"""
GRID_SWEEP = """\
[sweep]
name = "grid-turns"
base = "grid-turns.toml"
samples = 40
sampler = "lhs"
seed = 5
controllers = ["lane-keep", "avoid"]

[sweep.params]
"ego.speed_mps" = { uniform = [4.0, 14.0] }
"""


def grid_turns_sweep(folder: Path, vehicles: int = 0) -> SweepSpec:
    """The grid-turns family on a default ``netgenerate --grid`` network made here (its
    junctions give priority: minor links give way), with ``vehicles`` random trips."""
    net = folder / "default-grid.net.xml"
    # named relative to its folder: the file (its header names it) is the same in any
    # folder, and so are the runs on it
    subprocess.run([sumo_binary("netgenerate"), "--grid", "--output-file", net.name],
                   check=True, capture_output=True, cwd=folder)
    (folder / "grid-turns.toml").write_text(
        GRID_SCENARIO.format(net=net, vehicles=vehicles, warm_up_s=60.0 if vehicles else 0.0))
    (folder / "grid-turns-sweep.toml").write_text(GRID_SWEEP)
    return load_sweep(folder / "grid-turns-sweep.toml")


def family_sweep(name: str, folder: Path) -> SweepSpec:
    if name == "grid-turns":
        return grid_turns_sweep(folder)
    if name == "give-way-grid":
        return grid_turns_sweep(folder, vehicles=GIVE_WAY_VEHICLES)
    if name == "signal-grid":  # with avoid, the traffic warmed up four times, shared
        sweep = load_sweep(SWEEPS / "grid-town.toml")
        return dataclasses.replace(sweep, controllers=("seed", "lane-keep", "avoid"),
                                   warm_states=4)
    if name == "envelope":
        return load_sweep(SWEEPS / "seed-envelope.toml")
    return load_sweep(SWEEPS / f"{name}.toml")


FAMILIES = ("real-traffic", "real-motorway-stop", "grid-turns", "give-way-grid", "signal-grid",
            "envelope")
#: the give-way-grid family: grid-turns with this many cars on the grid
GIVE_WAY_VEHICLES = 150


def run_family(name: str, out_dir: Path, samples: int | None, workers: int) -> pd.DataFrame:
    """Run (or finish) one family's sweep into ``out_dir``; its result rows."""
    out_dir.mkdir(parents=True, exist_ok=True)
    sweep = family_sweep(name, out_dir)
    if samples is not None:
        sweep = sweep.with_samples(samples)
    check_inputs(sweep.base)
    run_sweep(sweep, out_dir / "runs", LocalExecutor(workers), QuietReporter(),
              traces="none", resume=True)
    rows = pd.read_parquet(out_dir / "runs" / "results.parquet").sort_values("run_index")
    if name == "envelope":  # the slice without traffic
        rows = rows[rows["p.traffic.flow_vph_per_lane"] == 0]
    return rows


def sumo_driver(out_dir: Path, samples: int | None, workers: int) -> dict[str, str]:
    """SUMO's own driver in the ego's place in each of the family's avoid runs: each
    run's outcome (passed, collided, not_past), by run ID."""
    sweep = family_sweep("real-motorway-stop", out_dir)
    if samples is not None:
        sweep = sweep.with_samples(samples)
    runs = [r for r in expand(sweep) if r.spec.controller.label == "avoid"]
    with ProcessPoolExecutor(workers) as pool:
        drives = list(pool.map(sumo_drives, [r.spec for r in runs]))
    return {r.run_id: d.outcome for r, d in zip(runs, drives, strict=True)}


def sumo_driver_figures(avoid: pd.DataFrame, drives: dict[str, str]) -> dict[str, float]:
    """SUMO's driver's figures, and what avoid completed where SUMO's driver passed."""
    outcomes = pd.Series(drives)
    passed = outcomes[outcomes == PASSED].index
    return {"runs": len(outcomes), "errors": 0, "completed": int((outcomes == PASSED).sum()),
            "collided": int((outcomes == COLLIDED).sum()), "stuck": 0,
            "unfinished": int((outcomes == NOT_PAST).sum()),  # not past when time ran out
            "avoid_completed_where_passed":
                int((avoid.set_index("run_id").outcome.reindex(passed) == "completed").sum())}


def figures(rows: pd.DataFrame) -> dict[str, float]:
    """One controller's figures from its result rows: avoid-roads' and those of
    this issue."""
    ok = rows[rows.status == "ok"]
    out = road_figures(rows)
    out["front_hits"] = int((ok.collision_part == "front").sum())
    possible = ok.stop_possible.fillna(False).astype(bool)
    out["collided_where_stop_possible"] = int((ok.collision & possible).sum())
    out["red_light_violations"] = int(ok.red_light_violations.fillna(0).sum())
    out["runs_through_red"] = int((ok.red_light_violations.fillna(0) > 0).sum())
    return out


def print_family(name: str, table: dict[str, dict[str, float]]) -> None:
    for controller, figs in table.items():
        for key, value in figs.items():
            print(f"{name}.{controller}.{key} {value:.4g}")
    keys = ("runs", "errors", *OUTCOMES, *(f"hit_{h}" for h in HITS), "front_hits",
            "red_light_violations")
    print(f"\n{name}\n{'controller':<11} " + " ".join(f"{k[:10]:>10}" for k in keys))
    for controller, figs in table.items():
        print(f"{controller:<11} " + " ".join(f"{figs.get(k, math.nan):>10.0f}" for k in keys))


def rate_line(name: str, hits: int, runs: int, target: str) -> str:
    lo, hi = wilson_interval(hits, runs)
    rate = hits / runs if runs else float("nan")
    return (f"must_show.{name} {rate:.3f} ({hits}/{runs}; target {target}; "
            f"Wilson 95% {lo:.3f} - {hi:.3f})")


def must_shows(results: dict[str, dict[str, dict[str, float]]]) -> list[str]:
    lines = []
    if "real-traffic" in results:
        a = results["real-traffic"]["avoid"]
        lines.append(rate_line("real_traffic.avoid_completed_rate", a["completed"], a["runs"],
                               ">= 0.95"))
        lines.append(f"must_show.real_traffic.avoid_road_edge_collisions {a['hit_road_edge']} "
                     "(target 0)")
        lines.append(f"must_show.real_traffic.avoid_front_collisions {a['front_hits']} (target 0)")
    if "real-motorway-stop" in results:
        a = results["real-motorway-stop"]["avoid"]
        lines.append(f"must_show.real_motorway_stop.avoid_collided_where_stop_possible "
                     f"{a['collided_where_stop_possible']} (target 0)")
        lines.append(rate_line("real_motorway_stop.avoid_completed_rate", a["completed"],
                               a["runs"], ">= 0.80"))
        s = results["real-motorway-stop"].get("sumo-driver")
        if s is not None:
            lines.append(rate_line("real_motorway_stop.sumo_driver_passed_rate", s["completed"],
                                   s["runs"], "none: the world's own driver, for reference"))
            lines.append(rate_line("real_motorway_stop.avoid_completed_where_sumo_driver_passed",
                                   s["avoid_completed_where_passed"], s["completed"],
                                   "none: what the world allows"))
    if "grid-turns" in results:
        a = results["grid-turns"]["avoid"]
        lines.append(f"must_show.grid_turns.avoid_road_edge_collisions {a['hit_road_edge']} "
                     "(target 0)")
    if "give-way-grid" in results:
        table = results["give-way-grid"]
        beside = ", ".join(f"{c} {f['hit_vehicle']:.0f}" for c, f in table.items())
        lines.append(f"must_show.give_way_grid.avoid_vehicle_collisions "
                     f"{table['avoid']['hit_vehicle']:.0f} (no target; {beside})")
    if "signal-grid" in results:
        table = results["signal-grid"]
        beside = ", ".join(f"{c} {f['red_light_violations']:.0f}" for c, f in table.items())
        lines.append(f"must_show.signal_grid.avoid_red_light_violations "
                     f"{table['avoid']['red_light_violations']:.0f} (target 0; {beside})")
    if "envelope" in results:
        a = results["envelope"]["avoid"]
        lines.append(f"must_show.envelope.avoid_stuck {a['stuck']} (target 0 where the lane "
                     "beside is free: no traffic in this slice)")
        lines.append(f"must_show.envelope.avoid_collided_where_stop_possible "
                     f"{a['collided_where_stop_possible']} (target 0)")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("families", nargs="*", choices=[[], *FAMILIES], default=[])
    parser.add_argument("--samples", type=int, default=None)
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args()
    out = args.out or Path(tempfile.mkdtemp(prefix="avoid-real-"))
    results = {}
    for name in args.families or FAMILIES:
        rows = run_family(name, out / name, args.samples, args.workers)
        table = {c: figures(rows[rows.controller == c]) for c in rows.controller.unique()}
        if name == "real-motorway-stop":
            drives = sumo_driver(out / name, args.samples, args.workers)
            table["sumo-driver"] = sumo_driver_figures(rows[rows.controller == "avoid"], drives)
        print_family(name, table)
        results[name] = table
    print()
    for line in must_shows(results):
        print(line)


if __name__ == "__main__":
    main()
