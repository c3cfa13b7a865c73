"""The world's audit inside the run, held to the replay it replaced.

An overlap of two bodies other than the ego is judged at the step it happens, from
SUMO's state at that step (:class:`sdc.run.world_witness.InRunAudit`). The replay
(:func:`sdc.run.world_witness.witness_world`: the world simulated once more, each ego
pushed along its trace) judges the same steps afterwards. This runs families of real
runs, alone and several to a world, judges each both ways and compares them pair by
pair at every step::

    python benchmarks/audit_in_run.py --samples 30 --families ingolstadt people a10
    python benchmarks/audit_in_run.py --samples 12 --families town --warm-seed 1

Families (``avoid`` where the sweep has it, else its first runs; ``--samples`` runs
each, alone, then the same runs 8 to a world, 4 of them at a time, entering as
seats free and the placement rule lets them): ``town`` (sweeps/grid-town.toml),
``ingolstadt`` (SUMO's Ingolstadt with its own demand and bicycles), ``people``
(sweeps/real-people.toml: fokr_bs_demo with its people), ``a10``
(sweeps/real-motorway-stop.toml). Prints a line a family: runs, runs with an overlap,
steps judged, steps where the two differ (each difference below it), and the wall
time of the runs (the in-run audit's share of it too) beside that of the replay
they no longer need.
"""

from __future__ import annotations

import argparse
import dataclasses
import time

from scenarios import CATALOG_DIR
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.spec.sweep_plan import expand
from scenarios.spec.sweep_spec import load_sweep
from scenarios.spec.toml_io import read_toml
from scenarios.world_backends import make_road, make_shared_world
from sdc.car.controller_plugins import make_controller
from sdc.run.episode import Simulation
from sdc.run.shared_world import Seats
from sdc.run.world_loop import Failed, WorldLoop
from sdc.run.world_witness import InRunAudit, witness_world

#: the wall time the in-run audits took, all runs [s]
AUDIT_S = [0.0]


def _timed(look):
    def timed(self, snapshot, step):
        start = time.perf_counter()
        look(self, snapshot, step)
        AUDIT_S[0] += time.perf_counter() - start
    return timed


InRunAudit.look = _timed(InRunAudit.look)

#: SUMO's Ingolstadt scenario, by the path sdc reads SUMO's own files by
INGOLSTADT = "sumo:tools/game/fkk_in.sumocfg"


def _catalog_specs(sweep: str, samples: int) -> list[ScenarioSpec]:
    runs = expand(load_sweep(CATALOG_DIR / "sweeps" / sweep))
    avoid = [r for r in runs if r.spec.controller.label == "avoid"]
    return [r.spec for r in (avoid or runs)[:samples]]


def _ingolstadt_specs(samples: int) -> list[ScenarioSpec]:
    plain = read_toml(CATALOG_DIR / "real-traffic.toml")
    plain["road"]["config_file"] = INGOLSTADT
    plain["controller"] = {"name": "avoid"}
    specs = []
    for k in range(samples):
        plain["traffic"]["enter_s"] = 100.0 + 7.0 * k
        plain["ego"]["speed_mps"] = 9.0 + (k % 5)
        plain["scenario"]["seed"] = k + 1
        specs.append(ScenarioSpec.from_plain(plain))
    return specs


FAMILIES = {
    "town": lambda n: _catalog_specs("grid-town.toml", n),
    "ingolstadt": _ingolstadt_specs,
    "people": lambda n: _catalog_specs("real-people.toml", n),
    "a10": lambda n: _catalog_specs("real-motorway-stop.toml", n),
}


def judged_both_ways(egos: list[tuple], seats: int
                     ) -> tuple[list[tuple[list, list, list, int]], float, float]:
    """Run ``egos`` (spec, road) in one world, ``seats`` at a time, and replay it: for
    each run the pairs judged in the run, those the replay judged, its trace's
    overlapping steps and the world's step it entered at; then the wall times [s] of
    the world's run and of its replay."""
    world = make_shared_world(egos, None, None)
    sims = [Simulation(spec, world, road=road, controller=make_controller(spec.controller),
                       slot=slot) for slot, (spec, road) in enumerate(egos)]
    start = time.perf_counter()
    with world:
        loop = WorldLoop(world, sims, seating=Seats(egos, seats))
        ends = loop.run()
    run_s = time.perf_counter() - start
    failed = [end for end in ends.values() if isinstance(end, Failed)]
    if failed:
        raise RuntimeError(failed[0].traceback)
    judged = [sim.judged() for sim in sims]
    start = time.perf_counter()
    entries = [loop.entered[i] for i in range(len(sims))]
    replayed = (witness_world(world.twin(), judged, entries)
                if any(len(j.steps) for j in judged) else [[] for _ in judged])
    replay_s = time.perf_counter() - start
    return ([(sim.audit.witnessed, seen, judged_one.steps.tolist(), entry)
             for sim, seen, judged_one, entry in zip(sims, replayed, judged, entries,
                                                     strict=True)],
            run_s, replay_s)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=25, help="runs a family")
    parser.add_argument("--families", nargs="*", default=list(FAMILIES))
    parser.add_argument("--seats", type=int, default=4, help="egos a shared world holds")
    parser.add_argument("--per-world", type=int, default=8, help="runs a shared world")
    parser.add_argument("--warm-seed", type=int, help="every run's traffic.warm_seed (one "
                        "warm state for all: the town's take a minute each)")
    args = parser.parse_args()
    for family in args.families:
        specs = FAMILIES[family](args.samples)
        if args.warm_seed is not None:  # one warm state for all, as a sweep's pool has few
            specs = [dataclasses.replace(s, traffic=dataclasses.replace(
                s.traffic, warm_seed=args.warm_seed)) for s in specs]
        egos = [(spec, make_road(spec)) for spec in specs]
        worlds = [([ego], 1) for ego in egos]
        for start in range(0, len(specs), args.per_world):  # the same runs, sharing
            chunk = specs[start:start + args.per_world]
            traffic = dataclasses.replace(chunk[0].traffic, warm_seed=1)
            group = [(spec, make_road(spec)) for spec in
                     (dataclasses.replace(s, road=chunk[0].road, traffic=traffic)
                      for s in chunk)]
            worlds.append((group, args.seats))
        runs = overlapped = steps = differ = later = 0
        run_s = replay_s = AUDIT_S[0] = 0.0
        for world, seats in worlds:
            results, world_s, world_replay_s = judged_both_ways(world, seats)
            run_s += world_s
            replay_s += world_replay_s
            for in_run, replayed, overlap_steps, entry in results:
                runs += 1
                later += entry > 0
                overlapped += bool(overlap_steps)
                steps += len(overlap_steps)
                judged_steps = {w.step for w in in_run}
                if judged_steps != set(overlap_steps):
                    differ += len(judged_steps ^ set(overlap_steps))
                    print(f"  {family}: steps judged in the run {sorted(judged_steps)[:5]}..."
                          f" are not the trace's {overlap_steps[:5]}...")
                if in_run != replayed:
                    bad = {w.step for w in set(in_run) ^ set(replayed)}
                    differ += len(bad)
                    print(f"  {family}: in the run and in the replay differ at steps "
                          f"{sorted(bad)[:8]} (world of {len(world)})")
        print(f"{family} runs {runs} entered_later {later} overlapped {overlapped} "
              f"steps_judged {steps} "
              f"steps_differing {differ} worlds {len(worlds)} run_s {run_s:.1f} "
              f"audit_in_run_s {AUDIT_S[0]:.2f} replay_s {replay_s:.1f}", flush=True)


if __name__ == "__main__":
    main()
