"""``avoid`` on its real families, counted so that two versions can be set side by side.

Issue 61 changed how an ego reaching over a lane line, and an obstacle at an edge's
end, are shown to SUMO. This runs ``avoid`` on the families where that shows, through
the CLI (``python -m sdc sweep``), so that the same script measures any checkout::

    python benchmarks/avoid_city_families.py --out runs/families
    PYTHONPATH=/tmp/old python benchmarks/avoid_city_families.py --out runs/families-old

The families (``avoid`` only, ``--samples`` each):

- ``a10``: sweeps/real-motorway-stop.toml, a stopped car on SUMO's A10 with its demand;
- ``braunschweig``: sweeps/real-people.toml, SUMO's fokr_bs_demo with its people and a
  person, bicycle or car standing in the ego's lane;
- ``town``: sweeps/grid-town.toml, 10 x 10 signalised junctions and 2000 cars (three
  warm states);
- ``grid3``, ``grid3-k8``: a 4 x 4 signalised ``netgenerate`` city of 3.0 m lanes, two
  each way, 80 cars, a car, truck or barrel in the ego's lane and a second one from 1 m
  right to 3 m left of its lane's centre (in the next lane, over a line, or over the
  road's centre line), each anywhere along the whole route (edge ends and junction
  entrances included); one ego a world, then eight.

Prints one line a family: runs, completed, stuck, collided by what
(``collision_with``) and by ``collision_role``, and the steps the audit judged made
up (``world_overlaps``, in how many runs) beside SUMO's own (``sumo_overlaps``).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

import pandas as pd

CATALOG = Path(__file__).resolve().parents[1] / "scenarios" / "catalog"

GRID3_SCENARIO = """\
[scenario]
name = "grid3"
duration_s = 40.0
step_s = 0.1
seed = 1

[road]
kind = "sumo_net"
net_file = "grid3.net.xml"
length_m = 420.0
route_turns = "any"

[traffic]
vehicles = 80
warm_up_s = 60.0
warm_seed = 1

[[obstacles]]
kind = "car"
lane = 0
position_m = 100.0

[[obstacles]]
kind = "car"
lane = 0
position_m = 200.0
lateral_offset_m = 3.0

[ego]
lane = 0
start_m = 10.0
speed_mps = 8.0

[lidar]
beams = 180
fov_deg = 180.0
max_range_m = 80.0

[controller]
name = "avoid"
"""

GRID3_SWEEP = """\
[sweep]
name = "{name}"
base = "grid3.toml"
samples = 40
sampler = "lhs"
seed = 61
controllers = ["avoid"]
egos_per_world = {egos}

[sweep.params]
"ego.speed_mps" = {{ uniform = [5.0, 10.0] }}
"obstacles[0].kind" = {{ choice = ["car", "truck", "barrel"] }}
"obstacles[0].position_m" = {{ uniform = [20.0, 410.0] }}
"obstacles[1].kind" = {{ choice = ["car", "truck", "barrel"] }}
"obstacles[1].position_m" = {{ uniform = [20.0, 410.0] }}
"obstacles[1].lateral_offset_m" = {{ uniform = [-1.0, 3.0] }}
"""

CATALOG_SWEEP = """\
[sweep]
name = "{name}"
base = "{base}"
samples = 40
sampler = "lhs"
seed = {seed}
controllers = ["avoid"]
{extra}

[sweep.params]
{params}
"""

#: name: (the catalog sweep whose base and parameters it takes, extra [sweep] lines)
CATALOG_FAMILIES = {
    "a10": ("real-motorway-stop", ""),
    "braunschweig": ("real-people", ""),
    "town": ("grid-town", "warm_states = 3"),
}
FAMILIES = (*CATALOG_FAMILIES, "grid3", "grid3-k8")


def catalog_sweep_text(name: str) -> str:
    """The catalog family's sweep under ``avoid`` alone, its base named absolutely."""
    catalog_name, extra = CATALOG_FAMILIES[name]
    text = (CATALOG / "sweeps" / f"{catalog_name}.toml").read_text()
    base = text.split('base = "', 1)[1].split('"', 1)[0]
    seed = text.split("\nseed = ", 1)[1].split("\n", 1)[0]
    params = text.split("[sweep.params]\n", 1)[1]
    return CATALOG_SWEEP.format(name=name, base=(CATALOG / "sweeps" / base).resolve(),
                                seed=seed, extra=extra, params=params)


def write_sweep(name: str, folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    if name.startswith("grid3"):
        net = folder / "grid3.net.xml"
        if not net.exists():
            subprocess.run(["netgenerate", "--grid", "--grid.number", "4", "--grid.length",
                            "120", "--default.lanenumber", "2", "--default.lanewidth", "3.0",
                            "--default.speed", "13.89", "--no-turnarounds", "true",
                            "--default-junction-type", "traffic_light",
                            "--output-file", net.name], check=True, capture_output=True,
                           cwd=folder)
        (folder / "grid3.toml").write_text(GRID3_SCENARIO)
        text = GRID3_SWEEP.format(name=name, egos=8 if name.endswith("k8") else 1)
    else:
        text = catalog_sweep_text(name)
    path = folder / f"{name}-sweep.toml"
    path.write_text(text)
    return path


def run_family(name: str, out: Path, samples: int, workers: int) -> pd.DataFrame:
    sweep = write_sweep(name, out / "specs")
    runs = out / name
    resume = ["--resume"] if (runs / "manifest.json").exists() else []
    done = subprocess.run([sys.executable, "-m", "sdc", "sweep", str(sweep), "--out",
                           str(runs), "--samples", str(samples), "--workers", str(workers),
                           "--quiet", "--traces", "none", *resume], env=os.environ)
    if done.returncode not in (0, 1):  # 1: some runs failed, counted as errors here
        raise SystemExit(f"{name}: sdc sweep exited {done.returncode}")
    return pd.read_parquet(runs / "results.parquet")


def counts(series: pd.Series) -> str:
    return " ".join(f"{key}={n}" for key, n in series.value_counts().sort_index().items())


def summary(name: str, rows: pd.DataFrame) -> str:
    ok = rows[rows["status"] == "ok"]
    hit = ok[ok["collision"]]
    overlapped = ok["world_overlaps"] > 0
    return (f"{name}: runs={len(ok)} errors={len(rows) - len(ok)} "
            f"completed={int((ok['outcome'] == 'completed').sum())} "
            f"stuck={int((ok['outcome'] == 'stuck').sum())} "
            f"unfinished={int((ok['outcome'] == 'unfinished').sum())} "
            f"collided={len(hit)} | with: {counts(hit['collision_with']) or '-'} "
            f"| role: {counts(hit['collision_role']) or '-'} "
            f"| world_overlaps={int(ok['world_overlaps'].sum())} steps in "
            f"{int(overlapped.sum())} runs, sumo_overlaps={int(ok['sumo_overlaps'].sum())}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("families", nargs="*", default=list(FAMILIES), choices=FAMILIES)
    parser.add_argument("--out", type=Path, default=Path("runs/avoid-city-families"))
    parser.add_argument("--samples", type=int, default=40)
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    for name in args.families:
        print(summary(name, run_family(name, args.out, args.samples, args.workers)),
              flush=True)


if __name__ == "__main__":
    main()
