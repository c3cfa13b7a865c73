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
from scenarios.spec.bodies import OBSTACLE_CLASSES, OBSTACLE_SIZES_M, VEHICLE_MODELS
from scenarios.spec.controller_ref import BUILTIN_CONTROLLERS, check_name, controller_label
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
    backend: Literal["sumo", "highway"] = "sumo"  # the world simulator

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


#: the road kinds that are a route through a SUMO network
NETWORK_KINDS = ("sumo_net", "sumo_config")
#: a file path starting with this is inside SUMO's installation (``sumo.SUMO_HOME``):
#: the scenarios its package ships, wherever it is installed (``sumo:tools/game/...``)
SUMO_HOME_PREFIX = "sumo:"


@spec_class
class RoadSpec(Spec):
    """A one-way N-lane road starting at the origin heading +x (``straight``,
    ``curve``), or a route through a SUMO network (``sumo_net``, ``sumo_config``).

    ``curve_radius_m`` (curve only) is signed: positive turns left, negative right.
    For ``sumo_net``, ``net_file`` names any SUMO ``.net.xml`` or ``.net.xml.gz``
    (relative to the scenario file), ``length_m`` is the length of the ego's route, drawn from the
    seed, and the road is that route's lane: ``lanes`` is not given, positions
    are along the route and every lane index is 0. ``lane_width_m`` and
    ``speed_limit_mps`` come from the network. For ``sumo_config``, ``config_file``
    names a SUMO configuration (``.sumocfg``, relative to the scenario file): its
    network is the road's, as for ``sumo_net``, and its own demand is the traffic
    (``scenarios/sumo_net/sumo_config.py``).
    """

    kind: Literal["straight", "curve", "sumo_net", "sumo_config"] = "straight"
    length_m: float = num(gt=0, le=50_000)
    lanes: int | None = num(None, ge=1, le=8)  # required for straight and curve
    lane_width_m: float = num(3.5, ge=2.0, le=6.0)
    speed_limit_mps: float = num(33.33, gt=0, le=70)
    curve_radius_m: float | None = None
    net_file: str | None = None  # sumo_net only
    config_file: str | None = None  # sumo_config only
    #: sumo_net: "straight" goes straight on at every junction where its lane can
    #: (turning only where it must), "any" takes a random turn at each
    route_turns: Literal["straight", "any"] = "straight"
    #: sumo_net and sumo_config: the ego's route pinned, as SUMO edge ids in order
    #: (default: drawn from the seed)
    route_edges: tuple[str, ...] | None = None
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
        return "road.net_file" if self.kind == "sumo_net" else "road.config_file"

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
    vehicles: int = num(0, ge=0, le=100_000)  # sumo_net: vehicles on random trips
    warm_seed: int | None = num(None, ge=0, lt=SEED_LIMIT)  # the warm-up's seed (None: scenario's)
    lane_change_s: float = num(2.0, ge=1.0, le=10.0)  # sumo: how long a lane change takes
    enter_s: float = num(0.0, ge=0, le=86_400)  # sumo_config: SUMO's time the ego enters at


@spec_class
class ObstacleSpec(Spec):
    kind: Literal["car", "truck", "barrel", "pedestrian", "bicycle"]
    lane: int = num(ge=0)
    position_m: float = num(ge=0)
    lateral_offset_m: float = 0.0

    @property
    def size_m(self) -> tuple[float, float]:
        return OBSTACLE_SIZES_M[self.kind]

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


@spec_class
class LaneKeepParams(Spec):
    """Bang-bang lane keeping on the lane centre's offset at a look-ahead point.

    Steer ``keep_steer_rad`` toward the centre while the look-ahead offset exceeds
    ``deadband_m``; otherwise (and when the lane is not sensed) keep the last angle.
    """

    keep_steer_rad: float = num(0.1, ge=0, le=1.0)
    look_ahead_m: float = num(5.0, ge=0, le=100)
    deadband_m: float = num(0.0, ge=0, le=5)


@spec_class
class SeedParams(LaneKeepParams):
    """The lesson's avoid-then-return maneuver; periods are control steps."""

    detect_range_m: float = num(5.0, gt=0)
    detect_beams: int = num(11, ge=1)
    avoid_steer_rad: float = num(0.7, ge=0, le=1.5)
    left_periods: int = num(10, ge=0)
    straight_periods: int = num(20, ge=0)
    right_periods: int = num(10, ge=0)


@spec_class
class AvoidParams(Spec):
    """The closed-loop avoid-then-return maneuver (``sdc.car.avoid.controller``).

    Lateral offsets are from the centre of the car's own lane, distances along it.
    """

    #: where the lane reading's preview offset is taken, ahead of the body centre
    #: (the controller reads the lane's curvature from it)
    look_ahead_m: float = num(5.0, gt=0, le=100)
    #: the speed kept when nothing is in the way; none: the speed at the first step
    cruise_speed_mps: float | None = num(None, ge=0, le=70)
    #: an obstacle in the own lane starts the maneuver when its gap over the speed
    #: (time to collision) falls under this
    detect_ttc_s: float = num(4.0, gt=0, le=60)
    #: the gap to keep to an obstacle when stopping behind it ...
    stop_margin_m: float = num(1.5, ge=0, le=50)
    #: ... or this gap when there is room to brake for it, enough to steer round
    #: the obstacle from a standstill later
    wait_gap_m: float = num(7.0, ge=0, le=100)
    #: the free space wanted on each side of the body when passing
    lateral_clearance_m: float = num(0.5, ge=0, le=5)
    #: what comes within this of the body's sides, the car on its lane's centre,
    #: is in its way (a kerb jutting into the lane at a junction's corner is not)
    path_clearance_m: float = num(0.3, ge=0, le=5)
    #: returns this close inside the own lane's edges do not count as in the lane
    #: (the road edge's own returns)
    edge_tolerance_m: float = num(0.1, ge=0, le=1)
    #: a side's corridor is checked from this far behind the car's rear bumper
    rear_margin_m: float = num(2.0, ge=0, le=50)
    #: ... to beyond the obstacle by the distance the car covers in this time
    free_time_s: float = num(2.0, ge=0, le=30)
    #: returns this far beyond the nearest one in the lane belong to the same
    #: obstacle (its width sets the lateral target)
    obstacle_depth_m: float = num(15.0, gt=0, le=100)
    #: without a rear view, a neighbouring lane is entered only after it was seen
    #: empty beside the car for this long, from the first step on (traffic from
    #: behind is out of the lidar's view) ...
    lane_watch_s: float = num(3.0, ge=0, le=600)
    #: ... or for this long once anything was seen in it beside the car (a lane
    #: whose traffic overtakes the car is not entered while stopping is possible) ...
    traffic_memory_s: float = num(60.0, ge=0, le=36_000)
    #: ... and the own lane, to return to it, for this long
    return_watch_s: float = num(1.5, ge=0, le=600)
    #: the swerve's estimated duration (bang-bang lateral acceleration plus the
    #: steering's lag) times this must fit in the gap, or the car brakes
    swerve_time_factor: float = num(1.3, ge=1, le=10)
    #: the steering's lag in that estimate: winding up to this angle and back at
    #: the car's steering rate
    swerve_steer_rad: float = num(0.5, ge=0, le=1.5)
    #: the tightest turn the estimate allows at any speed: the turning radius at
    #: this fraction of the car's steering limit (an S of two such arcs)
    tightest_steer_fraction: float = num(0.9, gt=0, le=1)
    #: the swerve's sideways shift clears the obstacle's edge by this much more
    shift_margin_m: float = num(0.2, ge=0, le=5)
    #: the car returns when its rear bumper is this far past the obstacle
    return_gap_m: float = num(2.0, ge=0, le=50)
    #: the return ends (cruise) once the offset is within this of the lane centre
    settled_offset_m: float = num(0.3, gt=0, le=2)
    #: the steering aims at a point this far ahead at least ...
    min_preview_m: float = num(4.0, gt=0, le=100)
    #: ... or as far as the car covers in this time
    preview_time_s: float = num(0.8, gt=0, le=10)
    #: the steering's lateral acceleration cap (the path's curvature x speed^2)
    max_lateral_accel_mps2: float = num(5.0, gt=0, le=20)
    #: the car slows for the lane's bends ahead (junction turns, tight curves) to
    #: take them at no more than this lateral acceleration
    turn_lateral_accel_mps2: float = num(3.0, gt=0, le=20)
    #: braking for an obstacle asks this times the deceleration a stop needs ...
    brake_gain: float = num(1.5, ge=1, le=10)
    #: ... and stops outright from under this speed
    creep_speed_mps: float = num(0.5, ge=0, le=10)
    #: the cruise speed's feedback gain: acceleration per m/s of speed error
    speed_gain_1ps: float = num(0.5, gt=0, le=10)
    #: with something ahead in its path the car keeps a speed from which it stops
    #: short of it braking at this fraction of its hardest
    gap_decel_fraction: float = num(0.5, gt=0, le=1)
    #: the range image covers the rear when its beams reach this far round from
    #: straight ahead on both sides (a 360-degree lidar): then the lanes behind are
    #: watched instead of waited for (the watch times above apply without it)
    rear_view_deg: float = num(170.0, gt=90, le=180)
    #: with a rear view a lane is entered (out to pass, or back) only when the
    #: nearest vehicle behind in it is at least rear_min_gap_m plus its closing
    #: speed times rear_gap_time_s behind the car's rear bumper (sdc.car.avoid.rear_watch)
    rear_gap_time_s: float = num(3.0, ge=0, le=30)
    rear_min_gap_m: float = num(10.0, ge=0, le=200)
    #: ... or, when that vehicle stands (slower than pass_max_speed_mps: a queue, a
    #: car waiting to merge; what comes behind must stop behind it), this gap (SUMO's
    #: default minGap)
    rear_standing_gap_m: float = num(2.5, ge=0, le=200)
    #: ... and a lane seen empty only when it was seen so far back that a vehicle
    #: just out of sight, as fast as the fastest seen in it so far or this fast,
    #: would leave that gap (the lidar's range and shadows limit how far)
    rear_unseen_speed_mps: float = num(15.0, ge=0, le=70)
    #: the closing speed is measured over this long (a vehicle seen for less than
    #: half of it, or lost for a moment, keeps its lane closed)
    rear_track_s: float = num(0.5, gt=0, le=10)
    #: a gap behind that grows by more than this in a step belongs to another
    #: vehicle: its track starts afresh
    rear_jump_m: float = num(3.0, gt=0, le=100)
    #: the nearest thing in the own lane ahead (the leader) is tracked along the
    #: lane over this long: its speed (sdc.car.avoid.leader_watch) ...
    leader_track_s: float = num(0.6, gt=0, le=10)
    #: ... and a leader that moves by more than this against its track in a step
    #: is another one: the track starts afresh
    leader_jump_m: float = num(2.0, gt=0, le=100)
    #: only a leader slower than this along the lane is an obstacle to pass; a
    #: faster one is followed (a car queued behind is traffic, not an obstacle:
    #: one seen moving faster than this is followed, and waited for when it stops)
    pass_max_speed_mps: float = num(2.0, ge=0, le=70)
    #: ... unless it stands this long: then it is passed like any obstacle
    stand_patience_s: float = num(30.0, ge=0, le=3600)
    #: with a rear view, a standing obstacle (its speed known, under
    #: pass_max_speed_mps) starts the pass this long before the car would reach it
    #: at its speed, into an open lane whose corridor is free as far as the lane
    #: change takes when what is ahead in that lane moves the car's way (it is then
    #: followed), else free to beyond the obstacle; 0: only at detect_ttc_s
    early_pass_ttc_s: float = num(10.0, ge=0, le=60)
    #: a pass on a side where the map shows no lane of the car's direction on past
    #: the obstacle (the other direction's lane, a lane that ends, a shoulder)
    #: starts only with that side seen free as far as a car coming the other way,
    #: out of sight, at this speed would come before the car is back in its lane
    #: (on the A10's two-way links SUMO's cars come at up to 19 m/s)
    oncoming_speed_mps: float = num(20.0, ge=0, le=70)
    #: following a leader (the intelligent driver model, Treiber et al. 2000;
    #: standing, wait_gap_m behind it): the time gap kept ...
    follow_time_gap_s: float = num(1.5, ge=0, le=10)
    #: ... the acceleration it asks at most, and the deceleration it is comfortable with
    follow_accel_mps2: float = num(1.5, gt=0, le=10)
    follow_decel_mps2: float = num(2.0, gt=0, le=10)
    #: no pass starts round what stands in a junction, up to this far past its stop
    #: line (a car crossing or turning) ...
    junction_depth_m: float = num(20.0, ge=0, le=500)
    #: ... or up to this far before a stop line where cars wait (a red or yellow
    #: light, a duty to give way): a queue. Both are waited behind, while the light
    #: is red or yellow, or else for this long at most
    junction_clear_m: float = num(25.0, ge=0, le=500)
    queue_patience_s: float = num(10.0, ge=0, le=3600)
    #: a yellow light is stopped for when stopping at its line needs no more than
    #: this fraction of the car's hardest braking (a red one whenever it can stop)
    yellow_decel_fraction: float = num(0.5, gt=0, le=1)
    #: before a line where the car gives way (a sign, right before left, a green
    #: without priority), within this of it, the car watches for foes: returns
    #: outside its lane, ahead of it and within give_way_reach_m of the line's middle,
    #: that moved more than foe_move_m over foe_track_s toward the line and reach it
    #: within give_way_gap_s (sdc.car.avoid.foe_watch) ...
    give_way_watch_m: float = num(60.0, ge=0, le=500)
    give_way_reach_m: float = num(50.0, gt=0, le=500)
    foe_move_m: float = num(1.5, gt=0, le=50)
    foe_track_s: float = num(0.5, gt=0, le=10)
    give_way_gap_s: float = num(5.0, ge=0, le=60)
    #: ... and stops short of the line (if it can) until none was seen for this long
    give_way_hold_s: float = num(1.0, ge=0, le=60)
    #: before a pedestrian crossing, within give_way_watch_m of it, the car watches its
    #: roadway (returns on it, this far along the route beyond either side of it, and
    #: up to crosswalk_kerb_m short of its ends: the kerbs and the people waiting
    #: there are not on it) for a body no bigger than crosswalk_body_m (a person, a
    #: bicycle: not a car, nor a kerb running on) and stops short of it (if it can)
    #: until none was seen there for give_way_hold_s
    crosswalk_margin_m: float = num(0.0, ge=0, le=20)
    crosswalk_kerb_m: float = num(0.5, ge=0, le=5)
    crosswalk_body_m: float = num(1.8, gt=0, le=20)
    #: through a bend of the lane tighter than this radius the car checks the room
    #: its body sweeps against the range image and picks its line by it ...
    bend_radius_m: float = num(25.0, gt=0, le=1000)
    #: ... keeping this far from every return (the turn at most as tight as at
    #: tightest_steer_fraction of the steering limit)
    bend_clearance_m: float = num(0.25, ge=0, le=5)


#: each built-in controller's parameters: the class of this module that its line in the
#: registry (``controller_ref.BUILTIN_CONTROLLERS``) names
CONTROLLER_PARAMS: dict[str, type[Spec]] = {
    name: globals()[builtin.params] for name, builtin in BUILTIN_CONTROLLERS.items()}
assert all(issubclass(params, Spec) for params in CONTROLLER_PARAMS.values())
#: the preview distance of the lane reading for a controller that names none
DEFAULT_LOOK_AHEAD_M = LaneKeepParams().look_ahead_m


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
        tables = {"scenario", "road", "ego", "traffic", "obstacles", "lidar", "vehicle",
                  "controller"}
        for key in data:
            if key not in tables:
                raise SpecError(key, f"unknown table (known: {', '.join(sorted(tables))})")
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
    if ego.lane >= road.lane_count:
        raise SpecError("ego.lane", f"{ego.lane} >= lanes ({road.lane_count})")
    if ego.start_m - model.length_m / 2 < 0 or ego.start_m + model.length_m / 2 >= road.length_m:
        raise SpecError(
            "ego.start_m",
            f"{ego.start_m} puts the {model.length_m} m car off the {road.length_m} m road",
        )
    ego_box = (ego.start_m, road.lane_center_d_m(ego.lane), model.length_m, model.width_m)

    for i, obstacle in enumerate(spec.obstacles):
        path = f"obstacles[{i}]"
        length_m, width_m = obstacle.size_m
        if obstacle.lane >= road.lane_count:
            raise SpecError(f"{path}.lane", f"{obstacle.lane} >= lanes ({road.lane_count})")
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
    own = {"road.net_file": ("sumo_net",), "traffic.vehicles": ("sumo_net",),
           "road.config_file": ("sumo_config",), "traffic.enter_s": ("sumo_config",),
           "road.route_turns": NETWORK_KINDS, "road.route_edges": NETWORK_KINDS}
    given = {"road.net_file": road.net_file is not None, "traffic.vehicles": traffic.vehicles > 0,
             "road.config_file": road.config_file is not None,
             "traffic.enter_s": traffic.enter_s > 0,
             "road.route_turns": road.route_turns != "straight",
             "road.route_edges": road.route_edges is not None}
    for field, kinds in own.items():
        if given[field] and road.kind not in kinds:
            names = " or ".join(f'"{k}"' for k in kinds)
            raise SpecError(field, f"only applies to road kind {names}")
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
        demand = "traffic.vehicles" if road.kind == "sumo_net" else "its configuration's demand"
        raise SpecError("traffic.flow_vph_per_lane",
                        f'is for the built-in roads; a "{road.kind}" road takes {demand}')
    if road.kind == "sumo_config" and traffic.warm_up_s > 0:
        raise SpecError("traffic.warm_up_s", 'a "sumo_config" road warms up on its '
                        "configuration's demand until traffic.enter_s")
    if spec.scenario.backend != "sumo":
        raise SpecError("scenario.backend",
                        f'{spec.scenario.backend} cannot load a SUMO network '
                        f'(road.kind "{road.kind}")')
