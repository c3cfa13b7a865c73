"""The straddle family (issue 61): does traffic drive through an ego that a controller
steers over a lane line and holds there?

A straight built two-lane road of each lane width, 600 veh/h a lane at 27 m/s from
its start; the ego from 200 m at 8 m/s under ``examples/straddler.py``, its body
0.5-0.9 m over its left line (from the right lane) or its right line (from the left
lane). Each run is judged on its trace with ``boxes_overlap`` (never a gap clamped at
0): the runs in which a traffic body overlapped the ego, and the least gap of a body
beside it in the lane it reaches into. With ``--three-lanes`` the second family: three
lanes, the ego in the middle one at 6 m/s reaching over its right line, traffic at
22 m/s. Prints one line a width::

    python benchmarks/straddle_family.py [--widths 2.8,3.0] [--seeds 20] [--workers 2]
    python benchmarks/straddle_family.py --three-lanes --widths 2.9,3.1
"""

from __future__ import annotations

import argparse
import copy
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from scenarios import CATALOG_DIR
from scenarios.scene import traffic_model
from scenarios.spec.bodies import VEHICLE_MODELS
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.spec.toml_io import read_toml
from scenarios.world_backends import make_road
from sdc.car.geometry import box_gap_m, boxes_overlap
from sdc.run.episode import run_episode

STRADDLER = Path(__file__).resolve().parents[1] / "examples" / "straddler.py"


def family_spec(width_m: float, seed: int, reach_m: float, side: int,
                three_lanes: bool = False) -> ScenarioSpec:
    """A run of the family; ``three_lanes``: the second family (three lanes, the ego
    in the middle one at 6 m/s reaching over its right line, traffic at 22 m/s)."""
    lanes, ego_mps, traffic_mps = (3, 6.0, 22.0) if three_lanes else (2, 8.0, 27.0)
    plain = copy.deepcopy(read_toml(CATALOG_DIR / "seed-lesson.toml"))
    plain["scenario"].update(seed=seed, duration_s=60.0, step_s=0.1)
    plain["road"].update(length_m=1000.0, lanes=lanes, lane_width_m=width_m,
                         speed_limit_mps=33.33)
    plain["traffic"] = {"flow_vph_per_lane": 600.0, "speed_mean_mps": traffic_mps,
                        "speed_dev": 0.1}
    plain["obstacles"] = []
    lane = 1 if three_lanes else (0 if side > 0 else 1)
    plain["ego"].update(lane=lane, start_m=200.0, speed_mps=ego_mps)
    plain["controller"] = {"name": f"{STRADDLER}:Straddler", "reach_m": reach_m,
                           "side": side, "speed_mps": ego_mps}
    return ScenarioSpec.from_plain(plain)


def one_run(case: tuple[float, int, float, int, bool]) -> dict:
    """One run of the family, judged on its trace."""
    width_m, seed, reach_m, side, three_lanes = case
    spec = family_spec(width_m, seed, reach_m, side, three_lanes)
    episode = run_episode(spec)
    road, model = make_road(spec), VEHICLE_MODELS[spec.vehicle.model]
    line_d_m = road.lane_center_d_m(spec.ego.lane) + side * width_m / 2
    floats = episode.trace.floats
    through, least_m, beside = 0, np.inf, 0
    for k, traffic in enumerate(episode.trace.traffic):
        boxes = np.asarray(traffic, float).reshape(-1, 5)
        if not len(boxes):
            continue
        ego = np.array([floats["x_m"][k], floats["y_m"][k], floats["yaw_rad"][k],
                        model.length_m, model.width_m])
        through += int(boxes_overlap(ego, boxes).any())
        (ego_s,), _ = road.to_frenet(ego[None, :2])
        other_s, other_d = road.to_frenet(boxes[:, :2])
        by = (side * (other_d - line_d_m) > 0) & (np.abs(other_s - ego_s)
                                                  < (ego[3] + boxes[:, 3]) / 2)
        if by.any():
            beside += 1
            least_m = min(least_m, float(box_gap_m(ego, boxes[by]).min()))
    row = episode.row
    return {"width_m": width_m, "seed": seed, "reach_m": reach_m, "side": side,
            "through_steps": through, "least_beside_m": least_m, "beside_steps": beside,
            "collision_with": row["collision_with"], "world_overlaps": row["world_overlaps"],
            "blocks": traffic_model.blocks_neighbour(reach_m, width_m, 1.8)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--widths", default="2.8,3.0,3.2,3.5,3.75",
                        help="lane widths [m], comma-separated")
    parser.add_argument("--seeds", type=int, default=20, help="runs a width (sides alternate)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--three-lanes", action="store_true",
                        help="the second family: three lanes, the ego in the middle one at "
                             "6 m/s reaching over its right line, traffic at 22 m/s")
    args = parser.parse_args()
    cases = [(float(w), 94665 + k, 0.5 + 0.4 * k / max(1, args.seeds - 1),
              -1 if args.three_lanes or k % 2 else 1, args.three_lanes)
             for w in args.widths.split(",") for k in range(args.seeds)]
    with ProcessPoolExecutor(args.workers) as pool:
        rows = list(pool.map(one_run, cases))
    for width_m in sorted({r["width_m"] for r in rows}):
        mine = [r for r in rows if r["width_m"] == width_m]
        into = [r for r in mine if r["through_steps"]]
        passed = [r["least_beside_m"] for r in mine if r["beside_steps"]]
        least = f"{min(passed):.3f} m" if passed else "none passed"
        left = sum(r["side"] > 0 for r in into)
        print(f"width {width_m:.2f} m: traffic into the ego in {len(into)}/{len(mine)} runs "
              f"(left {left}, right {len(into) - left}); "
              f"collisions {sum(r['collision_with'] != 'none' for r in mine)}; "
              f"world_overlaps {sum(r['world_overlaps'] for r in mine)}; "
              f"passed beside in {len(passed)} runs, least gap {least}", flush=True)


if __name__ == "__main__":
    main()
