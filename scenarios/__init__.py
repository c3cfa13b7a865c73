"""The world: scenario specs, road geometry, and the simulator backends."""

from pathlib import Path

from scenarios.common.errors import SdcError, SpecError
from scenarios.spec.controller_params import AvoidParams, LaneKeepParams, SeedParams
from scenarios.spec.controller_spec import ControllerSpec
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.spec.scenario_tables import (
    EgoSpec,
    LidarSpec,
    ObstacleSpec,
    RoadSpec,
    ScenarioMeta,
    TrafficSpec,
    VehicleSpec,
)
from scenarios.spec.toml_io import dumps_spec, load_spec

#: the scenarios shipped with sdc
CATALOG_DIR = Path(__file__).resolve().parent / "catalog"

__all__ = [
    "CATALOG_DIR",
    "AvoidParams",
    "ControllerSpec",
    "EgoSpec",
    "LaneKeepParams",
    "LidarSpec",
    "ObstacleSpec",
    "RoadSpec",
    "ScenarioMeta",
    "ScenarioSpec",
    "SdcError",
    "SeedParams",
    "SpecError",
    "TrafficSpec",
    "VehicleSpec",
    "dumps_spec",
    "load_spec",
]
