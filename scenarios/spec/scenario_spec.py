"""The scenario specification: frozen dataclasses, validated on construction.

Positions are metres along the road's centre line, lane 0 is the rightmost lane,
lateral offsets are positive to the left (ISO 8855). ``position_m`` and
``start_m`` locate the centre of the obstacle's or the ego's body.
"""

from __future__ import annotations

import dataclasses
import json
import math
from typing import Any

from scenarios.common.errors import SpecError
from scenarios.spec.bodies import VEHICLE_MODELS
from scenarios.spec.controller_params import SeedParams
from scenarios.spec.controller_spec import ControllerSpec
from scenarios.spec.scenario_tables import (
    MAX_STEPS,
    NETWORK_KINDS,
    TRIP_KINDS,
    EgoSpec,
    LidarSpec,
    ObstacleSpec,
    RoadSpec,
    ScenarioMeta,
    TrafficSpec,
    VehicleSpec,
)
from scenarios.spec.spec_fields import build, to_plain

#: the widest curve [m] (a polyline within 1 mm of its arc needs fewer points than
#: floating point can tell apart beyond)
MAX_CURVE_RADIUS_M = 1_000_000.0
#: SUMO's bounds on a vehicle type's speed factor (highway-env's desired speeds too)
SPEED_FACTOR_BOUNDS = (0.2, 2.0)


#: the tables of a scenario file
SCENARIO_TABLES = frozenset({"scenario", "road", "ego", "traffic", "obstacles", "lidar",
                             "vehicle", "controller"})


@dataclasses.dataclass(frozen=True)
class ScenarioSpec:
    scenario: ScenarioMeta
    road: RoadSpec
    ego: EgoSpec
    traffic: TrafficSpec = TrafficSpec()
    obstacles: tuple[ObstacleSpec, ...] = ()
    lidar: LidarSpec = LidarSpec()
    vehicle: VehicleSpec = VehicleSpec()
    controller: ControllerSpec = ControllerSpec("seed", SeedParams())

    def __post_init__(self):
        _check_consistency(self)

    @classmethod
    def from_plain(cls, data: Any) -> ScenarioSpec:
        """Build from the plain mapping of a TOML file; errors name the field path."""
        if not isinstance(data, dict):
            raise SpecError("", "a scenario must be a table")
        if "sweep" in data:
            sweep = data["sweep"]
            base = sweep.get("base") if isinstance(sweep, dict) else None
            raise SpecError("", "this is a sweep file ([sweep]), not a scenario: use `sdc "
                            "sweep FILE --out DIR`" + (f", or run its base scenario "
                            f"(sweep.base = {json.dumps(base)})" if isinstance(base, str)
                            else ""))
        for key in data:
            if key not in SCENARIO_TABLES:
                raise SpecError(key, f"unknown table (known: "
                                f"{', '.join(sorted(SCENARIO_TABLES))})")
        for key in ("scenario", "road", "ego"):
            if key not in data:
                raise SpecError(key, "table is required")
        obstacles = data.get("obstacles", [])
        if not isinstance(obstacles, list):
            raise SpecError("obstacles", "must be an array of tables ([[obstacles]])")
        return cls(
            scenario=build(ScenarioMeta, data["scenario"], "scenario"),
            road=build(RoadSpec, data["road"], "road"),
            ego=build(EgoSpec, data["ego"], "ego"),
            traffic=build(TrafficSpec, data.get("traffic", {}), "traffic"),
            obstacles=tuple(
                build(ObstacleSpec, o, f"obstacles[{i}]") for i, o in enumerate(obstacles)
            ),
            lidar=build(LidarSpec, data.get("lidar", {}), "lidar"),
            vehicle=build(VehicleSpec, data.get("vehicle", {}), "vehicle"),
            controller=ControllerSpec.from_plain(data.get("controller", {"name": "seed"})),
        )

    def to_plain(self) -> dict:
        plain = {
            "scenario": to_plain(self.scenario),
            "road": to_plain(self.road),
            "traffic": to_plain(self.traffic),
            "ego": to_plain(self.ego),
            "lidar": to_plain(self.lidar),
            "vehicle": to_plain(self.vehicle),
            "controller": self.controller.to_plain(),
        }
        if self.obstacles:
            plain["obstacles"] = [to_plain(o) for o in self.obstacles]
        return plain

    def with_controller(self, name: str) -> ScenarioSpec:
        return dataclasses.replace(self, controller=self.controller.renamed(name))

    def with_backend(self, backend: str) -> ScenarioSpec:
        return dataclasses.replace(
            self, scenario=dataclasses.replace(self.scenario, backend=backend))

    def with_seed(self, seed: int) -> ScenarioSpec:
        return dataclasses.replace(self, scenario=dataclasses.replace(self.scenario, seed=seed))


def _overlap_sd(a: tuple[float, float, float, float], b: tuple[float, float, float, float]):
    """Do two road-aligned rectangles (s, d, length, width) overlap?"""
    return abs(a[0] - b[0]) < (a[2] + b[2]) / 2 and abs(a[1] - b[1]) < (a[3] + b[3]) / 2


def _check_consistency(spec: ScenarioSpec) -> None:
    road = spec.road
    if road.kind == "curve":
        radius = road.curve_radius_m
        if radius is None:
            raise SpecError("road.curve_radius_m", 'is required for kind "curve"')
        if abs(radius) < road.half_width_m + 5.0:
            raise SpecError(
                "road.curve_radius_m",
                f"|{radius}| is too tight for a {2 * road.half_width_m:g} m wide road "
                f"(needs >= {road.half_width_m + 5.0:g})",
            )
        if abs(radius) > MAX_CURVE_RADIUS_M:
            raise SpecError("road.curve_radius_m", f"|{radius}| is above {MAX_CURVE_RADIUS_M:g}: "
                            'a road that straight is kind "straight"')
        if road.length_m / abs(radius) > 1.5 * math.pi:
            raise SpecError("road.length_m", "the curve would turn more than 270 degrees")
    elif road.curve_radius_m is not None:
        raise SpecError("road.curve_radius_m", 'only applies to kind "curve"')
    _check_road_kind(spec)

    if spec.scenario.duration_s < spec.scenario.step_s:
        raise SpecError("scenario.duration_s", "must be at least one step (step_s)")
    traffic = spec.traffic
    steps = (spec.scenario.duration_s + traffic.warm_up_s) / spec.scenario.step_s
    if steps > MAX_STEPS:
        raise SpecError("traffic.warm_up_s", f"makes the run {steps:,.0f} steps with "
                        f"scenario.duration_s, more than the {MAX_STEPS:,} a run may take")
    if traffic.flow_vph_per_lane > 0 and traffic.speed_mean_mps > 1.5 * road.speed_limit_mps:
        raise SpecError(
            "traffic.speed_mean_mps",
            f"{spec.traffic.speed_mean_mps} is above 1.5 x road.speed_limit_mps "
            f"({road.speed_limit_mps})",
        )
    _check_speed_factor(spec)

    model = VEHICLE_MODELS[spec.vehicle.model]
    ego = spec.ego
    _check_lane(road, ego.lane, "ego.lane")
    if ego.start_m - model.length_m / 2 < 0 or ego.start_m + model.length_m / 2 >= road.length_m:
        raise SpecError(
            "ego.start_m",
            f"{ego.start_m} puts the {model.length_m} m car off the {road.length_m} m road",
        )
    ego_box = (ego.start_m, road.lane_center_d_m(ego.lane), model.length_m, model.width_m)

    for i, obstacle in enumerate(spec.obstacles):
        path = f"obstacles[{i}]"
        length_m, width_m = obstacle.size_m
        _check_lane(road, obstacle.lane, f"{path}.lane")
        if obstacle.position_m + length_m / 2 > road.length_m or obstacle.position_m < length_m / 2:
            raise SpecError(
                f"{path}.position_m",
                f"{obstacle.position_m} puts the {length_m} m {obstacle.kind} beyond the "
                f"{road.length_m} m road",
            )
        d_m = road.lane_center_d_m(obstacle.lane) + obstacle.lateral_offset_m
        if abs(d_m) > road.half_width_m and not road.on_network:  # the network decides
            raise SpecError(
                f"{path}.lateral_offset_m",
                f"{obstacle.lateral_offset_m} puts the {obstacle.kind}'s centre off the road",
            )
        if _overlap_sd(ego_box, (obstacle.position_m, d_m, length_m, width_m)):
            raise SpecError(
                "ego.start_m",
                f"the ego starts inside {path} ({obstacle.kind} at {obstacle.position_m} m)",
            )
        if obstacle.position_m + length_m / 2 <= ego.start_m - model.length_m / 2:
            raise SpecError(
                f"{path}.position_m",
                f"{obstacle.position_m} puts the {obstacle.kind} behind the ego, which starts "
                f"at ego.start_m = {ego.start_m}: the run would never meet it",
            )


def _check_lane(road: RoadSpec, lane: int, field: str) -> None:
    """A lane the road has, or an error saying which it has."""
    if lane < road.lane_count:
        return
    if road.on_network:
        beside = (" (a body beside the route: lateral_offset_m, + to the left)"
                  if field.startswith("obstacles") else "")
        raise SpecError(field, f"{lane}, but a \"{road.kind}\" road is the ego's route, "
                        f"one lane: every lane index is 0{beside}")
    lanes = f"lanes 0 to {road.lane_count - 1}" if road.lane_count > 1 else "lane 0 only"
    raise SpecError(field, f"{lane}, but the road has {lanes} (road.lanes = "
                    f"{road.lane_count}; 0 is the rightmost)")


def _check_speed_factor(spec: ScenarioSpec) -> None:
    """SUMO refuses a traffic type (even with no traffic) whose speed factor, mean
    ``speed_mean_mps / speed_limit_mps``, stays 3 deviations outside its bounds."""
    if spec.road.on_network:  # the network's limits, factor 1
        return
    traffic, lo, hi = spec.traffic, *SPEED_FACTOR_BOUNDS
    factor = traffic.speed_mean_mps / spec.road.speed_limit_mps
    spread = 3 * traffic.speed_dev * factor
    if traffic.speed_dev > 0 and not (factor - spread <= hi and factor + spread >= lo):
        raise SpecError("traffic.speed_mean_mps",
                        f"{traffic.speed_mean_mps} is {factor:.3g} x road.speed_limit_mps "
                        f"({spec.road.speed_limit_mps}); with speed_dev {traffic.speed_dev} "
                        f"SUMO needs {lo} to {hi} x within 3 deviations")


def _check_road_kind(spec: ScenarioSpec) -> None:
    """What a built-in road needs, and what a SUMO network road must not be given."""
    road, traffic = spec.road, spec.traffic
    own = {"road.net_file": ("sumo_net",), "traffic.vehicles": TRIP_KINDS,
           "road.config_file": ("sumo_config",), "traffic.enter_s": ("sumo_config",),
           "road.xodr_file": ("opendrive",),
           "road.route_turns": NETWORK_KINDS, "road.route_edges": NETWORK_KINDS,
           "road.route_lane": NETWORK_KINDS}
    given = {"road.net_file": road.net_file is not None, "traffic.vehicles": traffic.vehicles > 0,
             "road.config_file": road.config_file is not None,
             "traffic.enter_s": traffic.enter_s > 0,
             "road.xodr_file": road.xodr_file is not None,
             "road.route_turns": road.route_turns != "straight",
             "road.route_edges": road.route_edges is not None,
             "road.route_lane": road.route_lane is not None}
    for field, kinds in own.items():
        if given[field] and road.kind not in kinds:
            names = " or ".join(f'"{k}"' for k in kinds)
            raise SpecError(field, f"only applies to road kind {names}")
    if road.route_lane is not None and road.route_edges is None:
        raise SpecError("road.route_lane", "is the ego's lane on a pinned route's first edge: "
                        "give road.route_edges too")
    if not road.on_network:
        if road.lanes is None:
            raise SpecError("road.lanes", f'is required for kind "{road.kind}"')
        return
    if not given[road.network_field]:
        raise SpecError(road.network_field, f'is required for kind "{road.kind}"')
    if road.lanes is not None:
        raise SpecError("road.lanes", f'a "{road.kind}" road is its route\'s own lane: leave '
                        "lanes out (every lane index is 0)")
    if traffic.flow_vph_per_lane > 0:
        demand = ("traffic.vehicles" if road.kind in TRIP_KINDS
                  else "its configuration's demand")
        raise SpecError("traffic.flow_vph_per_lane",
                        f'is for the built-in roads; a "{road.kind}" road takes {demand}')
    if road.kind == "sumo_config" and traffic.warm_up_s > 0:
        raise SpecError("traffic.warm_up_s", 'a "sumo_config" road warms up on its '
                        "configuration's demand until traffic.enter_s")
    if not spec.scenario.world_backend.loads_networks:
        raise SpecError("scenario.backend",
                        f'{spec.scenario.backend} cannot load a SUMO network '
                        f'(road.kind "{road.kind}")')
