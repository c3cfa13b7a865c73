"""What the runs of a signalised city stood for: the family issue 62 was found on.

A 4 x 4 ``netgenerate`` city (two lanes each way of 3.0 m, sidewalks, crossings,
lights at every junction), 80 cars, a parked car and a standing person on the ego's
route; 40 samples under ``avoid`` and ``lane-keep``, 40 s each. It runs through the
CLI (``python -m sdc``), so the same script measures any checkout::

    python benchmarks/stood_for_city.py --out runs/stood-for
    PYTHONPATH=/tmp/old python benchmarks/stood_for_city.py --out runs/stood-for-old

Prints the report's verdict sentences, then a table of every stuck and unfinished
run: how long it stood, what it stood for (``stood_for``, where the checkout has it)
and how far ahead, with the light the trace recorded at the stop line ahead of its
front bumper as it ended. With ``--sheet F.png`` it draws the last step of each of
those that ended standing in one sheet (the stop lines in their lights' colours), to
look at.
"""

from __future__ import annotations

import argparse
import io
import os
import subprocess
import sys
from pathlib import Path

import pandas as pd

SCENARIO = """\
[scenario]
name = "city4"
duration_s = 40.0
step_s = 0.1
seed = 1

[road]
kind = "sumo_net"
net_file = "city4.net.xml"
length_m = 400.0
route_turns = "any"

[traffic]
vehicles = 80
warm_up_s = 60.0

[[obstacles]]
kind = "car"
lane = 0
position_m = 60.0

[[obstacles]]
kind = "pedestrian"
lane = 0
position_m = 250.0

[ego]
lane = 0
start_m = 10.0
speed_mps = 8.0

[controller]
name = "avoid"
"""

SWEEP = """\
[sweep]
name = "city4"
base = "city4.toml"
samples = 40
sampler = "lhs"
seed = 62
controllers = ["avoid", "lane-keep"]

[sweep.params]
"scenario.seed" = { int_range = [1, 1000] }
"ego.speed_mps" = { uniform = [5.0, 10.0] }
"obstacles[0].position_m" = { uniform = [30.0, 150.0] }
"obstacles[1].position_m" = { uniform = [160.0, 380.0] }
"""


def write_sweep(folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    net = folder / "city4.net.xml"
    if not net.exists():
        subprocess.run(["netgenerate", "--grid", "--grid.number", "4", "--grid.length", "120",
                        "--default.lanenumber", "2", "--default.lanewidth", "3.0",
                        "--default.speed", "13.89", "--sidewalks.guess", "--crossings.guess",
                        "--no-turnarounds", "true", "--default-junction-type", "traffic_light",
                        "--output-file", net.name], check=True, capture_output=True, cwd=folder)
    (folder / "city4.toml").write_text(SCENARIO)
    path = folder / "city4-sweep.toml"
    path.write_text(SWEEP)
    return path


def sdc(*args: str, check: tuple[int, ...] = (0, 1)) -> str:
    done = subprocess.run([sys.executable, "-m", "sdc", *args], env=os.environ,
                          capture_output=True, text=True)
    if done.returncode not in check:
        raise SystemExit(f"sdc {' '.join(args)} exited {done.returncode}: {done.stderr}")
    return done.stdout


def light_ahead(trace_path: Path) -> str:
    """The light the trace recorded at the first stop line ahead of the front bumper
    at the last step, and how far: ``r 1.5 m``, or ``-`` (none recorded)."""
    from analysis.measures.trace_file import read_trace

    trace, metadata = read_trace(trace_path)
    stops = metadata["road"].get("stops")
    if not stops or not trace.signals or not trace.signals[-1]:
        return "-"
    front_s_m = trace.floats["s_m"][-1] + metadata["vehicle"]["length_m"] / 2
    ahead = [(stop[0] - front_s_m, k) for k, stop in enumerate(stops)
             if stop[0] - front_s_m > -1.0]
    if not ahead:
        return "-"
    gap_m, k = min(ahead)
    return f"{trace.signals[-1][k]} {gap_m:.1f} m"


def looked_at(rows: pd.DataFrame, runs: Path) -> pd.DataFrame:
    columns = ["run_id", "outcome", "stood_at_end_s", "stood_for", "stood_for_gap_m",
               "stood_for_cycle_s"]
    table = rows[rows.outcome.isin(["stuck", "unfinished"])]
    table = table[[c for c in columns if c in table]].copy()
    table["light_ahead"] = [light_ahead(runs / "traces" / f"{r}.parquet")
                            for r in table.run_id]
    return table


def sheet(table: pd.DataFrame, runs: Path, out: Path) -> None:
    """The last step of each run of ``table``, drawn small, in one PNG."""
    from PIL import Image

    from analysis.measures.trace_file import read_trace
    from analysis.report.render import scene_from_trace, thumbnail_png

    tiles = []
    for run_id in table.run_id:
        trace, metadata = read_trace(runs / "traces" / f"{run_id}.parquet")
        scene = scene_from_trace(trace, metadata)
        tiles.append((run_id, Image.open(io.BytesIO(thumbnail_png(scene, len(trace) - 1)))))
    if not tiles:
        return
    width, height = tiles[0][1].size
    per_row = 4
    page = Image.new("RGB", (per_row * width, -(-len(tiles) // per_row) * (height + 14)),
                     "white")
    from PIL import ImageDraw

    draw = ImageDraw.Draw(page)
    for n, (run_id, tile) in enumerate(tiles):
        x, y = (n % per_row) * width, (n // per_row) * (height + 14)
        draw.text((x + 4, y), run_id, fill="black")
        page.paste(tile, (x, y + 14))
    page.save(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("runs/stood-for-city"))
    parser.add_argument("--samples", type=int, default=40)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--sheet", type=Path, help="draw the stuck and unfinished runs here")
    args = parser.parse_args()
    sweep = write_sweep(args.out / "specs")
    runs = args.out / "runs"
    resume = ["--resume"] if (runs / "manifest.json").exists() else []
    sdc("sweep", str(sweep), "--out", str(runs), "--samples", str(args.samples),
        "--workers", str(args.workers), "--quiet", "--traces", "all", *resume)
    report = sdc("report", str(runs))
    print("\n".join(line for line in report.splitlines()
                    if line.startswith(("avoid:", "lane-keep:")) or "too short" in line))
    rows = pd.read_parquet(runs / "results.parquet")
    table = looked_at(rows[rows.status == "ok"], runs)
    print(table.to_string(index=False))
    if args.sheet:  # the runs that ended standing
        sheet(table[table.stood_at_end_s > 0], runs, args.sheet)


if __name__ == "__main__":
    main()
