"""Several runs in one SUMO world: the traffic simulated once, an ego for each run.

The runs of a world share what :func:`scenarios.spec.world_seating.world_fields` names
(the road, the traffic and its seed, the step): the first run's traffic is the
world's. Each ego has its own start, route, obstacles, controller, sensors and
checks, and ends on its own (collision, duration, route end); its bodies then leave
SUMO and the others go on. The egos are bodies to each other: each sees the others
and their obstacles as traffic where they truly are, and can hit them (counted as
hitting traffic).

**The placement rule** (:func:`placed_apart`): egos share a world only when, at the
start, each one's sensing radius holds no other ego nor any other ego's obstacle
(their start points farther apart than the sum of their radii, every obstacle
farther from another ego than that ego's radius). So every run starts as it would
alone, and only what happens later (traffic an ego slowed, two routes that meet) can
reach another run. Runs that do not fit go to a further world on the same traffic
(the same warm state and seed): fewer share it, and ``world_egos`` says how many did.

Each step, every ego still in the world senses, decides and is checked in slot order,
then all move and SUMO advances once (:mod:`sdc.run.world_loop`, the loop of every
world): a world of the same runs gives the same traces, bit for bit.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from scenarios.scene.road_geometry import RoadGeometry
from scenarios.scene.snapshot import obstacle_boxes, sensing_radius_m
from scenarios.spec.bodies import VEHICLE_MODELS
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.sumo_net.road_source import RoadSource, road_source
from scenarios.world_backends import make_road, make_shared_world
from sdc.car.controller_plugins import make_controller
from sdc.car.vehicle import Vehicle
from sdc.run.episode import Episode, Simulation, initial_state
from sdc.run.world_loop import Failed, WorldLoop


def start_points(spec: ScenarioSpec, road: RoadGeometry) -> tuple[np.ndarray, np.ndarray]:
    """Where a run's ego starts (its body centre) and its obstacles' centres (K, 2)."""
    vehicle = Vehicle(VEHICLE_MODELS[spec.vehicle.model], spec.vehicle.friction_mu)
    start = vehicle.body_box(initial_state(spec, road, vehicle))[:2]
    return start, obstacle_boxes(spec, road)[:, :2]


def _apart(a: tuple, b: tuple) -> bool:
    """May two runs (each: its start point, obstacle centres, sensing radius) share a
    world by the placement rule?"""
    (start_a, obstacles_a, radius_a), (start_b, obstacles_b, radius_b) = a, b
    if np.hypot(*(start_a - start_b)) <= radius_a + radius_b:
        return False
    return bool(np.all(np.hypot(*(obstacles_a - start_b).T) > radius_b)
                and np.all(np.hypot(*(obstacles_b - start_a).T) > radius_a))


def placed_apart(egos: list[tuple[ScenarioSpec, RoadGeometry]]) -> list[list[int]]:
    """The worlds ``egos`` (in slot order) run in: each a list of their indices, every
    pair in one world apart by the placement rule; an ego joins the first world it
    fits, else starts one."""
    seen = [(*start_points(spec, road), sensing_radius_m(spec)) for spec, road in egos]
    worlds: list[list[int]] = []
    for i, mine in enumerate(seen):
        home = next((w for w in worlds if all(_apart(mine, seen[j]) for j in w)), None)
        if home is None:
            worlds.append([i])
        else:
            home.append(i)
    return worlds


def run_world(egos: list[tuple[ScenarioSpec, RoadGeometry]], run_ids: list[str], *,
              cache_dir: Path | None = None, warm_state: Path | None = None,
              source: RoadSource | None = None) -> list[Episode | Failed]:
    """Run ``egos`` (each a spec and its road; the first's traffic is the world's) in
    one SUMO world, stepped together; each run's :class:`Episode` named by
    ``run_ids``, or how it failed. A failure of the world itself fails every run still
    in it. ``source``: the road source the egos share, when the caller has it."""
    controllers: list = []
    for spec, _ in egos:
        try:
            controllers.append(make_controller(spec.controller))
        except Exception as e:  # noqa: BLE001 - that run's failure, not the world's
            controllers.append(Failed.of(e))
    ends: dict[int, str | Failed] = {i: c for i, c in enumerate(controllers)
                                     if isinstance(c, Failed)}
    sims: list[Simulation] = []
    try:
        world = make_shared_world(egos, cache_dir, warm_state, source)
        sims = [Simulation(spec, world, road=road, controller=controller, slot=slot)
                for slot, ((spec, road), controller)
                in enumerate(zip(egos, controllers, strict=True))]
        for sim in sims:
            sim.world_egos = len(egos)
        with world:
            loop = WorldLoop(world, sims, ends)
            ends = loop.ends  # filled as runs end: kept when the world then fails
            loop.run()
    except Exception as e:  # noqa: BLE001 - the world failed: so did every run in it
        failed = Failed.of(e)
        for i in range(len(egos)):
            ends.setdefault(i, failed)
    out: list[Episode | Failed] = []
    for i, sim in enumerate(sims or [None] * len(egos)):
        end = ends[i]
        if isinstance(end, Failed):
            out.append(end)
            continue
        try:
            out.append(sim.finish(end, run_ids[i]))
        except Exception as e:  # noqa: BLE001 - its summing up failed: its row says so
            out.append(Failed.of(e))
    return out


def run_group(specs: list[ScenarioSpec], run_ids: list[str], *,
              cache_dir: Path | None = None, warm_state: Path | None = None
              ) -> list[Episode | Failed]:
    """Run the runs of one group of a sweep (specs sharing the world's fields, in slot
    order) in as many worlds as the placement rule needs, one after the other: each
    run's outcome, as :func:`run_world` (its row's ``world_egos`` says how many egos
    shared its world)."""
    egos, out = [], {}
    # the group's one road source: its runs share their road (world_fields)
    source = road_source(specs[0].road) if specs else None
    for i, spec in enumerate(specs):
        try:
            egos.append((spec, make_road(spec, cache_dir, source)))
        except Exception as e:  # noqa: BLE001 - a road it cannot have: its row says why
            out[i] = Failed.of(e)
            egos.append(None)
    placeable = [i for i, ego in enumerate(egos) if ego is not None]
    for world in placed_apart([egos[i] for i in placeable]):
        members = [placeable[j] for j in world]
        results = run_world([egos[i] for i in members], [run_ids[i] for i in members],
                            cache_dir=cache_dir, warm_state=warm_state, source=source)
        out.update(zip(members, results, strict=True))
    return [out[i] for i in range(len(specs))]


def replay_in_world(specs: list[ScenarioSpec], run_ids: list[str], run_id: str,
                    cache_dir: Path | None = None) -> Episode | Failed:
    """Re-simulate the shared world of ``specs`` (its runs in slot order, named
    ``run_ids``) as its sweep ran it, and return ``run_id``'s outcome."""
    outcomes = run_group(specs, run_ids, cache_dir=cache_dir)
    return outcomes[run_ids.index(run_id)]
