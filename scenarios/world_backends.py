"""The world backends behind one door: a spec's ``scenario.backend`` picks one, and
every backend is a :class:`World`.
"""

from __future__ import annotations

import contextlib
import dataclasses
from collections.abc import Callable
from pathlib import Path
from typing import Protocol

import numpy as np

from scenarios.errors import SdcError, SpecError
from scenarios.road_geometry import RoadGeometry
from scenarios.scenario_spec import RoadSpec, ScenarioSpec
from scenarios.snapshot import Snapshot
from scenarios.sumo_net.build import build_network, source_sha256, sumo_load_error
from scenarios.warm_state import cached_path, uses_warm_state, warm_key, warm_up_steps

BACKENDS = ("sumo", "highway")


class World(Protocol):
    """What a run asks of a world backend (``scenarios/sumo_world.py``,
    ``scenarios/highway_world.py``). The ego is a box ``[cx, cy, yaw, length, width]``
    [m, rad] pushed in every step at its speed [m/s]; the world answers with what the
    car can see (a :class:`Snapshot`)."""

    backend: str
    road: RoadGeometry
    #: the warm state the traffic started from (None: warmed up in the run, or none)
    warm_state_key: str | None

    def start(self, ego_box: np.ndarray, ego_speed_mps: float) -> Snapshot: ...
    def step(self, ego_box: np.ndarray, ego_speed_mps: float) -> Snapshot: ...
    def vehicle_count(self) -> int: ...  # traffic vehicles in the whole network
    def close(self) -> None: ...
    def __enter__(self) -> World: ...
    def __exit__(self, *exc: object) -> None: ...


def make_road(spec: ScenarioSpec, cache_dir: Path | None = None) -> RoadGeometry:
    """The road of ``spec``: a built-in road, or the route drawn through a SUMO network."""
    if spec.road.on_network:
        from scenarios.sumo_net.route_road import network_road

        return network_road(spec, cache_dir)
    return RoadGeometry.from_spec(spec.road)


def check_inputs(spec: ScenarioSpec) -> None:
    """Check what a run of ``spec`` reads besides the spec (a network file) and the
    road it draws there, so a bad one is reported as bad input before anything runs."""
    if spec.road.kind == "sumo_config":
        from scenarios.sumo_net.route_road import network_road
        from scenarios.sumo_net.sumo_config import check_config

        network_road(spec)
        check_config(spec.road.config_file, spec.traffic.enter_s)
    elif spec.road.kind == "sumo_net":
        from scenarios.sumo_net.random_trips import trip_edges
        from scenarios.sumo_net.route_road import network_road

        road = network_road(spec)
        if spec.traffic.vehicles:
            trip_edges(road.net)
        problem = sumo_load_error(road.net.path)
        if problem is not None:
            raise SpecError("road.net_file", f"{road.net.path}: SUMO cannot load the network: "
                                             f"{problem}")


def prepare_network(road: RoadSpec, cache_dir: Path | None = None) -> None:
    """Build and cache what SUMO runs on ``road`` need (its network; a network
    file's road edges), so parallel runs find it ready. A network file that cannot
    be read is left to the runs to report."""
    if not road.on_network:
        build_network(road, cache_dir)
        return
    from scenarios.sumo_net.route_road import network_area, road_network

    with contextlib.suppress(SdcError):
        network_area(road_network(road), cache_dir)


def warm_state_path(spec: ScenarioSpec, cache_dir: Path | None = None) -> Path | None:
    """Where ``spec``'s warm state is cached on this machine (None: it has no warm-up)."""
    if not uses_warm_state(spec):
        return None
    return cached_path(warm_key(spec, source_sha256(spec.road, cache_dir)))


def warm_up_span_s(spec: ScenarioSpec) -> tuple[float, float]:
    """SUMO's clock where ``spec``'s warm-up starts and where it ends [s]: from 0 over
    ``traffic.warm_up_s``, or on a ``sumo_config`` road from its configuration's begin
    to ``traffic.enter_s``."""
    begin_s = 0.0
    if spec.road.kind == "sumo_config":
        from scenarios.sumo_net.sumo_config import load_bundle

        begin_s = load_bundle(spec.road.config_file).begin_s
    return begin_s, begin_s + warm_up_steps(spec, begin_s) * spec.scenario.step_s


def warm_state_file(spec: ScenarioSpec, cache_dir: Path | None = None,
                    on_sample: Callable[[float], None] | None = None) -> bytes:
    """The file of ``spec``'s warm state (``scenarios/warm_state.py``), from this
    machine's cache or computed into it (``on_sample``: called with SUMO's clock [s]
    as the warm-up goes on)."""
    from scenarios.sumo_world import SumoWorld

    with SumoWorld(spec, make_road(spec, cache_dir), cache_dir) as world:
        return world.warm_state(on_sample).to_bytes()


def settling_series(spec: ScenarioSpec, duration_s: float, cache_dir: Path | None = None,
                    on_sample: Callable[[float], None] | None = None) -> dict[str, list]:
    """How ``spec``'s traffic settles over a warm-up of ``duration_s`` (SUMO, no ego):
    the series a warm state records (``scenarios.warm_state.SETTLING_COLUMNS``)."""
    from scenarios.sumo_world import SumoWorld

    if spec.road.kind == "sumo_config":  # from its begin
        from scenarios.sumo_net.sumo_config import load_bundle

        longer = {"enter_s": load_bundle(spec.road.config_file).begin_s + duration_s}
    else:
        longer = {"warm_up_s": duration_s}
    spec = dataclasses.replace(spec, traffic=dataclasses.replace(spec.traffic, **longer))
    with SumoWorld(spec, make_road(spec, cache_dir), cache_dir) as world:
        return world.compute_warm_state(world.warm_key(), on_sample).settling


def make_world(spec: ScenarioSpec, road: RoadGeometry, cache_dir: Path | None = None,
               gui: bool = False, warm_state: Path | None = None) -> World:
    """``warm_state``: the file of the spec's warm state, when the caller has it (the
    sumo backend; without it a run finds or computes its own)."""
    if spec.scenario.backend == "highway":
        if gui:
            raise SdcError("--gui: only the sumo backend has a GUI")
        from scenarios.highway_world import HighwayWorld

        return HighwayWorld(spec, road)
    from scenarios.sumo_world import SumoWorld

    return SumoWorld(spec, road, cache_dir, gui, warm_state=warm_state)
