"""The world backends behind one door: a spec's ``scenario.backend`` picks one.

A world has ``backend``, ``road``, ``start(ego_box, ego_speed_mps)`` and
``step(ego_box, ego_speed_mps)`` returning a :class:`~scenarios.snapshot.Snapshot`,
and ``close()``; it is a context manager.
"""

from __future__ import annotations

from pathlib import Path

from scenarios.errors import SdcError
from scenarios.road import RoadGeometry
from scenarios.spec import ScenarioSpec

BACKENDS = ("sumo", "highway")


def make_world(spec: ScenarioSpec, road: RoadGeometry, cache_dir: Path | None = None,
               gui: bool = False):
    if spec.scenario.backend == "highway":
        if gui:
            raise SdcError("--gui: only the sumo backend has a GUI")
        from scenarios.highway_world import HighwayWorld

        return HighwayWorld(spec, road)
    from scenarios.sumo_world import SumoWorld

    return SumoWorld(spec, road, cache_dir, gui)
