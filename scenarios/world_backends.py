"""The world backends behind one door: a spec's ``scenario.backend`` picks one.

A world has ``backend``, ``road``, ``start(ego_box, ego_speed_mps)`` and
``step(ego_box, ego_speed_mps)`` returning a :class:`~scenarios.snapshot.Snapshot`,
and ``close()``; it is a context manager.
"""

from __future__ import annotations

import contextlib
from pathlib import Path

from scenarios.errors import SdcError, SpecError
from scenarios.road_geometry import RoadGeometry
from scenarios.scenario_spec import RoadSpec, ScenarioSpec
from scenarios.sumo_net.build import build_network, sumo_load_error

BACKENDS = ("sumo", "highway")


def make_road(spec: ScenarioSpec, cache_dir: Path | None = None) -> RoadGeometry:
    """The road of ``spec``: a built-in road, or the route drawn through a SUMO network."""
    if spec.road.kind == "sumo_net":
        from scenarios.sumo_net.route_road import network_road

        return network_road(spec, cache_dir)
    return RoadGeometry.from_spec(spec.road)


def check_inputs(spec: ScenarioSpec) -> None:
    """Check what a run of ``spec`` reads besides the spec (a network file) and the
    road it draws there, so a bad one is reported as bad input before anything runs."""
    if spec.road.kind == "sumo_net":
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
    if road.kind != "sumo_net":
        build_network(road, cache_dir)
        return
    from scenarios.sumo_net.net_xml import read_net
    from scenarios.sumo_net.route_road import network_area

    with contextlib.suppress(SdcError):
        network_area(read_net(road.net_file), cache_dir)


def make_world(spec: ScenarioSpec, road: RoadGeometry, cache_dir: Path | None = None,
               gui: bool = False):
    if spec.scenario.backend == "highway":
        if gui:
            raise SdcError("--gui: only the sumo backend has a GUI")
        from scenarios.highway_world import HighwayWorld

        return HighwayWorld(spec, road)
    from scenarios.sumo_world import SumoWorld

    return SumoWorld(spec, road, cache_dir, gui)
