"""The true P(collision) of the catalog family seed-modes, from four grid sweeps.

    S=scenarios/catalog/sweeps
    sdc sweep $S/seed-modes-truth-speed.toml --out runs/modes-speed --traces none
    sdc sweep $S/seed-modes-truth-left.toml --out runs/modes-left --traces none
    sdc sweep $S/seed-modes-truth-right.toml --out runs/modes-right --traces none
    sdc sweep $S/seed-modes-check.toml --out runs/modes-check --traces none
    python truths/seed_modes_truth.py runs/modes-speed runs/modes-left runs/modes-right \\
        runs/modes-check [--write]

The family (scenarios/catalog/sweeps/seed-modes.toml) draws the ego's speed V and
the barrel's lateral offset D from the lane centre (+ = left) from independent
normals. The seed maneuver starts when one of its 11 central lidar beams (+-5
degrees) reads under 5 m. The beam at 5 degrees on the barrel's side enters the
0.6 m barrel through its inner side, |D| - 0.3 m from the car's centre line, at
the range (|D| - 0.3) / sin(5 deg), whatever the speed: it does so while the car
covers 0.6 m (the barrel's length), more than the 0.1 to 0.36 m it moves in one
64 ms control period at 1.6 to 5.6 m/s, so some period always sees that range.
The barrel is detected exactly when |D| < d* = 0.3 + 5 sin(5 deg) = 0.7358 m.
Then:

* |D| < d* (detected, the maneuver runs): the open-loop swing is the same
  whatever D, so the left road edge is hit exactly when V > v_e (road_edge);
  below 1.7 to 2.5 m/s (depending on D) the maneuver ends before the car is past
  the barrel and the return steers into it (obstacle): a small fourth region,
  the low-speed one.
* d* < |D| < f (undetected, and in the car's way; f = 0.3 m + the car's half
  width): the car drives into the barrel at any speed (obstacle).
* |D| > f: the barrel is missed, and no maneuver starts: no collision.

So, up to the small low-speed region, the failures are three boxes in (V, D):

    road_edge:        V > v_e,       -d*_R < D < d*_L
    obstacle, left:   any V,          d*_L < D < f_L
    obstacle, right:  any V,         -f_R  < D < -d*_R

and P(collision) is their nominal mass (:func:`analysis.rare.grid_probability.box_probability`)
plus the low-speed region's. The corner V > v_e with the barrel undetected is the
obstacle modes' (the car hits the barrel there; it never swings).

**The fine scans** locate v_e (seed-modes-truth-speed.toml: speeds 0.025 mm/s apart
at five offsets) and d*_L, d*_R (seed-modes-truth-left/right.toml: offsets 0.01 mm
apart at six speeds); each boundary must sit between the same two scan values at
every value of the other parameter, and the road-edge gap of the speed scan must
not depend on the offset. **The check** (seed-modes-check.toml) is a 121 x 121 grid
over (V, D) at +-8 standard deviations: every run must collide or pass, with the
right collision_with, as the boxes above say (with v_e and d* from the fine scans,
f from the grid itself, the same in every row); the maneuver must start exactly in
the detected band; in each speed row the road-edge gap must be one value across
the detected band. The low-speed region is measured on the grid (it must be, in
every offset column, a run of the lowest speeds) and integrated there
(:func:`analysis.rare.grid_probability.grid_probability`). The grid also gives an
assumption-free coarse estimate of the whole.

Bounds: each boundary anywhere within its scan bracket (the modes' ``p_low`` and
``p_high``); the total's are the sums of the modes' (valid, as the modes are
disjoint), its high bound including the nominal mass outside the check grid's box.

Prints the result as JSON; ``--write`` stores it beside the family as
``seed-modes.truth.json``.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd
from truth_sweeps import normal_params, publish, read_sweep, sweep_record  # beside this script

from analysis.measures.run_score import run_score
from analysis.rare.grid_probability import Bracket, box_probability, grid_probability
from scenarios import CATALOG_DIR

SWEEPS = "scenarios/catalog/sweeps"
FAMILY = CATALOG_DIR / "sweeps" / "seed-modes.toml"
TRUTH_FILE = CATALOG_DIR / "sweeps" / "seed-modes.truth.json"
SPEED, OFFSET = "ego.speed_mps", "obstacles[0].lateral_offset_m"
V, D = f"p.{SPEED}", f"p.{OFFSET}"
GAP_TOLERANCE_M = 1e-6  # float noise between runs that should give the same corner positions
EVERYWHERE: tuple[Bracket, Bracket] = ((-math.inf, -math.inf), (math.inf, math.inf))
COMMANDS = [
    f"sdc sweep {SWEEPS}/seed-modes-truth-speed.toml --out runs/modes-speed --traces none",
    f"sdc sweep {SWEEPS}/seed-modes-truth-left.toml --out runs/modes-left --traces none",
    f"sdc sweep {SWEEPS}/seed-modes-truth-right.toml --out runs/modes-right --traces none",
    f"sdc sweep {SWEEPS}/seed-modes-check.toml --out runs/modes-check --traces none",
    "python truths/seed_modes_truth.py runs/modes-speed runs/modes-left runs/modes-right "
    "runs/modes-check --write",
]


class StructureError(SystemExit):
    """A scan contradicts the structure the integral rests on: there is no truth."""

    def __init__(self, message: str):
        super().__init__(f"the structure does not hold: {message}")


def nominal(path: Path = FAMILY) -> dict[str, tuple[float, float]]:
    """The family's ``(mean, sd)`` per parameter; refuses anything but the two normals."""
    return normal_params(path, {SPEED, OFFSET})


def outcomes(rows: pd.DataFrame) -> np.ndarray:
    """What each run hit: ``collision_with``, or ``none`` without a collision."""
    return np.where(rows.collision.to_numpy(), rows.collision_with.to_numpy(), "none")


def switch(values: np.ndarray, flags: np.ndarray, what: str) -> Bracket:
    """``(last value without the flag, first value with it)`` along increasing values,
    where the flag must switch exactly once, from off to on."""
    order = np.argsort(values)
    v, f = np.asarray(values, float)[order], np.asarray(flags, bool)[order]
    changes = np.flatnonzero(f[1:] != f[:-1])
    if len(changes) != 1 or f[0] or not f[-1]:
        raise StructureError(f"{what}: expected one switch from off to on, found "
                             f"{len(changes)} changes (first {f[0]}, last {f[-1]})")
    return float(v[changes[0]]), float(v[changes[0] + 1])


def beside(bracket: Bracket, value: float) -> str:
    """Which side of a bracket a scanned value is on; one inside it has no side."""
    if bracket[0] < value < bracket[1]:
        raise StructureError(f"{value} lies inside the bracket {bracket}")
    return "below" if value <= bracket[0] else "above"


def speed_scan(rows: pd.DataFrame) -> dict:
    """v_e from the fine speed scan: one bracket at every offset, the road edge the
    only thing hit, and the road-edge gap the same at every offset."""
    brackets = {}
    for offset, column in rows.groupby(D):
        hit = sorted(set(outcomes(column)) - {"none"})
        if hit != ["road_edge"]:
            raise StructureError(f"speed scan at offset {offset}: collisions with {hit}")
        brackets[float(offset)] = switch(column[V].to_numpy(), column.collision.to_numpy(),
                                         f"speed scan at offset {offset}")
    if len(set(brackets.values())) != 1:
        raise StructureError(f"the speed boundary moves with the offset: {brackets}")
    spread = rows.groupby(V).min_road_edge_gap_m.agg(lambda g: g.max() - g.min())
    if spread.max() > GAP_TOLERANCE_M:
        raise StructureError(f"the road-edge gap depends on the offset at speed "
                             f"{spread.idxmax()} (by {spread.max()} m)")
    bracket = next(iter(brackets.values()))
    gap = rows.groupby(V).min_road_edge_gap_m.first()
    below, above = gap[bracket[0]], gap[bracket[1]]
    return {"bracket_mps": list(bracket), "offsets_m": sorted(brackets),
            "gap_at_bracket_m": [float(below), float(above)],
            # where the road-edge gap, linear between the two, crosses zero
            "interpolated_mps": bracket[0] + (bracket[1] - bracket[0]) * below / (below - above),
            "gap_spread_across_offsets_m": float(spread.max()), "gap_by_speed": gap}


def offset_scan(rows: pd.DataFrame, side: str, speed_bracket: Bracket) -> dict:
    """d* on one side from its fine scan: at every speed the barrel is hit (and nothing
    else) exactly beyond one bracket of |offset|, the same at every speed; inside it the
    run passes, or hits the road edge above v_e; the maneuver starts exactly inside."""
    brackets = {}
    for speed, row in rows.groupby(V):
        reach = row[D].abs().to_numpy()
        what = outcomes(row)
        bracket = switch(reach, what == "obstacle", f"{side} scan at speed {speed}")
        inside_expected = "road_edge" if beside(speed_bracket, speed) == "above" else "none"
        inside = reach <= bracket[0]
        if set(what[inside]) != {inside_expected}:
            raise StructureError(f"{side} scan at speed {speed}: {set(what[inside])} inside "
                                 f"the detection boundary, expected {inside_expected}")
        if not np.array_equal(row.maneuver_started.to_numpy(), inside):
            raise StructureError(f"{side} scan at speed {speed}: the maneuver does not start "
                                 f"exactly where the barrel is within the boundary")
        brackets[float(speed)] = bracket
    if len(set(brackets.values())) != 1:
        raise StructureError(f"the {side} offset boundary moves with the speed: {brackets}")
    return {"bracket_m": list(next(iter(brackets.values()))), "speeds_mps": sorted(brackets)}


def check_grid(rows: pd.DataFrame, speed_bracket: Bracket, left: Bracket,
               right: Bracket) -> dict:
    """Every run of the (speed, offset) grid against the boxes; the far edges and the
    low-speed region measured on the grid."""
    speed, offset = rows[V].to_numpy(), rows[D].to_numpy()
    what = outcomes(rows)
    for value in np.unique(speed):
        beside(speed_bracket, value)
    for value in np.unique(offset):
        beside(left if value >= 0 else right, abs(value))
    detected = np.where(offset >= 0, offset <= left[0], -offset <= right[0])
    far = {}
    for name, sign, edge in (("left", 1, left), ("right", -1, right)):
        beyond = sign * offset >= edge[1]
        brackets = set()
        for value in np.unique(speed):
            here = beyond & (speed == value)
            brackets.add(switch(sign * offset[here], what[here] == "none",
                                f"beyond the {name} boundary at speed {value}"))
        if len(brackets) != 1:
            raise StructureError(f"the far {name} edge moves with the speed: {brackets}")
        far[name] = brackets.pop()
    in_way = np.where(offset >= 0, offset <= far["left"][0], -offset <= far["right"][0])
    fast = speed >= speed_bracket[1]
    predicted = np.where(detected, np.where(fast, "road_edge", "none"),
                         np.where(in_way, "obstacle", "none"))
    low_speed = detected & ~fast & (what == "obstacle")
    mismatches = (what != predicted) & ~low_speed

    speeds, offsets = np.unique(speed), np.unique(offset)
    table = pd.DataFrame({"v": speed, "d": offset, "low": low_speed}).pivot_table(
        index="v", columns="d", values="low", aggfunc="first").reindex(
        index=speeds, columns=offsets)
    low_grid = table.to_numpy(dtype=bool)
    last_low = []  # per offset column, the fastest low-speed hit (None: none)
    for j in range(len(offsets)):
        hits = np.flatnonzero(low_grid[:, j])
        if len(hits) and not np.array_equal(hits, np.arange(hits[-1] + 1)):
            raise StructureError(f"the low-speed hits at offset {offsets[j]} are not the "
                                 f"lowest speeds of the column: {speeds[hits]}")
        last_low.append(float(speeds[hits[-1]]) if len(hits) else None)

    # the road-edge gap across the detected band of each speed row (the swing), and
    # where nothing was detected (no maneuver: the lane's own edge distance)
    gaps = rows.min_road_edge_gap_m.to_numpy()
    spread = pd.Series(gaps[detected]).groupby(speed[detected]).agg(lambda g: g.max() - g.min())
    undetected_gaps = gaps[~detected & (what == "none")]
    return {
        "runs": len(rows), "collisions": int(rows.collision.sum()),
        "collision_with": sorted(set(what) - {"none"}),
        "outcome_mismatches": int(mismatches.sum()),
        "maneuver_mismatches": int(np.sum(rows.maneuver_started.to_numpy() != detected)),
        "road_edge_gap_spread_in_detected_band_m": float(spread.max()),
        "road_edge_gap_without_maneuver_m": [float(undetected_gaps.min()),
                                             float(undetected_gaps.max())],
        "far_edge_brackets_m": {name: list(b) for name, b in far.items()},
        "low_speed_hits": int(low_speed.sum()),
        "low_speed_fastest_hit_mps": float(speed[low_speed].max()) if low_speed.any() else None,
        "speed_grid": [float(speeds[0]), float(speeds[-1]), len(speeds)],
        "offset_grid": [float(offsets[0]), float(offsets[-1]), len(offsets)],
        # per offset column (np.linspace of offset_grid), the fastest speed whose run hit
        # the barrel on the return: every slower run of that column hit it too
        "low_speed_last_hit_by_offset_mps": last_low,
    }


def low_speed_mode(check: dict, normals: dict) -> dict:
    """The grid mass of the low-speed hits, rebuilt from what ``check`` records."""
    speeds, offsets = np.linspace(*check["speed_grid"]), np.linspace(*check["offset_grid"])
    last = np.array([-np.inf if t is None else t
                     for t in check["low_speed_last_hit_by_offset_mps"]])
    failed = speeds[:, None] <= last[None, :] + 1e-9
    return grid_probability(failed, [speeds, offsets],
                            [normals[SPEED], normals[OFFSET]]).to_plain()


def modes(boundaries: dict, check: dict, normals: dict) -> list[dict]:
    """The failure modes' probabilities from the located boundaries (see the docstring)."""
    v_e = tuple(boundaries["speed_mps"])
    d_l, d_r = tuple(boundaries["left_offset_m"]), tuple(boundaries["right_offset_m"])
    f_l, f_r = tuple(boundaries["far_left_offset_m"]), tuple(boundaries["far_right_offset_m"])
    both = [normals[SPEED], normals[OFFSET]]

    def neg(b: Bracket) -> Bracket:
        return -b[1], -b[0]

    mid = {name: sum(b) / 2 for name, b in boundaries.items()}
    boxes = [
        ("road_edge", f"speed above {mid['speed_mps']:.5f} m/s with the barrel within "
         f"{mid['right_offset_m']:.5f} m right to {mid['left_offset_m']:.5f} m left of the "
         f"lane centre (detected): the swing reaches the left road edge",
         [(v_e, EVERYWHERE[1]), (neg(d_r), d_l)]),
        ("obstacle", f"the barrel {mid['left_offset_m']:.5f} to {mid['far_left_offset_m']:.3f} m "
         f"left of the lane centre, any speed: undetected and driven into (with the corner "
         f"above {mid['speed_mps']:.4f} m/s)", [EVERYWHERE, (d_l, f_l)]),
        ("obstacle", f"the barrel {mid['right_offset_m']:.5f} to {mid['far_right_offset_m']:.3f} "
         f"m right of the lane centre, any speed: undetected and driven into (with the "
         f"corner above {mid['speed_mps']:.4f} m/s)", [EVERYWHERE, (neg(f_r), neg(d_r))]),
    ]
    result = []
    for name, (outcome, region, sides) in zip(("speed", "left", "right"), boxes, strict=True):
        box = box_probability(sides, both)
        result.append({"name": name, "outcome": outcome, "region": region,
                       "p": box.p, "p_low": box.low, "p_high": box.high})
    low = low_speed_mode(check, normals)
    result.append({
        "name": "low_speed", "outcome": "obstacle",
        "region": (f"speed below about {check['low_speed_fastest_hit_mps']:.2f} m/s (the "
                   "limit depends on the offset) with the barrel detected: the return steers "
                   "into it; integrated on the check grid, whose high bound includes the mass "
                   "outside the grid's box"),
        "p": low["p"], "p_low": low["low"], "p_high": low["high"]})
    return result


def score_profiles(check_rows: pd.DataFrame, scans: dict[str, pd.DataFrame],
                   at_speed: float = 3.6, at_offset: float = 0.0) -> dict:
    """The default search score (``gap``) and ``min_ttc_s`` approaching each boundary from
    the nominal: grid runs along the nominal's row and column, then the fine scan's last
    run before the boundary."""
    def points(rows: pd.DataFrame, along: str) -> list[dict]:
        return [{"value": round(float(r[along]), 6), "collision_with": r["collision_with"],
                 "score": round(run_score(r.to_dict()), 6),
                 "min_gap_obstacle_m": round(float(r.min_gap_obstacle_m), 6),
                 "min_road_edge_gap_m": round(float(r.min_road_edge_gap_m), 6),
                 "min_ttc_s": None if np.isnan(r.min_ttc_s) else round(float(r.min_ttc_s), 3)}
                for _, r in rows.iterrows()]

    row = check_rows[np.isclose(check_rows[V], at_speed)].sort_values(D)
    column = check_rows[np.isclose(check_rows[D], at_offset, atol=1e-9)].sort_values(V)
    last_pass = {}
    for name, rows, along, fixed, at in (("speed", scans["speed"], V, D, at_offset),
                                         ("left", scans["left"], D, V, at_speed),
                                         ("right", scans["right"], D, V, at_speed)):
        line = rows[np.isclose(rows[fixed], at, atol=1e-9)]
        line = line[~line.collision].sort_values(along, key=abs)
        last_pass[name] = points(line.tail(1), along)
    return {
        "speed_at_offset_0": points(column[(column[V] >= at_speed)
                                           & (column[V] < 4.6)].iloc[::3], V)
        + last_pass["speed"],
        "left_at_3.6_mps": points(row[(row[D] >= 0) & (row[D] < 0.8)].iloc[::3], D)
        + last_pass["left"],
        "right_at_3.6_mps": points(row[(row[D] <= 0) & (row[D] > -0.8)].iloc[::-3], D)
        + last_pass["right"],
        "low_speed_at_offset_0": points(column[(column[V] <= at_speed)
                                               & (column[V] > 2.0)].iloc[::-3], V),
        "far_left_at_3.6_mps_from_outside": points(row[row[D] > 1.2].iloc[::-2], D),
    }


def boundary_examples(speed: dict, left_rows: pd.DataFrame, right_rows: pd.DataFrame,
                      boundaries: dict, check: dict, margin_gap_m: float = 0.01,
                      margin_offset_m: float = 5e-4) -> list[dict]:
    """Runs for a test to repeat: per boundary, a scanned value just on each side of it
    (the speed's by a road-edge gap beyond +-margin_gap_m, the offsets' by
    margin_offset_m) at two values of the other parameter, with what must happen."""
    examples = []
    gap = speed["gap_by_speed"]
    last_pass = float(gap[gap > margin_gap_m].index.max())
    first_hit = float(gap[gap < -margin_gap_m].index.min())
    for offset in (0.0, 0.73):
        for v, collision in ((last_pass, False), (first_hit, True)):
            examples.append({"boundary": "speed", "speed_mps": v, "lateral_offset_m": offset,
                             "collision": collision,
                             "collision_with": "road_edge" if collision else "none",
                             "predicted_road_edge_gap_m": float(gap[v])})
    for name, rows, sign in (("left", left_rows, 1), ("right", right_rows, -1)):
        bracket = boundaries[f"{name}_offset_m"]
        reach = np.unique(rows[D].abs())
        inside = float(reach[reach <= bracket[0] - margin_offset_m].max())
        outside = float(reach[reach >= bracket[1] + margin_offset_m].min())
        for v in (3.6, 4.6):
            fast = beside(tuple(boundaries["speed_mps"]), v) == "above"
            for reach_m, collision_with in ((inside, "road_edge" if fast else "none"),
                                            (outside, "obstacle")):
                examples.append({"boundary": name, "speed_mps": v,
                                 "lateral_offset_m": sign * reach_m,
                                 "collision": collision_with != "none",
                                 "collision_with": collision_with})
    for name, sign in (("far_left", 1), ("far_right", -1)):
        inner, outer = boundaries[f"{name}_offset_m"]
        for reach_m, collision_with in ((inner, "obstacle"), (outer, "none")):
            examples.append({"boundary": name, "speed_mps": 3.6,
                             "lateral_offset_m": sign * reach_m,
                             "collision": collision_with != "none",
                             "collision_with": collision_with})
    offsets = np.linspace(*check["offset_grid"])
    centre = int(np.argmin(np.abs(offsets)))
    last_hit = check["low_speed_last_hit_by_offset_mps"][centre]
    speeds = np.linspace(*check["speed_grid"])
    after = float(speeds[np.flatnonzero(speeds > last_hit + 1e-9)[0]])
    for v, collision_with in ((last_hit, "obstacle"), (after, "none")):
        examples.append({"boundary": "low_speed", "speed_mps": v,
                         "lateral_offset_m": float(offsets[centre]),
                         "collision": collision_with != "none", "collision_with": collision_with})
    return examples


def truth(speed_dir: Path, left_dir: Path, right_dir: Path, check_dir: Path) -> dict:
    normals = nominal()
    read = {name: read_sweep(path) for name, path in
            (("speed", speed_dir), ("left", left_dir), ("right", right_dir), ("check", check_dir))}
    speed = speed_scan(read["speed"][0])
    v_e = tuple(speed["bracket_mps"])
    left = offset_scan(read["left"][0], "left", v_e)
    right = offset_scan(read["right"][0], "right", v_e)
    check = check_grid(read["check"][0], v_e, tuple(left["bracket_m"]),
                       tuple(right["bracket_m"]))
    boundaries = {"speed_mps": speed["bracket_mps"], "left_offset_m": left["bracket_m"],
                  "right_offset_m": right["bracket_m"],
                  "far_left_offset_m": check["far_edge_brackets_m"]["left"],
                  "far_right_offset_m": check["far_edge_brackets_m"]["right"]}
    found = modes(boundaries, check, normals)
    total = {key: sum(m[key] for m in found) for key in ("p", "p_low", "p_high")}
    check_rows = read["check"][0]
    collided = check_rows.pivot_table(index=V, columns=D, values="collision", aggfunc="first")
    grid = grid_probability(collided.to_numpy(dtype=bool),
                            [collided.index.to_numpy(), collided.columns.to_numpy()],
                            [normals[SPEED], normals[OFFSET]])

    def record(name: str, extra: dict) -> dict:
        path = {"speed": speed_dir, "left": left_dir, "right": right_dir, "check": check_dir}
        rows, manifest = read[name]
        stem = manifest["sweep"]["sweep"]["name"]
        return {**sweep_record(path[name], rows, manifest), "file": f"{SWEEPS}/{stem}.toml",
                **extra}

    return {
        "family": f"{SWEEPS}/seed-modes.toml",
        "nominal": {name: {"normal": list(ms)} for name, ms in normals.items()},
        "failure": ("road_edge (the left edge) when speed > v_e and the barrel is detected "
                    "(|offset| < d*); obstacle when d* < |offset| < f (undetected, in the way), "
                    "at any speed, or at low speed when detected (the return hits it)"),
        "p_true": total["p"], "p_low": total["p_low"], "p_high": total["p_high"],
        "bound": max(total["p"] - total["p_low"], total["p_high"] - total["p"]),
        "bound_relative": max(total["p"] - total["p_low"], total["p_high"] - total["p"])
        / total["p"],
        "method": ("three boxes in (speed, offset) whose faces the fine scans bracket, each "
                   "the product of two normal CDF differences, plus the low-speed region's "
                   "mass on the check grid; p with every face at its bracket's midpoint, "
                   "bounds with every face at its bracket's ends "
                   "(truths/seed_modes_truth.py)"),
        "modes": found,
        "boundaries": {
            **boundaries,
            "speed_interpolated_mps": speed["interpolated_mps"],
            "detection_offset_geometry_m": 0.3 + 5.0 * math.sin(math.radians(5.0)),
        },
        "score": score_profiles(check_rows, {n: read[n][0] for n in ("speed", "left", "right")}),
        "boundary_examples": boundary_examples(speed, read["left"][0], read["right"][0],
                                               boundaries, check),
        "scans": {
            "speed": record("speed", {
                "bracket_mps": speed["bracket_mps"], "offsets_m": speed["offsets_m"],
                "gap_at_bracket_m": speed["gap_at_bracket_m"],
                "gap_spread_across_offsets_m": speed["gap_spread_across_offsets_m"]}),
            "left": record("left", left),
            "right": record("right", right),
        },
        "check": record("check", {**check, "grid_estimate": {
            **grid.to_plain(), "grid": list(collided.shape)}}),
        "commands": COMMANDS,
    }


def failed_checks(result: dict) -> list[str]:
    """What must hold of the truth before it is written: the scans and the check grid
    agree with the structure, the boundaries lie where the geometry puts them, the gap
    score warns of the speed region only, and P is rare, tight and the sum of three modes
    of about a third each and a negligible fourth."""
    p, modes, check = result["p_true"], result["modes"], result["check"]
    b, scans, score = result["boundaries"], result["scans"], result["score"]
    toward_speed = [point["score"] for point in score["speed_at_offset_0"]]
    claims = {
        "the check grid contradicts the structure (an outcome)": check["outcome_mismatches"] == 0,
        "the check grid contradicts the structure (a maneuver)": check["maneuver_mismatches"] == 0,
        "the road-edge gap varies in the detected band":
            check["road_edge_gap_spread_in_detected_band_m"] <= GAP_TOLERANCE_M,
        "the speed scan's gap varies across offsets":
            scans["speed"]["gap_spread_across_offsets_m"] <= GAP_TOLERANCE_M,
        "too few scan lines": (len(scans["speed"]["offsets_m"]) >= 3
                               and len(scans["left"]["speeds_mps"]) >= 3
                               and len(scans["right"]["speeds_mps"]) >= 3),
        "something other than the obstacle or the road edge was hit":
            check["collision_with"] == ["obstacle", "road_edge"],
        "the check grid's own bounds do not hold P":
            check["grid_estimate"]["low"] <= p <= check["grid_estimate"]["high"],
        "the check grid leaves out too much mass":
            check["grid_estimate"]["outside_mass"] < 1e-6 * p,
        "an offset boundary is not where the detection's geometry puts it": all(
            b[side][0] <= b["detection_offset_geometry_m"] <= b[side][1]
            for side in ("left_offset_m", "right_offset_m")),
        "the speed boundary is not bracketed to 1e-4 m/s": (
            b["speed_mps"][1] - b["speed_mps"][0] < 1e-4
            and b["speed_mps"][0] <= b["speed_interpolated_mps"] <= b["speed_mps"][1]),
        "the gap score does not fall to 0 toward the speed boundary":
            toward_speed == sorted(toward_speed, reverse=True) and toward_speed[-1] < 0.01,
        "the gap score warns of an offset boundary": all(
            min(point["score"] for point in score[side]) > 2.0
            for side in ("left_at_3.6_mps", "right_at_3.6_mps")),
        "P is not rare (1e-4 to 1e-3)": 1e-4 <= p <= 1e-3,
        "P lies outside its bounds": result["p_low"] <= p <= result["p_high"],
        "the bounds are not within 1 % of P": result["bound"] < 0.01 * p,
        "the modes are not speed, left, right and low_speed":
            [(m["name"], m["outcome"]) for m in modes] == [
                ("speed", "road_edge"), ("left", "obstacle"), ("right", "obstacle"),
                ("low_speed", "obstacle")],
        "the modes do not add up to P": all(
            math.isclose(sum(m[key] for m in modes), result[total], rel_tol=1e-6)
            for key, total in (("p", "p_true"), ("p_low", "p_low"), ("p_high", "p_high"))),
        "a mode lies outside its bounds": all(m["p_low"] <= m["p"] <= m["p_high"]
                                              for m in modes),
        "the three modes are not about a third each":
            all(0.25 * p < m["p"] < 0.45 * p for m in modes[:3]),
        "the low-speed mode is not negligible": modes[3]["p_high"] < 1e-3 * p,
    }
    return [claim for claim, holds in claims.items() if not holds]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("speed_dir", type=Path, help="output of seed-modes-truth-speed.toml")
    parser.add_argument("left_dir", type=Path, help="output of seed-modes-truth-left.toml")
    parser.add_argument("right_dir", type=Path, help="output of seed-modes-truth-right.toml")
    parser.add_argument("check_dir", type=Path, help="output of seed-modes-check.toml")
    parser.add_argument("--write", action="store_true", help=f"store as {TRUTH_FILE.name}")
    args = parser.parse_args(argv)
    result = truth(args.speed_dir, args.left_dir, args.right_dir, args.check_dir)
    return publish(result, failed_checks(result), TRUTH_FILE, args.write)


if __name__ == "__main__":
    sys.exit(main())
