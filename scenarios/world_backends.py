"""The world backends behind one door: a spec's ``scenario.backend`` picks one.

A world has ``backend``, ``road``, ``start(ego_box, ego_speed_mps)`` and
``step(ego_box, ego_speed_mps)`` returning a :class:`~scenarios.snapshot.Snapshot`,
and ``close()``; it is a context manager.
"""

from __future__ import annotations

import contextlib
from pathlib import Path

from scenarios.errors import SdcError
from scenarios.road_geometry import RoadGeometry
from scenarios.scenario_spec import RoadSpec, ScenarioSpec
from scenarios.sumo_net.build import build_network

BACKENDS = ("sumo", "highway")


def make_road(spec: ScenarioSpec, cache_dir: Path | None = None) -> RoadGeometry:
    """The road of ``spec``: a built-in road, or the route drawn through a SUMO network."""
    if spec.road.kind == "sumo_net":
        from scenarios.sumo_net.route_road import network_road

        return network_road(spec, cache_dir)
    return RoadGeometry.from_spec(spec.road)


def check_inputs(spec: ScenarioSpec) -> None:
    """Check what a run of ``spec`` reads besides the spec (a network file), so a
    bad one is reported as bad input before anything runs."""
    if spec.road.kind == "sumo_net":
        from scenarios.sumo_net.route_road import read_network_file

        read_network_file(spec)


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
