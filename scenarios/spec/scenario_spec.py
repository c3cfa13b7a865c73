"""The scenario specification: frozen dataclasses, validated on construction.

Positions are metres along the road's centre line, lane 0 is the rightmost lane,
lateral offsets are positive to the left (ISO 8855). ``position_m`` and
``start_m`` locate the centre of the obstacle's or the ego's body.
"""

from __future__ import annotations

import dataclasses
import json
import math
from typing import Any, Literal

import numpy as np

from scenarios.common.errors import SpecError
from scenarios.common.seeding import SEED_LIMIT
from scenarios.spec.backends import BACKENDS, Backend
from scenarios.spec.bodies import OBSTACLE_CLASSES, OBSTACLE_SIZES_M, VEHICLE_MODELS
from scenarios.spec.controller_params import (
    CONTROLLER_PARAMS,
    DEFAULT_LOOK_AHEAD_M,
    AvoidParams,
    LaneKeepParams,
    SeedParams,
)
from scenarios.spec.controller_ref import check_name, controller_label
from scenarios.spec.spec_fields import Spec, build, num, to_plain

spec_class = dataclasses.dataclass(frozen=True, kw_only=True)

#: SUMO's clock ticks in whole milliseconds: it rounds any other step length, so
#: its traffic would run at another rate than the ego, and refuses one under 1 ms
MIN_STEP_S = 0.001
#: the widest curve [m] (a polyline within 1 mm of its arc needs fewer points than
#: floating point can tell apart beyond)
MAX_CURVE_RADIUS_M = 1_000_000.0
#: SUMO's bounds on a vehicle type's speed factor (highway-env's desired speeds too)
SPEED_FACTOR_BOUNDS = (0.2, 2.0)
#: the most steps one run may take, warm-up included (1000 s at 1 ms steps; any
#: duration up to the limit at the default 0.064 s steps)
MAX_STEPS = 1_000_000


@spec_class
class ScenarioMeta(Spec):
    name: str
    duration_s: float = num(gt=0, le=36_000)
    #: a whole number of milliseconds; on a sumo_config road left out, the configuration's
    #: own step-length where it has one
    step_s: float = num(0.064, ge=MIN_STEP_S, le=1.0)
    seed: int = num(0, ge=0, lt=SEED_LIMIT)
    backend: Literal["sumo", "highway", "scripted"] = "sumo"  # the world simulator

    def __post_init__(self):
        super().__post_init__()
        step_ms = self.step_s * 1000
        if abs(step_ms - round(step_ms)) > 1e-6:
            raise SpecError("step_s", f"must be a whole number of milliseconds (SUMO's "
                            f"resolution), got {self.step_s!r}")
        if self.duration_s / self.step_s > MAX_STEPS:
            raise SpecError("duration_s", f"{self.duration_s:g} s is "
                            f"{self.duration_s / self.step_s:,.0f} steps of {self.step_s:g} s, "
                            f"more than the {MAX_STEPS:,} a run may take")

    @property
    def world_backend(self) -> Backend:
        """What the backend it runs on can do (:mod:`scenarios.spec.backends`)."""
        return BACKENDS[self.backend]


#: the road kinds that are a route through a SUMO network
NETWORK_KINDS = ("sumo_net", "sumo_config", "opendrive")
#: the road kinds whose traffic is ``traffic.vehicles`` random trips across the network
TRIP_KINDS = ("sumo_net", "opendrive")
#: a file path starting with this is inside SUMO's installation (``sumo.SUMO_HOME``):
#: the scenarios its package ships, wherever it is installed (``sumo:tools/game/...``)
SUMO_HOME_PREFIX = "sumo:"


@spec_class
class RoadSpec(Spec):
    """A one-way N-lane road starting at the origin heading +x (``straight``,
    ``curve``), or a route through a SUMO network (``sumo_net``, ``sumo_config``,
    ``opendrive``).

    ``curve_radius_m`` (curve only) is signed: positive turns left, negative right.
    For ``sumo_net``, ``net_file`` names any SUMO ``.net.xml`` or ``.net.xml.gz``
    (relative to the scenario file), ``length_m`` is the length of the ego's route, drawn from the
    seed, and the road is that route's lane: ``lanes`` is not given, positions
    are along the route and every lane index is 0. ``lane_width_m`` and
    ``speed_limit_mps`` come from the network. For ``sumo_config``, ``config_file``
    names a SUMO configuration (``.sumocfg``, relative to the scenario file): its
    network is the road's, as for ``sumo_net``, and its own demand is the traffic
    (``scenarios/sumo_net/sumo_config.py``). For ``opendrive``, ``xodr_file`` names an
    OpenDRIVE road network (``.xodr``, relative to the scenario file), converted by SUMO's
    netconvert and then a road as ``sumo_net`` is (``scenarios/sumo_net/opendrive_net.py``).
    """

    kind: Literal["straight", "curve", "sumo_net", "sumo_config", "opendrive"] = "straight"
    length_m: float = num(gt=0, le=50_000)
    lanes: int | None = num(None, ge=1, le=8)  # required for straight and curve
    lane_width_m: float = num(3.5, ge=2.0, le=6.0)
    speed_limit_mps: float = num(33.33, gt=0, le=70)
    curve_radius_m: float | None = None
    net_file: str | None = None  # sumo_net only
    config_file: str | None = None  # sumo_config only
    xodr_file: str | None = None  # opendrive only
    #: a network road (sumo_net, sumo_config, opendrive): "straight" goes straight on
    #: at every junction where its lane can (turning only where it must), "any" takes
    #: a random turn at each
    route_turns: Literal["straight", "any"] = "straight"
    #: a network road (sumo_net, sumo_config, opendrive): the ego's route pinned, as
    #: SUMO edge ids in order (default: drawn from the seed)
    route_edges: tuple[str, ...] | None = None
    #: with ``route_edges``: the ego's lane on the first edge, SUMO's index (0 the
    #: rightmost; default: the rightmost lane that leads through every edge)
    route_lane: int | None = num(None, ge=0, le=15)
    see_edges: bool = True

    @property
    def on_network(self) -> bool:
        """Is the road a route through a SUMO network (``sumo_net``, ``sumo_config``)?"""
        return self.kind in NETWORK_KINDS

    @property
    def own_demand(self) -> bool:
        """Does the road bring its own demand (a ``sumo_config`` road's configuration),
        run until ``traffic.enter_s`` as every run's warm-up?"""
        return self.kind == "sumo_config"

    @property
    def network_field(self) -> str:
        """The field naming what a network road is read from."""
        return {"sumo_net": "road.net_file", "sumo_config": "road.config_file",
                "opendrive": "road.xodr_file"}[self.kind]

    @property
    def lane_count(self) -> int:
        """Lanes of the road (a sumo_net road is its route's one lane)."""
        return self.lanes or 1

    @property
    def half_width_m(self) -> float:
        return self.lane_count * self.lane_width_m / 2

    def lane_center_d_m(self, lane: int) -> float:
        """Lateral offset of a lane's centre from the road's centre line [m]."""
        return (lane - (self.lane_count - 1) / 2) * self.lane_width_m


@spec_class
class TrafficSpec(Spec):
    """Background traffic entering at the road's start; ``speed_dev`` is relative.

    On a ``sumo_net`` road, ``vehicles`` cars drive random trips (from and to
    edges drawn in proportion to their length, like SUMO's ``randomTrips.py
    -l``), the first ones departing one step after the ego from free random places, each car that
    arrives replaced by a new trip (``scenarios/sumo_net/random_trips.py``). They drive at each
    edge's speed limit times a factor ~ N(1, ``speed_dev``); ``flow_vph_per_lane`` and
    ``speed_mean_mps`` are for the built-in roads.

    With ``warm_up_s``, the traffic flows that long before the ego is put on the
    road (vehicles where it starts or an obstacle stands are taken off), so it starts
    inside traffic. On the sumo backend the warmed-up traffic is a warm state
    (``scenarios/sumo/warm_state.py``), computed once and loaded by every run that shares
    it: the same network, traffic, step and ``warm_seed`` (default: the scenario's seed).

    On a ``sumo_config`` road the configuration's own demand is the traffic: the ego
    enters at SUMO's time ``enter_s`` (at least one step after the configuration's
    begin), and the demand before it is the warm-up, a warm state as above.

    On the sumo backend every lane change takes ``lane_change_s`` (sideways at a lane
    width per that; ``scenarios/scene/traffic_model.py``); highway-env steers its own.
    """

    flow_vph_per_lane: float = num(0.0, ge=0, le=3600)
    speed_mean_mps: float = num(25.0, gt=0, le=70)
    speed_dev: float = num(0.1, ge=0, le=1)
    warm_up_s: float = num(0.0, ge=0, le=3600)  # traffic runs this long before the ego enters
    vehicles: int = num(0, ge=0, le=100_000)  # sumo_net, opendrive: vehicles on random trips
    warm_seed: int | None = num(None, ge=0, lt=SEED_LIMIT)  # the warm-up's seed (None: scenario's)
    lane_change_s: float = num(2.0, ge=1.0, le=10.0)  # sumo: how long a lane change takes
    enter_s: float = num(0.0, ge=0, le=86_400)  # sumo_config: SUMO's time the ego enters at


@spec_class
class ObstacleSpec(Spec):
    kind: Literal["car", "truck", "barrel", "pedestrian", "bicycle"]
    lane: int = num(ge=0)
    position_m: float = num(ge=0)
    lateral_offset_m: float = 0.0
    #: its body's length and width (default: its kind's, scenarios/spec/bodies.py)
    length_m: float | None = num(None, gt=0, le=30)
    width_m: float | None = num(None, gt=0, le=5)

    @property
    def size_m(self) -> tuple[float, float]:
        length_m, width_m = OBSTACLE_SIZES_M[self.kind]
        return (length_m if self.length_m is None else self.length_m,
                width_m if self.width_m is None else self.width_m)

    @property
    def sized(self) -> bool:
        """Is its size its own, not its kind's?"""
        return self.size_m != OBSTACLE_SIZES_M[self.kind]

    @property
    def type_name(self) -> str:
        """The name of its SUMO type (after ``OBSTACLE_TYPE_PREFIX``): its kind, and
        its size where that is its own."""
        return f"{self.kind}.{self.size_m[0]:g}x{self.size_m[1]:g}" if self.sized else self.kind

    @property
    def vehicle_class(self) -> str | None:
        """Its SUMO vehicle class, ``pedestrian`` for a standing person (None: a thing)."""
        return OBSTACLE_CLASSES[self.kind]


@spec_class
class EgoSpec(Spec):
    lane: int = num(ge=0)
    start_m: float = num(ge=0)
    speed_mps: float = num(ge=0, le=70)


def beam_angles_rad(beams: int, fov_deg: float) -> np.ndarray:
    """Beam directions relative to the car's heading, index 0 leftmost.

    Beams are ``fov_deg / beams`` apart and index ``beams // 2`` looks straight
    ahead, as in the lesson's 180-beam range image (ranges[85:96] is the centre).
    """
    step_rad = math.radians(fov_deg) / beams
    return (beams // 2 - np.arange(beams)) * step_rad


@spec_class
class LidarSpec(Spec):
    """Lesson semantics (SICK LMS 291): ``beams`` ranges over ``fov_deg``, index 0 leftmost."""

    beams: int = num(180, ge=1, le=4096)
    fov_deg: float = num(180.0, gt=0, le=360)
    max_range_m: float = num(80.0, gt=0, le=1000)
    noise_std_m: float = num(0.0, ge=0, le=10)
    mount_ahead_m: float = num(3.85, ge=-10, le=10)  # ahead of the rear axle


@spec_class
class VehicleSpec(Spec):
    model: Literal["x5-lesson", "x5-road"] = "x5-lesson"
    friction_mu: float = num(0.9, gt=0, le=2.0)


def _check_plain(value: Any, field: str) -> None:
    """A plug-in's parameter must be plain data (numbers, strings, booleans, and
    lists and tables of them): what a manifest and a plan can hold."""
    if isinstance(value, dict):
        for key, item in value.items():
            _check_plain(item, f"{field}.{key}")
    elif isinstance(value, list):
        for i, item in enumerate(value):
            _check_plain(item, f"{field}[{i}]")
    elif isinstance(value, float) and not math.isfinite(value):
        raise SpecError(field, f"must be a finite number, got {value!r}")
    elif not isinstance(value, str | int | float | bool):
        raise SpecError(field, f"must be a number, string, boolean, array or table, "
                        f"got {type(value).__name__}")


@dataclasses.dataclass(frozen=True)
class ControllerSpec:
    """The ``[controller]`` table: a name (see ``scenarios.spec.controller_ref``) and the
    parameters. A built-in's parameters are validated here, into its params class;
    a plug-in's are kept as the plain TOML values, for its constructor to judge."""

    name: str
    params: LaneKeepParams | AvoidParams | dict

    @classmethod
    def from_plain(cls, data: Any, path: str = "controller") -> ControllerSpec:
        if not isinstance(data, dict):
            raise SpecError(path, f"must be a table, got {type(data).__name__}")
        name = check_name(data.get("name", "seed"), f"{path}.name")
        params = {k: v for k, v in data.items() if k != "name"}
        if name in CONTROLLER_PARAMS:
            return cls(name, build(CONTROLLER_PARAMS[name], params, path))
        for key, value in params.items():
            _check_plain(value, f"{path}.{key}")
        return cls(name, params)

    @property
    def builtin(self) -> bool:
        return self.name in CONTROLLER_PARAMS

    @property
    def label(self) -> str:
        """The short name in run IDs and result rows (``controller_label``)."""
        return controller_label(self.name)

    def plain_params(self) -> dict:
        """The parameters as plain values: what the controller's constructor gets."""
        if isinstance(self.params, dict):
            return json.loads(json.dumps(self.params))  # a deep copy the plug-in may keep
        return to_plain(self.params)

    def to_plain(self) -> dict:
        return {"name": self.name, **self.plain_params()}

    @property
    def look_ahead_m(self) -> float:
        """Where the lane reading's preview offset is taken, ahead of the body centre."""
        value = (self.params.get("look_ahead_m") if isinstance(self.params, dict)
                 else self.params.look_ahead_m)
        return float(value) if isinstance(value, int | float) else DEFAULT_LOOK_AHEAD_M

    @property
    def detect_beams(self) -> int:
        """The central beams the seed controller watches (the lesson's 11 for the others):
        their shortest range is the detection range in metrics and drawings."""
        value = getattr(self.params, "detect_beams", None)
        return value if isinstance(value, int) else SeedParams().detect_beams

    def takes(self, name: str, field: str) -> bool:
        """Does the controller ``name``, in a sweep of this base controller, take the
        parameter ``field``? A built-in when its params class has the field, a
        plug-in when it is this one."""
        if name in CONTROLLER_PARAMS:
            return field in {f.name for f in dataclasses.fields(CONTROLLER_PARAMS[name])}
        return name == self.name

    def renamed(self, name: str, values: dict[str, Any] | None = None) -> ControllerSpec:
        """The controller ``name`` with those of this one's parameters it takes (see
        :meth:`takes`), then the swept ``values`` (field -> value) it takes."""
        if name == self.name and not values:
            return self
        merged = {**self.plain_params(), **(values or {})}
        return ControllerSpec.from_plain(
            {"name": name, **{k: v for k, v in merged.items() if self.takes(name, k)}})


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
