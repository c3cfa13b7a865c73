"""What reading SUMO's people costs, as ratios in one run.

On SUMO's Braunschweig junction (``fokr_bs_demo``, its own cars, bicycles and
pedestrians; the catalog's ``real-people`` base without its standing person) under
avoid, paired closed loops (bench_perf.closed_loop) with the persons read as bodies
and without (the person context subscription left out, the world before people):

- ``people.agent_ratio``: our own cost per step (everything but SUMO's step), with
  people over without;
- ``people.step_ratio``: the whole step, with over without;
- ``people.sumo_step_ratio``: SUMO's step inside the loop, with over without (the
  subscription's search for persons around the ego is SUMO's work);
- ``people.in_view``: the persons within the sensing radius, on average over the
  timed steps, and ``raw.*`` the medians in milliseconds.

    python benchmarks/bench_people.py

``SDC_BENCH_SMOKE=1``: the smoke size (benchmarks/smoke.py): one pair, bench_perf's
smoke size of timed steps.
"""

from __future__ import annotations

import statistics

import bench_perf
import libsumo
import traci.constants as tc
from smoke import size

from scenarios import CATALOG_DIR
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.spec.toml_io import load_spec

PAIRS = size(3, 1)


def junction_spec() -> ScenarioSpec:
    plain = load_spec(CATALOG_DIR / "real-people.toml").to_plain()
    plain["obstacles"] = []
    plain["scenario"]["duration_s"] = 60.0
    return ScenarioSpec.from_plain(plain)


def without_people(spec: ScenarioSpec) -> dict:
    """bench_perf's closed loop with the persons' context subscription left out."""
    subscribe = libsumo.vehicle.subscribeContext

    def vehicles_only(object_id, domain, *args):
        if domain != tc.CMD_GET_PERSON_VARIABLE:
            subscribe(object_id, domain, *args)

    libsumo.vehicle.subscribeContext = vehicles_only
    try:
        return bench_perf.closed_loop(spec)
    finally:
        libsumo.vehicle.subscribeContext = subscribe


def persons_in_view(spec: ScenarioSpec) -> float:
    """The persons the world reports around the ego, on average over the loop's steps."""
    from scenarios.world_backends import make_road, make_world
    from sdc.car.controller_plugins import make_controller

    counts = []
    controller = make_controller(spec.controller)
    with make_world(spec, make_road(spec)) as world:
        sim, loop = bench_perf.alone(spec, world, controller)
        for _ in range(bench_perf.TIMED_STEPS):
            counts.append(int((sim.snapshot.traffic_classes == "pedestrian").sum()))
            if bench_perf.ended(loop):
                break
    return statistics.mean(counts)


def main() -> None:
    spec = junction_spec()
    pairs = [(bench_perf.closed_loop(spec), without_people(spec)) for _ in range(PAIRS)]
    for key, name in (("agent_ms", "agent_ratio"), ("step_ms", "step_ratio"),
                      ("sumo_ms", "sumo_step_ratio")):
        ratio = statistics.median(with_[key] / without[key] for with_, without in pairs)
        print(f"people.{name} {ratio:.2f}")
    for key in ("agent_ms", "step_ms", "sumo_ms"):
        print(f"raw.people.{key}_with {statistics.median(p[0][key] for p in pairs):.3f}")
        print(f"raw.people.{key}_without {statistics.median(p[1][key] for p in pairs):.3f}")
    print(f"people.in_view {persons_in_view(spec):.1f}")
    print(f"raw.people.steps {pairs[0][0]['steps']}")


if __name__ == "__main__":
    main()
