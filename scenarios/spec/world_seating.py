"""Which runs of a sweep share a world (``[sweep] egos_per_world``): plain data.

What the egos of one world share is :func:`world_fields`: the road, the traffic (its
seed, ``traffic.warm_seed``, among it), the step length and the backend. A sweep
with ``egos_per_world = K`` groups each controller's runs, in plan order, into worlds
of up to K runs whose world fields agree (the traffic's seed too, where a spec sets
it: ``warm_states`` draws it from a pool); each world's runs then take its first
run's traffic seed (so they load one warm state). The rest
of a spec stays each run's own: its start, route (its seed's, on a network),
obstacles, controller, sensors, car and duration.

A world is named ``w<its first sample>-<controller>`` and its runs keep their plan
order as slots 0, 1, ...: the order in which they take its seats.
"""

from __future__ import annotations

import dataclasses
import json

from scenarios.spec.scenario_spec import ScenarioSpec


def traffic_seed(spec: ScenarioSpec) -> int:
    """The seed of ``spec``'s traffic (its warm-up; SUMO's randomness and the random
    trips of a run without one): ``traffic.warm_seed``, or the scenario's."""
    seed = spec.traffic.warm_seed
    return spec.scenario.seed if seed is None else seed


#: the fields of a network road each ego of a world has its own: its route through the
#: network, how far it drives along it, and whether its lidar sees the road's edges
EGO_ROAD_FIELDS = ("length_m", "route_turns", "route_edges", "route_lane", "see_edges")


def world_fields(spec: ScenarioSpec) -> dict:
    """What the egos of one world share (plain data): its road (on a network, but for
    :data:`EGO_ROAD_FIELDS`), its traffic (its seed :func:`traffic_seed` among it),
    its step length and backend."""
    plain = spec.to_plain()
    road = plain["road"]
    if spec.road.on_network:
        road = {k: v for k, v in road.items() if k not in EGO_ROAD_FIELDS}
    return {"road": road, "traffic": plain["traffic"],
            "step_s": spec.scenario.step_s, "backend": spec.scenario.backend}


def on_world_road(spec: ScenarioSpec, world: ScenarioSpec) -> ScenarioSpec:
    """``spec`` on the road of ``world`` (a spec of its world, its files where a worker
    holds them), its own route kept (:data:`EGO_ROAD_FIELDS`)."""
    own = {name: getattr(spec.road, name) for name in EGO_ROAD_FIELDS}
    return dataclasses.replace(spec, road=dataclasses.replace(world.road, **own))


def _group_key(spec: ScenarioSpec) -> str:
    """The world fields as text; the traffic's seed among them only when the spec sets
    one (``warm_states`` draws it from a pool: the world keeps it)."""
    fields = world_fields(spec)
    if spec.traffic.warm_seed is None:
        fields["traffic"].pop("warm_seed", None)
    return json.dumps(fields, sort_keys=True)


@dataclasses.dataclass(frozen=True)
class WorldSeat:
    """A run's place in a sweep's shared worlds."""

    world_id: str  # w<first sample>-<controller>
    slot: int  # its place among the world's runs, from 0
    seats: int  # the egos its world holds at a time ([sweep] egos_per_world)


def group_worlds(runs: list[tuple[int, str, str, ScenarioSpec]], runs_per_world: int,
                 seats: int) -> dict[int, tuple[WorldSeat, ScenarioSpec]]:
    """The worlds of ``runs`` (each: its index in the plan, its sample's number as run
    IDs write it, its controller's label and its spec; in plan order), up to
    ``runs_per_world`` runs each, ``seats`` of them at a time: index -> its seat and
    its spec with the world's traffic seed."""
    open_worlds: dict[tuple[str, str], list[tuple[int, str, ScenarioSpec]]] = {}
    out: dict[int, tuple[WorldSeat, ScenarioSpec]] = {}

    def close(label: str, members: list[tuple[int, str, ScenarioSpec]]) -> None:
        seed = traffic_seed(members[0][2])
        world_id = f"w{members[0][1]}-{label}"
        for slot, (index, _, spec) in enumerate(members):
            traffic = dataclasses.replace(spec.traffic, warm_seed=seed)
            out[index] = (WorldSeat(world_id, slot, seats),
                          dataclasses.replace(spec, traffic=traffic))

    for index, sample, label, spec in runs:
        key = (label, _group_key(spec))
        members = open_worlds.setdefault(key, [])
        members.append((index, sample, spec))
        if len(members) == runs_per_world:
            close(label, open_worlds.pop(key))
    for (label, _), members in open_worlds.items():
        close(label, members)
    return out
