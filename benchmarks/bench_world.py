"""What the one-world traffic model costs (scenarios/scene/traffic_model.py), as ratios in one run.

For each scenario, paired measurements with the model's SUMO options and without
(``--lanechange.duration`` off: SUMO's one-step lane changes, the world before the
model), each a closed loop under lane keeping (bench_perf.closed_loop) and the
bare SUMO step of the same scenario with the same options (bench_perf.bare_sumo_ms):

- ``world.<name>.sumo_step_ratio``: SUMO's step inside our loop, with the model over
  without;
- ``world.<name>.step_ratio``: our whole closed-loop step, with over without;
- ``world.<name>.overhead_vs_bare_sumo``: our step over bare SUMO's, both with the
  model's options (``..._without``: both without);
- ``world.audit_ms_per_step``: the world audit (analysis.measures.world_audit) over a trace of
  the 100-vehicle highway, per step;
- ``world.ego_pose_us``: telling SUMO where the ego is (``scenarios.sumo.ego_pose``: its
  lateral position by the model's rule), per step, with the options or without.

Scenarios: ``highway_100`` (3 lanes, about 100 vehicles, bench_perf's), ``highway_20``
(about 20), ``town_2000`` (the catalog's grid-town, 2000 cars; its warm-up is
computed once per option set and cached).

    python benchmarks/bench_world.py

``SDC_BENCH_SMOKE=1``: the smoke size (benchmarks/smoke.py): one pair a scenario, at
bench_perf's smoke size (its timed steps, warm-ups and town).
"""

from __future__ import annotations

import statistics
import time

import bench_perf
import numpy as np
from smoke import size

from analysis.measures.world_audit import world_overlaps
from scenarios.scene import traffic_model
from scenarios.sumo.ego_pose import ego_pose
from scenarios.sumo.ego_slot import EgoSlot
from scenarios.sumo.routes_xml import TRAFFIC_WIDTH_M
from scenarios.world_backends import make_road
from sdc.run.episode import run_episode

PAIRS = size(3, 1)


def measured(spec, options, bare: bool = True) -> dict:
    """bench_perf's closed loop and bare step with ``options`` as the traffic model's
    SUMO options function."""
    traffic_model.sumo_options = options
    loop = bench_perf.closed_loop(spec)
    loop["bare_ms"] = bench_perf.bare_sumo_ms(spec) if bare else float("nan")
    return loop


def main() -> None:
    model = traffic_model.sumo_options
    scenarios = {"highway_100": (bench_perf.traffic_spec(3, 2500.0, 1100.0, 120.0), PAIRS),
                 "highway_20": (bench_perf.traffic_spec(3, 2500.0, 240.0, 100.0), PAIRS),
                 "town_2000": (bench_perf.town_spec(), 1)}
    for name, (spec, pairs) in scenarios.items():
        bare = name != "town_2000"  # the town's ego leaves its lane at junctions
        runs = [(measured(spec, model, bare), measured(spec, lambda _: (), bare))
                for _ in range(pairs)]
        traffic_model.sumo_options = model

        def ratio(key: str, runs=runs) -> float:
            return statistics.median(a[key] / b[key] for a, b in runs)

        print(f"world.{name}.sumo_step_ratio {ratio('sumo_ms'):.2f}")
        print(f"world.{name}.step_ratio {ratio('step_ms'):.2f}")
        if bare:
            over = statistics.median(a["step_ms"] / a["bare_ms"] for a, _ in runs)
            over_without = statistics.median(b["step_ms"] / b["bare_ms"] for _, b in runs)
            print(f"world.{name}.overhead_vs_bare_sumo {over:.2f}")
            print(f"world.{name}.overhead_vs_bare_sumo_without {over_without:.2f}")
        for key in ("vehicles", "step_ms", "sumo_ms", "bare_ms"):
            print(f"raw.{name}.{key} {statistics.median(a[key] for a, _ in runs):.3f} "
                  f"(without: {statistics.median(b[key] for _, b in runs):.3f})")
    episode_spec = bench_perf.traffic_spec(3, 2500.0, 1100.0, 120.0)
    episode = run_episode(episode_spec)
    start = time.perf_counter()
    world_overlaps(episode.trace.traffic, np.zeros((0, 5)))
    audit_s = time.perf_counter() - start
    print(f"world.audit_ms_per_step {1e3 * audit_s / len(episode.trace):.4f}")
    ego = EgoSlot(0, episode_spec, make_road(episode_spec))
    boxes = episode.trace.body_boxes(ego.model.center_ahead_of_rear_axle_m,
                                     ego.model.length_m, ego.model.width_m)
    start = time.perf_counter()
    for box in boxes:
        ego_pose(ego, box, TRAFFIC_WIDTH_M)  # before SUMO loads a type: the built-in's
    pose_s = time.perf_counter() - start
    print(f"world.ego_pose_us {1e6 * pose_s / len(boxes):.2f}")
    print(f"raw.audit_traffic_per_step "
          f"{statistics.mean(len(r) // 5 for r in episode.trace.traffic):.1f}")


if __name__ == "__main__":
    main()
