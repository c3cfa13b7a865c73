"""A scenario file's tables as frozen dataclasses, each validated on construction:
``[scenario]``, ``[road]``, ``[traffic]``, ``[[obstacles]]``, ``[ego]``, ``[lidar]``
(and its beams' directions), ``[vehicle]``; the road kinds and the bounds they share.
How positions, lanes and offsets read: :mod:`scenarios.spec.scenario_spec`."""

from __future__ import annotations

import dataclasses
import math
from typing import Literal

import numpy as np

from scenarios.common.errors import SpecError
from scenarios.common.seeding import SEED_LIMIT
from scenarios.spec.backends import BACKENDS, Backend
from scenarios.spec.bodies import OBSTACLE_CLASSES, OBSTACLE_SIZES_M
from scenarios.spec.spec_fields import Spec, num

spec_class = dataclasses.dataclass(frozen=True, kw_only=True)

#: SUMO's clock ticks in whole milliseconds: it rounds any other step length, so
#: its traffic would run at another rate than the ego, and refuses one under 1 ms
MIN_STEP_S = 0.001
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
