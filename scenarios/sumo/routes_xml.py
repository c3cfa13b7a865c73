"""What SUMO loads besides its network: the vehicle types, the ego's route,
the obstacles as vehicles stopped for good where they stand, and the background
traffic (flows per lane on a built road, random trips across a network), as
``.rou.xml`` text; and the names SUMO knows our vehicles by.

On a built-in road an obstacle that reaches too far into a lane beside its own
for the traffic to pass stands there too, as a second vehicle; on a network
the world adds it once SUMO's vehicle types are known
(:mod:`scenarios.sumo.obstacles_beside`).
"""

from __future__ import annotations

import math
from collections.abc import Collection, Sequence
from dataclasses import dataclass

import numpy as np

from scenarios.scene import traffic_model
from scenarios.scene.road_geometry import EDGE_ID, RoadGeometry
from scenarios.scene.snapshot import obstacle_boxes
from scenarios.spec.bodies import OBSTACLE_SIZES_M, VEHICLE_MODELS
from scenarios.spec.scenario_spec import SPEED_FACTOR_BOUNDS, ScenarioSpec
from scenarios.spec.scenario_tables import ObstacleSpec

EGO_ID = "ego"
EGO_TYPE, OBSTACLE_TYPE_PREFIX = "ego", "obstacle_"  # our vTypes: not traffic
OBSTACLE_PREFIX = "obstacle."
TRAFFIC_PREFIX = "traffic."
EGO_ROUTE = "r0"


@dataclass(frozen=True)
class EgoNames:
    """The names SUMO knows one ego of a world by: the first ego's are :data:`EGO_ID`,
    :data:`EGO_TYPE`, :data:`EGO_ROUTE` and :data:`OBSTACLE_PREFIX`; the ego in slot
    ``k`` of a shared world has ``ego<k>``, ``ego<k>``, ``r0.<k>`` and
    ``obstacle<k>.`` (its type starts with :data:`EGO_TYPE`, so it is never read as a
    traffic type; no other slot's obstacle id starts with the first's prefix)."""

    ego_id: str
    ego_type: str
    route_id: str
    obstacle_prefix: str  # its obstacles' ids: <prefix><i>, and <prefix><i>.<lane> beside

    def stand_in_id(self, side: int) -> str:
        """The id of the body standing in for the ego in the lane on its ``side`` (-1
        right, +1 left): it starts with :attr:`obstacle_prefix`, so every read that
        leaves our bodies out of the traffic leaves it out too."""
        return f"{self.obstacle_prefix}ego.{'left' if side > 0 else 'right'}"


def ego_names(slot: int) -> EgoNames:
    """The names of the ego in ``slot`` of its world (0: the only ego of a run alone)."""
    if slot == 0:
        return EgoNames(EGO_ID, EGO_TYPE, EGO_ROUTE, OBSTACLE_PREFIX)
    return EgoNames(f"{EGO_ID}{slot}", f"{EGO_TYPE}{slot}", f"{EGO_ROUTE}.{slot}",
                    f"obstacle{slot}.")


FIRST = ego_names(0)
TRAFFIC_LENGTH_M, TRAFFIC_WIDTH_M = traffic_model.TRAFFIC_LENGTH_M, traffic_model.TRAFFIC_WIDTH_M


#: a warm state's flows run on past any run's end (the state must not know the run's
#: duration) [s]
WARM_FLOW_END_S = 1e7


def _flows(spec: ScenarioSpec, route: str, end_s: float, begin_s: float = 0.0) -> list[str]:
    """A flow per lane entering at the road's start, from ``begin_s`` until ``end_s``."""
    traffic = spec.traffic
    if traffic.flow_vph_per_lane == 0:
        return []
    return [
        f'  <flow id="{TRAFFIC_PREFIX}{lane}" type="traffic" route="{route}" begin="{begin_s!r}" '
        f'end="{end_s}" '
        f'vehsPerHour="{traffic.flow_vph_per_lane}" departLane="{lane}" departSpeed="desired"/>'
        for lane in range(spec.road.lane_count)
    ]


def _trips(trips: list[tuple[str, str]], depart_s: float = 0.0) -> list[str]:
    """The first random trips across the network, all leaving at ``depart_s``."""
    return [
        f'  <trip id="{TRAFFIC_PREFIX}{k}" type="traffic" depart="{depart_s!r}" from="{start}" '
        f'to="{end}" departLane="random" departPos="random_free" departSpeed="0"/>'
        for k, (start, end) in enumerate(trips)
    ]


def _traffic_type(spec: ScenarioSpec, flows: bool) -> str:
    """The traffic's vType (``flows``: its road source's flag, flows on a built road)."""
    traffic = spec.traffic
    factor = (traffic.speed_mean_mps / spec.road.speed_limit_mps
              if flows else 1.0)  # a network: its own limits
    lo, hi = SPEED_FACTOR_BOUNDS
    return (f'  <vType id="traffic" length="{TRAFFIC_LENGTH_M}" width="{TRAFFIC_WIDTH_M}" '
            f'speedFactor="normc({factor:.6f},{traffic.speed_dev * factor:.6f},{lo},{hi})"/>')


def _ego_type(spec: ScenarioSpec, names: EgoNames) -> str:
    """The ego's vType: its size, acceleration and braking, so followers keep gaps for
    the car it is."""
    model = VEHICLE_MODELS[spec.vehicle.model]
    decel = model.braking_decel_mps2(spec.vehicle.friction_mu)
    return (f'  <vType id="{names.ego_type}" length="{model.length_m}" '
            f'width="{model.width_m}" accel="{model.max_accel_mps2}" decel="{decel!r}" '
            f'emergencyDecel="{decel!r}"/>')


def _obstacle_types(egos: Egos) -> list[str]:
    """A type per obstacle kind, and one per size of its own an obstacle of ``egos``
    has (``ObstacleSpec.type_name``)."""
    sizes = {kind: size for kind, size in OBSTACLE_SIZES_M.items()}
    sizes |= {o.type_name: o.size_m for spec, _ in egos for o in spec.obstacles if o.sized}
    return [f'  <vType id="{OBSTACLE_TYPE_PREFIX}{name}" length="{length}" width="{width}"/>'
            for name, (length, width) in sizes.items()]


def _ego_route(spec: ScenarioSpec, road: RoadGeometry, names: EgoNames) -> str:
    ego_front_m = spec.ego.start_m + VEHICLE_MODELS[spec.vehicle.model].length_m / 2
    return (f'  <route id="{names.route_id}" '
            f'edges="{" ".join(road.route_edges(ego_front_m))}"/>')


def lanes_blocked(road: RoadGeometry, box: np.ndarray, lane: int,
                  traffic_width_m: float) -> list[int]:
    """The lanes beside ``lane`` (-1 on its right, +1 on its left) that a body standing
    at ``box`` reaches into too far for traffic ``traffic_width_m`` wide to pass
    (:func:`scenarios.scene.traffic_model.sides_blocked`), each lane as wide as it is there."""
    (s_m,), (d_m,) = road.to_frenet(box[None, :2])
    lo_m, hi_m = across_m(box, float(road.heading_at(s_m)), d_m)
    width_m, beside_m = road.lane_widths_m(s_m, lane)
    right, left = traffic_model.sides_blocked(lo_m, hi_m, road.lane_center_d_m(lane), width_m,
                                              traffic_width_m, beside_m)
    return [step for step, blocked in ((-1, right), (1, left)) if blocked]


def obstacle_lanes(road: RoadGeometry, box: np.ndarray) -> list[int]:
    """The lanes of a built-in road in which SUMO must see an obstacle standing at
    ``box``: the lane of its centre first, then each neighbouring lane it blocks
    (:func:`lanes_blocked`, for the built-in traffic)."""
    (_,), (d_m,) = road.to_frenet(box[None, :2])
    own = min(max(road.lane_at_d(d_m), 0), road.lanes - 1)
    return [own] + [own + step for step in lanes_blocked(road, box, own, TRAFFIC_WIDTH_M)]


def across_m(box: np.ndarray, heading_rad: float, d_m: float) -> tuple[float, float]:
    """How far across the road (lowest, highest ``d``) a box centred at ``d_m`` reaches,
    the road heading ``heading_rad`` there."""
    _, _, yaw_rad, length_m, width_m = box.tolist()
    psi = yaw_rad - heading_rad
    half_m = abs(length_m / 2 * math.sin(psi)) + abs(width_m / 2 * math.cos(psi))
    return d_m - half_m, d_m + half_m


def obstacle_spot(road: RoadGeometry, obstacle: ObstacleSpec, lane: int = 0
                  ) -> tuple[str, int, float]:
    """SUMO's edge, lane index and lane position of the front of ``obstacle`` standing
    in ``lane`` of ``road`` (SUMO places a vehicle by its front bumper)."""
    length_m = obstacle.size_m[0]
    return road.sumo_place(road.place_s_m(obstacle.position_m, length_m) + length_m / 2, lane)


def _obstacles(spec: ScenarioSpec, road: RoadGeometry, names: EgoNames, flows: bool,
               depart: str = "0", checks: str = "all") -> list[str]:
    """The obstacles as vehicles stopped for good where they stand, entering at
    ``depart`` with SUMO's insertion ``checks``. On a built-in road (``flows``) an obstacle that
    blocks a neighbouring lane stands there too, as a second vehicle
    (``obstacle.<i>.<lane>``)."""
    lines = []
    checked = "" if checks == "all" else f' insertionChecks="{checks}"'
    for i, (obstacle, box) in enumerate(zip(spec.obstacles, obstacle_boxes(spec, road),
                                            strict=True)):
        # on a network, a second body beside it waits for SUMO's types (obstacles_beside.py)
        lanes = obstacle_lanes(road, box) if flows else [obstacle.lane]
        for k, spec_lane in enumerate(lanes):
            edge, lane, front_m = obstacle_spot(road, obstacle, spec_lane)
            vid = (f"{names.obstacle_prefix}{i}" if k == 0
                   else f"{names.obstacle_prefix}{i}.{lane}")
            route = names.route_id if edge == EDGE_ID else vid
            if route != names.route_id:
                lines.append(f'  <route id="{route}" edges="{edge}"/>')
            lines += [
                f'  <vehicle id="{vid}" type="{OBSTACLE_TYPE_PREFIX}{obstacle.type_name}" '
                f'route="{route}" depart="{depart}" departLane="{lane}" '
                f'departPos="{front_m:.6f}" departSpeed="0"{checked}>',
                f'    <stop lane="{edge}_{lane}" endPos="{front_m:.6f}" duration="1e9"/>',
                "  </vehicle>",
            ]
    return lines


def _routes(lines: list[str]) -> str:
    return "\n".join(["<routes>", *lines, "</routes>"]) + "\n"


#: the egos of one world: each one's spec and road, the first's traffic the world's
Egos = Sequence[tuple[ScenarioSpec, RoadGeometry]]


def _egos_lines(egos: Egos, flows: bool, seated: Collection[int], depart: str = "0",
                checks: str = "all") -> list[str]:
    """Each ego's vType and route, the obstacles' types after the first ego's type, and
    the obstacles of the egos ``seated`` at the start (the others' enter with them)."""
    lines = []
    for slot, (spec, road) in enumerate(egos):
        names = ego_names(slot)
        lines += [_ego_type(spec, names), *(_obstacle_types(egos) if slot == 0 else []),
                  _ego_route(spec, road, names)]
        if slot in seated:
            lines += _obstacles(spec, road, names, flows, depart=depart, checks=checks)
    return lines


def routes_xml(egos: Egos, flows: bool, trips: list[tuple[str, str]] = (),
               seated: Collection[int] = (0,)) -> str:
    """The ``.rou.xml`` text of a world without a warm state: vehicle types, each ego's
    route, the obstacles of the egos ``seated`` at the start as stopped vehicles, and
    the background traffic of the first ego's spec (flows until the last run's end, or
    on a network the ``trips`` (from edge, to edge) leaving at 0 s). ``flows``: the
    world's road source's flag."""
    spec, _ = egos[0]
    end_s = spec.traffic.warm_up_s + max(s.scenario.duration_s for s, _ in egos)
    enter_s = spec.scenario.step_s  # after the egos, which enter in the first step
    return _routes([_traffic_type(spec, flows), *_egos_lines(egos, flows, seated),
                    *(_flows(spec, EGO_ROUTE, end_s, enter_s) if flows
                      else _trips(trips, enter_s))])


def warm_up_routes_xml(spec: ScenarioSpec, flows: bool,
                       trips: list[tuple[str, str]] = ()) -> str:
    """The ``.rou.xml`` text of a warm-up: the background traffic alone (``flows``:
    its road source's flag)."""
    if not flows:
        return _routes([_traffic_type(spec, flows), *_trips(trips)])
    return _routes([_traffic_type(spec, flows), f'  <route id="traffic" edges="{EDGE_ID}"/>',
                    *_flows(spec, "traffic", WARM_FLOW_END_S)])


def warm_run_routes_xml(egos: Egos, flows: bool, seated: Collection[int] = (0,)) -> str:
    """The ``.rou.xml`` text loaded beside a warm state: each ego's types and route,
    and the obstacles of the egos ``seated`` at the start entering as the run begins,
    wherever the traffic stands (the traffic on their spots is taken off first)."""
    return _routes(_egos_lines(egos, flows, seated, depart="begin", checks="none"))
