"""The world backends behind one door: a spec's ``scenario.backend`` picks one, and
every backend is a :class:`World`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path
from typing import Protocol

import numpy as np

from scenarios.common.errors import SdcError
from scenarios.scene.road_geometry import RoadGeometry
from scenarios.scene.snapshot import Pose, Snapshot
from scenarios.spec.backends import BACKENDS as ALL_BACKENDS
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.spec.scenario_tables import RoadSpec
from scenarios.sumo.warm_state import cached_path, uses_warm_state, warm_state_key
from scenarios.sumo_net.road_source import RoadSource, road_source

BACKENDS = tuple(ALL_BACKENDS)  # their names


class World(Protocol):
    """What a run asks of a world backend (``scenarios/sumo/sumo_world.py``,
    ``scenarios/highway/highway_world.py``). Each ego of the world sits in a slot
    (0, 1, ...; a world of one ego has slot 0 only), pushed in every step at its
    :data:`Pose`; the world answers each with what its car can see (a
    :class:`Snapshot`). ``sdc.run.world_loop`` is the one loop that steps it."""

    backend: str
    road: RoadGeometry
    #: the warm state the traffic started from (None: warmed up in the run, or none)
    warm_state_key: str | None
    #: each light along the route: its program's cycle [s] (filled as the world starts)
    signal_cycles_s: dict[str, float]

    def start_all(self, egos: dict[int, Pose]) -> dict[int, Snapshot]: ...
    def step_all(self, egos: dict[int, Pose | None]) -> dict[int, Snapshot]: ...
    def leave(self, slot: int) -> None: ...  # its run ended; the world goes on for the others
    # a waiting slot's ego enters at the next step (asked of worlds holding several egos)
    def enter(self, slot: int, pose: Pose) -> None: ...
    def start(self, ego_box: np.ndarray, ego_speed_mps: float) -> Snapshot: ...  # slot 0 alone
    def step(self, ego_box: np.ndarray, ego_speed_mps: float) -> Snapshot: ...  # slot 0 alone
    def vehicle_count(self) -> int: ...  # traffic vehicles in the whole network
    def twin(self) -> WitnessWorld | None: ...  # an unstarted copy to replay; None: none
    def witness(self) -> WitnessWorld | None: ...  # itself, if it has a model to judge by
    def close(self) -> None: ...
    def __enter__(self) -> World: ...
    def __exit__(self, *exc: object) -> None: ...


class WitnessWorld(World, Protocol):
    """A world with a model of its own to hold ours against (SUMO): it names the bodies
    it holds (:meth:`ids`), lays them as it holds them (``sdc.run.world_witness``), and
    its own driver can take an ego's place (``sdc.run.sumo_driver``)."""

    ego_ids: frozenset[str]  # the ids of the world's egos

    def is_traffic(self, vehicle_id: str) -> bool: ...  # no ego's, nor their obstacles
    def ids(self, slot: int) -> list[str]: ...  # the SUMO ids of the last snapshot's rows
    def placed_by_sumo(self, traffic_boxes: np.ndarray, rows: list[int],
                       obstacles: list[int], slot_index: int = 0) -> list[np.ndarray]: ...
    def hand_ego_to_sumo(self, slot: int, max_speed_mps: float) -> None: ...
    def sumo_ego(self, slot: int) -> tuple[float, float, float, bool]: ...


def _source(road: RoadSpec, handed: RoadSource | None = None) -> RoadSource:
    """The road source a run was ``handed`` (obtained once where it starts:
    ``sdc/run/episode.py``, ``sdc/run/shared_world.py``), else ``road``'s own: the one
    place the door obtains one, for a caller holding a spec alone (a check, a tool, the
    gym). Below the door, a world is handed its source and never asks for it again."""
    return road_source(road) if handed is None else handed


def make_road(spec: ScenarioSpec, cache_dir: Path | None = None,
              source: RoadSource | None = None) -> RoadGeometry:
    """The road of ``spec``: a built-in road, or the route drawn through a SUMO network
    (``source``: the run's road source, when the caller has it)."""
    return _source(spec.road, source).geometry(spec, cache_dir)


def check_inputs(spec: ScenarioSpec) -> None:
    """Check what a run of ``spec`` reads besides the spec (a network file) and the
    road it draws there, so a bad one is reported as bad input before anything runs."""
    _source(spec.road).check_inputs(spec)


def prepare_network(road: RoadSpec, cache_dir: Path | None = None) -> None:
    """Build and cache what SUMO runs on ``road`` need (its network; a network
    file's road edges), so parallel runs find it ready. A network file that cannot
    be read is left to the runs to report."""
    _source(road).prepare(cache_dir)


def warm_state_path(spec: ScenarioSpec, cache_dir: Path | None = None) -> Path | None:
    """Where ``spec``'s warm state is cached on this machine (None: it has no warm-up)."""
    if not uses_warm_state(spec):
        return None
    return cached_path(warm_state_key(spec, _source(spec.road), cache_dir))


def warm_up_span_s(spec: ScenarioSpec) -> tuple[float, float]:
    """SUMO's clock where ``spec``'s warm-up starts and where it ends [s]: from 0 over
    ``traffic.warm_up_s``, or on a ``sumo_config`` road from its configuration's begin
    to ``traffic.enter_s``."""
    source = _source(spec.road)
    begin_s = source.warm_up_begin_s()
    return begin_s, begin_s + source.warm_up_steps(spec) * spec.scenario.step_s


def warm_state_file(spec: ScenarioSpec, cache_dir: Path | None = None,
                    on_sample: Callable[[float], None] | None = None) -> bytes:
    """The file of ``spec``'s warm state (``scenarios/sumo/warm_state.py``), from this
    machine's cache or computed into it (``on_sample``: called with SUMO's clock [s]
    as the warm-up goes on)."""
    from scenarios.sumo.sumo_world import SumoWorld

    source = _source(spec.road)
    with SumoWorld(spec, make_road(spec, cache_dir, source), cache_dir,
                   source=source) as world:
        return world.warm_state(on_sample).to_bytes()


def settling_series(spec: ScenarioSpec, duration_s: float, cache_dir: Path | None = None,
                    on_sample: Callable[[float], None] | None = None) -> dict[str, list]:
    """How ``spec``'s traffic settles over a warm-up of ``duration_s`` (SUMO, no ego):
    the series a warm state records (``scenarios.sumo.warm_state.SETTLING_COLUMNS``)."""
    from scenarios.sumo.sumo_world import SumoWorld

    source = _source(spec.road)  # a configuration's clock runs from its begin
    longer = {source.warm_up_field: source.warm_up_begin_s() + duration_s}
    spec = dataclasses.replace(spec, traffic=dataclasses.replace(spec.traffic, **longer))
    with SumoWorld(spec, make_road(spec, cache_dir, source), cache_dir,
                   source=source) as world:
        return world.compute_warm_state(world.warm_key(), on_sample).settling


def make_world(spec: ScenarioSpec, road: RoadGeometry, cache_dir: Path | None = None,
               gui: bool = False, warm_state: Path | None = None,
               source: RoadSource | None = None) -> World:
    """``warm_state``: the file of the spec's warm state, when the caller has it (the
    sumo backend; without it a run finds or computes its own). ``source``: the run's
    road source, when the caller has it (the sumo backend's)."""
    if gui and not spec.scenario.world_backend.has_gui:
        raise SdcError("--gui: only the sumo backend has a GUI")
    if spec.scenario.backend == "highway":
        from scenarios.highway.highway_world import HighwayWorld

        return HighwayWorld(spec, road)
    if spec.scenario.backend == "scripted":
        from scenarios.scripted.scripted_world import ScriptedWorld

        return ScriptedWorld(spec, road)
    from scenarios.sumo.sumo_world import SumoWorld

    return SumoWorld(spec, road, cache_dir, gui, warm_state=warm_state,
                     source=_source(spec.road, source))


def make_shared_world(egos: list[tuple[ScenarioSpec, RoadGeometry]],
                      cache_dir: Path | None = None, warm_state: Path | None = None,
                      source: RoadSource | None = None):
    """One SUMO world for several egos (each a spec and its road; the first's traffic is
    the world's: :class:`scenarios.sumo.sumo_world.SumoWorld`); the highway backend
    holds one ego only. ``source``: the road source the egos share, when the caller
    has it."""
    (spec, road), others = egos[0], tuple(egos[1:])
    if others and not spec.scenario.world_backend.holds_several_egos:
        raise SdcError("[sweep] egos_per_world: only the sumo backend holds several egos")
    if not others:
        return make_world(spec, road, cache_dir, warm_state=warm_state, source=source)
    from scenarios.sumo.sumo_world import SumoWorld

    return SumoWorld(spec, road, cache_dir, warm_state=warm_state, others=others,
                     source=_source(spec.road, source))
