"""The true P(collision) of the catalog family seed-rare, from two grid sweeps.

    sdc sweep scenarios/catalog/sweeps/seed-rare-truth.toml --out runs/rare-truth
    sdc sweep scenarios/catalog/sweeps/seed-rare-check.toml --out runs/rare-check
    python truths/seed_rare_truth.py runs/rare-truth runs/rare-check [--write]

The family (scenarios/catalog/sweeps/seed-rare.toml) draws the ego's speed V
and the lane width W from independent normals. The road is straight, the car
starts on its lane's centre and senses the barrel, which stands on that
centre too, whatever W: W moves the road edges and nothing else, so the
car's path in its lane's frame depends on V alone. Its left corners swing
out to C(V) from the lane centre; the left edge is k W away (k = lanes - lane
- 1/2 = 2.5), so the run hits it exactly when k W < C(V), and

    P(collision) = E_V[ P(W < C(V) / k) ] = E_V[ Phi((C(V) / k - mean_W) / sd_W) ]

**The truth scan** (seed-rare-truth.toml) runs each speed of a fine grid once
on lanes so wide (W_ref = 5 m) that nothing is hit, and reads C(v) =
k W_ref - min_road_edge_gap_m. The right edge is as far away as the left
(the ego drives the middle of five lanes) and the car never swings right as
far as it swings left, so the gap is the left edge's; were it the right's,
C(v) would be over-stated (the gap is the nearer edge's), erring towards
more failures. The integral over the speed cells, with bounds from each
cell's neighbours, is :func:`analysis.rare.grid_probability.threshold_probability`.

**The check** (seed-rare-check.toml) is a plain grid over (V, W) that tests
the claim above run by run: in each speed column, the run at W = W_ref gives
the swing, and every other run must have min_road_edge_gap_m = that run's -
k (W_ref - W) (where the left edge is the nearer: the gap is never larger) and
collide exactly when that is below zero. The same grid also gives a coarser,
assumption-free estimate (:func:`analysis.rare.grid_probability.grid_probability`).

Prints the result as JSON; ``--write`` stores it beside the family as
``seed-rare.truth.json``.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd
from truth_sweeps import normal_params, publish, read_sweep, sweep_record  # beside this script

from analysis.rare.grid_probability import grid_probability, threshold_probability
from scenarios import CATALOG_DIR
from scenarios.spec.sweep_spec import load_sweep

FAMILY = CATALOG_DIR / "sweeps" / "seed-rare.toml"
TRUTH_FILE = CATALOG_DIR / "sweeps" / "seed-rare.truth.json"
SPEED, WIDTH = "ego.speed_mps", "road.lane_width_m"
GAP_TOLERANCE_M = 1e-6  # float noise between runs that should give the same corner positions


def nominal(path: Path = FAMILY) -> dict[str, tuple[float, float]]:
    """The family's ``(mean, sd)`` per parameter; refuses anything but two normals."""
    return normal_params(path, {SPEED, WIDTH})


def edge_factor(path: Path = FAMILY) -> float:
    """k: the left road edge's distance from the ego's lane centre, in lane widths."""
    base = load_sweep(path).base
    return base.road.lanes - base.ego.lane - 0.5


def swing_by_speed(rows: pd.DataFrame, k: float) -> tuple[float, pd.Series]:
    """W_ref and C(v) per speed from runs at one lane width (none may collide)."""
    widths = rows[f"p.{WIDTH}"].unique()
    if len(widths) != 1 or rows.collision.any():
        raise SystemExit("the truth scan must be at one lane width, without collisions")
    w_ref = float(widths[0])
    rows = rows.sort_values(f"p.{SPEED}")
    swing_m = k * w_ref - rows.min_road_edge_gap_m.to_numpy()
    return w_ref, pd.Series(swing_m, index=rows[f"p.{SPEED}"].to_numpy())


def check_shift(rows: pd.DataFrame, k: float) -> dict:
    """Each run of the (speed, width) grid against its speed column's widest-lane run."""
    w_ref = float(rows[f"p.{WIDTH}"].max())
    ref = rows[rows[f"p.{WIDTH}"] == w_ref].set_index(f"p.{SPEED}")
    if ref.collision.any():
        raise SystemExit(f"the check grid's widest lanes ({w_ref} m) must see no collision")
    ref_gap_m = rows[f"p.{SPEED}"].map(ref.min_road_edge_gap_m)
    predicted_m = ref_gap_m - k * (w_ref - rows[f"p.{WIDTH}"])
    collided = rows.collision.to_numpy()
    predicted_hit = (predicted_m < 0).to_numpy()
    passed = ~collided
    exact = passed & (np.abs(rows.min_road_edge_gap_m - predicted_m) <= GAP_TOLERANCE_M).to_numpy()
    nearer_right = passed & (rows.min_road_edge_gap_m < predicted_m - GAP_TOLERANCE_M).to_numpy()
    return {
        "runs": len(rows), "reference_width_m": w_ref,
        "collisions": int(collided.sum()),
        "collision_with": sorted(set(rows.collision_with[collided])),
        "outcome_mismatches": int(np.sum(collided != predicted_hit)),
        "passing_runs_gap_exact": int(exact.sum()),
        "passing_runs_right_edge_nearer": int(nearer_right.sum()),
        "passing_runs_gap_larger_than_predicted": int(np.sum(passed & ~exact & ~nearer_right)),
        "closest_predicted_gap_to_zero_m": float(np.min(np.abs(predicted_m))),
    }


def boundary_examples(swing_m: pd.Series, k: float, widths_m=(3.25, 3.5, 3.75),
                      margin_m: float = 0.01) -> list[dict]:
    """Per lane width, the first scan speed whose run must hit the left edge (predicted
    gap below -margin) and the last one before it that must pass (gap above margin)."""
    examples = []
    for width_m in widths_m:
        gap_m = k * width_m - swing_m.to_numpy()
        first_hit = int(np.argmax(gap_m < -margin_m))
        last_pass = int(np.flatnonzero(gap_m[:first_hit] > margin_m)[-1])
        for i, collision in ((last_pass, False), (first_hit, True)):
            examples.append({"lane_width_m": width_m, "speed_mps": float(swing_m.index[i]),
                             "collision": collision, "predicted_gap_m": float(gap_m[i])})
    return examples


def grid_estimate(rows: pd.DataFrame, normals: dict) -> dict:
    speeds = np.sort(rows[f"p.{SPEED}"].unique())
    widths = np.sort(rows[f"p.{WIDTH}"].unique())
    table = rows.pivot_table(index=f"p.{SPEED}", columns=f"p.{WIDTH}", values="collision",
                             aggfunc="first").reindex(index=speeds, columns=widths)
    failed = table.to_numpy(dtype=bool)
    result = grid_probability(failed, [speeds, widths], [normals[SPEED], normals[WIDTH]])
    faces = {"speed_min": failed[0].any(), "speed_max": failed[-1].any(),
             "width_min": failed[:, 0].any(), "width_max": failed[:, -1].any()}
    return {**result.to_plain(), "grid": [len(speeds), len(widths)],
            "collisions_on_box_faces": [name for name, hit in faces.items() if hit]}


def truth(scan_dir: Path, check_dir: Path) -> dict:
    normals, k = nominal(), edge_factor()
    scan_rows, scan_manifest = read_sweep(scan_dir)
    check_rows, check_manifest = read_sweep(check_dir)
    w_ref, swing_m = swing_by_speed(scan_rows, k)
    result = threshold_probability(swing_m.index.to_numpy(), swing_m.to_numpy() / k,
                                   normals[SPEED], normals[WIDTH])
    speeds = swing_m.index.to_numpy()
    # where the failure mass lies: the nominal density of the speed times P(W < C(v)/k)
    weight = np.gradient(speeds) * np.exp(-0.5 * ((speeds - normals[SPEED][0])
                                                  / normals[SPEED][1]) ** 2)
    weight = weight * pd.Series(swing_m.to_numpy() / k).map(
        lambda t: 0.5 * math.erfc(-(t - normals[WIDTH][0]) / (normals[WIDTH][1] * math.sqrt(2))))
    likeliest = int(np.argmax(weight))
    return {
        "family": "scenarios/catalog/sweeps/seed-rare.toml",
        "nominal": {name: {"normal": list(ms)} for name, ms in normals.items()},
        "failure": "road_edge (the left edge) when 2.5 * lane_width_m < C(speed), the swing",
        "p_true": result.p, "p_low": result.low, "p_high": result.high,
        "bound": result.bound, "bound_relative": result.bound / result.p,
        "method": ("C(v) from one run per speed at lane width W_ref; P = sum over speed "
                   "cells of nominal mass x Phi((C(v)/2.5 - mean_w)/sd_w); bounds from each "
                   "cell's neighbours' C; plus the nominal mass outside the speed grid "
                   "(truths/seed_rare_truth.py)"),
        "truth_scan": {**sweep_record(scan_dir, scan_rows, scan_manifest),
                       "file": "scenarios/catalog/sweeps/seed-rare-truth.toml",
                       "reference_width_m": w_ref, "speed_grid": [float(speeds[0]),
                                                                  float(speeds[-1]), len(speeds)],
                       "outside_mass": result.outside_mass,
                       # C(v) at the grid's speeds (np.linspace of speed_grid), to recompute
                       # the integral without SUMO; rounded to the micrometre
                       "swing_m": [round(float(c), 6) for c in swing_m.to_numpy()],
                       "speed_cells_with_bound": result.boundary_cells},
        "boundary_examples": boundary_examples(swing_m, k),
        "likeliest_failure": {"speed_mps": float(speeds[likeliest]),
                              "lane_width_below_m": float(swing_m.iloc[likeliest] / k)},
        "check": {**sweep_record(check_dir, check_rows, check_manifest),
                  "file": "scenarios/catalog/sweeps/seed-rare-check.toml",
                  **check_shift(check_rows, k),
                  "grid_estimate": grid_estimate(check_rows, normals)},
        "commands": [
            "sdc sweep scenarios/catalog/sweeps/seed-rare-truth.toml --out runs/rare-truth",
            "sdc sweep scenarios/catalog/sweeps/seed-rare-check.toml --out runs/rare-check",
            "python truths/seed_rare_truth.py runs/rare-truth runs/rare-check --write",
        ],
    }


def failed_checks(result: dict) -> list[str]:
    """What must hold of the truth before it is written: the check grid agrees with the
    shift claim run by run, only the road edge is hit, and P is rare, tight and inside
    the grid's own bounds."""
    p, check, grid = result["p_true"], result["check"], result["check"]["grid_estimate"]
    claims = {
        "the check grid contradicts the shift claim (an outcome)":
            check["outcome_mismatches"] == 0,
        "the check grid contradicts the shift claim (a gap larger than predicted)":
            check["passing_runs_gap_larger_than_predicted"] == 0,
        "something other than the road edge was hit": check["collision_with"] == ["road_edge"],
        "P is not rare (1e-4 to 1e-2)": 1e-4 <= p <= 1e-2,
        "P lies outside its bounds": result["p_low"] <= p <= result["p_high"],
        "the bounds are not within 10 % of P": result["bound"] < 0.1 * p,
        "the speed grid leaves out too much mass":
            result["truth_scan"]["outside_mass"] < 1e-3 * p,
        "the check grid's own bounds do not hold P": grid["low"] <= p <= grid["high"],
    }
    return [claim for claim, holds in claims.items() if not holds]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scan_dir", type=Path, help="output of seed-rare-truth.toml")
    parser.add_argument("check_dir", type=Path, help="output of seed-rare-check.toml")
    parser.add_argument("--write", action="store_true", help=f"store as {TRUTH_FILE.name}")
    args = parser.parse_args(argv)
    result = truth(args.scan_dir, args.check_dir)
    return publish(result, failed_checks(result), TRUTH_FILE, args.write)


if __name__ == "__main__":
    sys.exit(main())
