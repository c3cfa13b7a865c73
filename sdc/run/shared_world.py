"""Several runs in one SUMO world: the traffic simulated once, an ego for each run.

The runs of a world share what :func:`scenarios.spec.world_seating.world_fields` names
(the road, the traffic and its seed, the step): the first run's traffic is the
world's. Each ego has its own start, route, obstacles, controller, sensors and
checks, and ends on its own (collision, duration, route end); its bodies then leave
SUMO and the others go on. The egos are bodies to each other: each sees the others
and their obstacles as traffic where they truly are, and can hit them (counted as
hitting traffic).

**Seats** (:class:`Seats`): a world holds up to ``seats`` egos at a time
(``[sweep] egos_per_world``); its runs take them in slot order, and as a run ends
the next waiting run that fits enters, on the world's traffic as it is then
(``world_entry_step`` says when). So a world steps with about as many egos as it has
seats until its runs are done.

**The placement rule**: an ego enters only when its sensing radius holds no other
ego nor any other ego's obstacle (its start point farther from each ego in the world
than the sum of their radii, each obstacle of either farther from the other ego than
that ego's radius). So every run starts as it would alone, and only what happens
later (traffic an ego slowed, two routes that meet) can reach another run.

Each step, every ego in the world senses, decides and is checked in slot order, the
waiting ones that may enter do, then all move and SUMO advances once
(:mod:`sdc.run.world_loop`, the loop of every world): a world of the same runs gives
the same traces, bit for bit.
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
    """May two egos (each: its body centre, obstacle centres, sensing radius) be in one
    world by the placement rule?"""
    (start_a, obstacles_a, radius_a), (start_b, obstacles_b, radius_b) = a, b
    if np.hypot(*(start_a - start_b)) <= radius_a + radius_b:
        return False
    return bool(np.all(np.hypot(*(obstacles_a - start_b).T) > radius_b)
                and np.all(np.hypot(*(obstacles_b - start_a).T) > radius_a))


class Seats:
    """Who of a world's runs (``egos``, in slot order: each a spec and its road) enters
    it when (:class:`sdc.run.world_loop.Seating`): up to ``seats`` egos at a time, each
    waiting run in slot order entering when a seat is free and the placement rule lets
    it in beside the egos in the world (where they are now) and those entering."""

    def __init__(self, egos: list[tuple[ScenarioSpec, RoadGeometry]], seats: int):
        self.seats = seats
        self._runs = [(*start_points(spec, road), sensing_radius_m(spec)) for spec, road in egos]

    def entering(self, waiting: list[int], present: dict[int, np.ndarray], step: int
                 ) -> list[int]:
        here = [(box[:2], *self._runs[i][1:]) for i, box in present.items()]
        chosen: list[int] = []
        for i in waiting:
            if len(here) >= self.seats:
                break
            if all(_apart(self._runs[i], other) for other in here):
                here.append(self._runs[i])
                chosen.append(i)
        return chosen


def run_world(egos: list[tuple[ScenarioSpec, RoadGeometry]], run_ids: list[str],
              seats: int | None = None, *, cache_dir: Path | None = None,
              warm_state: Path | None = None, source: RoadSource | None = None
              ) -> list[Episode | Failed]:
    """Run ``egos`` (each a spec and its road; the first's traffic is the world's) in
    one SUMO world, ``seats`` of them at a time by the placement rule (:class:`Seats`;
    None: all of them from the start, wherever they are), stepped together; each run's
    :class:`Episode` named by ``run_ids``, or how it failed. A failure of the world
    itself fails every run in it or waiting for it. ``source``: the road source the
    egos share, when the caller has it."""
    controllers: list = []
    for spec, _ in egos:
        try:
            controllers.append(make_controller(spec.controller))
        except Exception as e:  # noqa: BLE001 - that run's failure, not the world's
            controllers.append(Failed.of(e))
    ends: dict[int, str | Failed] = {i: c for i, c in enumerate(controllers)
                                     if isinstance(c, Failed)}
    sims: list[Simulation] = []
    entered: dict[int, int] = {}
    try:
        world = make_shared_world(egos, cache_dir, warm_state, source)
        sims = [Simulation(spec, world, road=road, controller=controller, slot=slot)
                for slot, ((spec, road), controller)
                in enumerate(zip(egos, controllers, strict=True))]
        with world:
            loop = WorldLoop(world, sims, ends, None if seats is None else Seats(egos, seats))
            ends, entered = loop.ends, loop.entered  # filled as runs go: kept if it fails
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
        sim.world_egos = len(egos)
        sim.world_entry_step = entered[i] if len(egos) > 1 else None  # else its own world
        try:
            out.append(sim.finish(end, run_ids[i]))
        except Exception as e:  # noqa: BLE001 - its summing up failed: its row says so
            out.append(Failed.of(e))
    return out


def run_group(specs: list[ScenarioSpec], run_ids: list[str], seats: int | None = None, *,
              cache_dir: Path | None = None, warm_state: Path | None = None
              ) -> list[Episode | Failed]:
    """Run the runs of one world of a sweep (specs sharing the world's fields, in slot
    order), ``seats`` of them at a time (default: all that fit): each run's outcome, as
    :func:`run_world` (a run whose road cannot be had fails alone)."""
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
    if placeable:
        results = run_world([egos[i] for i in placeable], [run_ids[i] for i in placeable],
                            seats or len(placeable), cache_dir=cache_dir,
                            warm_state=warm_state, source=source)
        out.update(zip(placeable, results, strict=True))
    return [out[i] for i in range(len(specs))]


def replay_in_world(specs: list[ScenarioSpec], run_ids: list[str], run_id: str,
                    seats: int, cache_dir: Path | None = None) -> Episode | Failed:
    """Re-simulate the shared world of ``specs`` (its runs in slot order, named
    ``run_ids``, ``seats`` at a time) as its sweep ran it, and return ``run_id``'s
    outcome."""
    outcomes = run_group(specs, run_ids, seats, cache_dir=cache_dir)
    return outcomes[run_ids.index(run_id)]
