"""An OpenSCENARIO scenario (``scenarios/asam/xosc_scenario.py``) as an sdc scenario:
an ``opendrive`` road on its ``LogicFile``, the ego's route pinned from the lane the
file places it in, its bodies standing along that route.

- **The route** starts on the SUMO lane the ego's position maps to
  (``scenarios/asam/xodr_places.py``: lane ids by name, so OpenDRIVE's -1 is the lane
  next to the reference line whatever SUMO's index) and goes straight on, junction
  after junction, for as long as a lane goes straight on (or is the only way on);
  ``road.route_edges`` and ``road.route_lane`` hold it, ``road.length_m`` is its length.
- **The ego's and each body's centre** is its reference point (a vehicle's rear
  axle, where OpenSCENARIO places it) moved by its bounding box's centre, along and
  across its lane; a body's place on the route is that centre's station and offset
  from the ego's lane's centre (``position_m``, ``lateral_offset_m``).
- **What sdc cannot hold is refused or said, never approximated in silence**: a
  body off the ego's route and a run with no ``SimulationTimeCondition`` to end it
  are refused, naming the entity or element and the file. A ``MiscObject`` is a
  standing thing (obstacle kind ``barrel``, not a road user) of its bounding box's
  size, whatever its size. The bodies keep the file's sizes (an obstacle's
  ``length_m`` and ``width_m``); the ego is sdc's car (its model's size), starting on
  its lane's centre, along its lane: where the file's ego differs (by more than
  :data:`SIZE_NOTE_M`, :data:`OFF_CENTRE_NOTE_M` or :data:`TURN_NOTE_DEG`) that is one
  of the :attr:`XoscSpec.notes` a command prints.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from pathlib import Path
from types import MappingProxyType

from scenarios.asam.xodr_places import MapPlace, XodrMap
from scenarios.asam.xosc_scenario import (
    LanePlace,
    Place,
    RoadPlace,
    XoscScenario,
    read_scenario,
)
from scenarios.common.errors import SpecError
from scenarios.spec.bodies import OBSTACLE_SIZES_M, VEHICLE_MODELS
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.spec.scenario_tables import VehicleSpec
from scenarios.sumo_net.net_xml import STRAIGHT, NetFile, NetLane
from scenarios.sumo_net.road_source import road_source
from scenarios.sumo_net.route_drawing import drivable_turns, pinned_route

#: the ego's size off sdc's car's by more than this is said in the notes [m]
SIZE_NOTE_M = 0.25
#: the ego's centre off its lane's centre by more than this is said in the notes [m]
OFF_CENTRE_NOTE_M = 0.05
#: the ego turned from its lane by more than this is said in the notes [degrees]
TURN_NOTE_DEG = 3.0
#: the obstacle kind of a thing standing on the road (not a road user), which a
#: MiscObject bigger than a barrel is too, of its own size
THING = "barrel"
#: the route goes on no farther than this [m]
ROUTE_MAX_M = 20_000.0
#: a body's centre farther than this from the ego's lane's centre is off its route [m]
OFF_ROUTE_M = 12.0


@dataclasses.dataclass(frozen=True)
class XoscSpec:
    """The spec, the scenario it was read from, and what sdc holds differently from
    the file (the ego's size, place across its lane, heading), in sentences."""

    spec: ScenarioSpec
    scenario: XoscScenario
    notes: tuple[str, ...]


def _placed(world: XodrMap, place: Place, where: str, facing: bool = True) -> MapPlace:
    """Where ``place`` is on the map; ``facing``: on a lane whose traffic goes the way
    the place faces (the ego's; a standing body's lane may face either way)."""
    if isinstance(place, LanePlace):
        return world.lane_place(place.road_id, place.lane_id, place.s_m, place.offset_m, where)
    if isinstance(place, RoadPlace):
        return world.road_place(place.road_id, place.s_m, place.t_m, where, facing)
    return world.world_place(place.x_m, place.y_m, place.heading_rad if facing else None,
                             where)


def _straight_on(net: NetFile, lane: NetLane, min_radius_m: float) -> tuple[str, ...]:
    """The edges from ``lane``'s on: straight on at each junction (or the one way on)."""
    edges, length_m, seen = [lane.edge], lane.length_m, {lane.edge}
    while length_m < ROUTE_MAX_M:
        turns = drivable_turns(net, lane, min_radius_m)
        ahead = [t for t in turns if t.direction == STRAIGHT] or (turns if len(turns) == 1
                                                                  else [])
        if not ahead or net.lanes[ahead[0].to].edge in seen:
            break
        lane = net.lanes[ahead[0].to]
        edges.append(lane.edge)
        seen.add(lane.edge)
        length_m += lane.length_m
    return tuple(edges)


def xosc_spec(path: str | Path, parameters: Mapping[str, object] = MappingProxyType({}),
              ego: str | None = None, *, controller: str | None = None, seed: int = 1,
              cache_dir: Path | None = None,
              maps: dict[Path, XodrMap] | None = None) -> XoscSpec:
    """The sdc scenario of the OpenSCENARIO file ``path`` (its parameters overridden by
    ``parameters``, its ego the entity ``ego``), run by ``controller`` (default: the
    spec's) from ``seed``; ``maps`` keeps each road's map between calls. Every refusal
    is a :class:`SpecError` naming the file."""
    path = Path(path)
    try:
        scenario = read_scenario(path, parameters, ego)
        maps = {} if maps is None else maps
        if scenario.xodr_file not in maps:
            maps[scenario.xodr_file] = XodrMap(scenario.xodr_file, cache_dir)
        return _spec(scenario, maps[scenario.xodr_file], controller, seed, cache_dir)
    except SpecError as e:
        raise e.in_file(path) from None


def _spec(scenario: XoscScenario, world: XodrMap, controller: str | None, seed: int,
          cache_dir: Path | None) -> XoscSpec:
    if scenario.duration_s is None:
        raise SpecError("Storyboard/StopTrigger", "no SimulationTimeCondition ends the run: "
                        "sdc runs a scenario for a duration")
    model = VEHICLE_MODELS[VehicleSpec().model]
    start = _placed(world, scenario.ego_place, f"Init/Private[{scenario.ego_name}]")
    edges = _straight_on(world.net, start.lane, model.min_turn_radius_m)
    route = pinned_route(world.net, edges, model.min_turn_radius_m, start.lane.index)
    start_m = start.pos_m + scenario.ego_center_m[0]
    plain = {
        "scenario": {"name": Path(scenario.path).stem, "duration_s": scenario.duration_s,
                     "seed": seed},
        "road": {"kind": "opendrive", "xodr_file": str(scenario.xodr_file),
                 "route_edges": list(edges), "route_lane": start.lane.index,
                 "length_m": math.floor(sum(lane.length_m for lane in route) * 10) / 10},
        "traffic": {"vehicles": scenario.traffic_vehicles},
        "ego": {"lane": 0, "start_m": start_m, "speed_mps": scenario.ego_speed_mps},
        "vehicle": {"friction_mu": VehicleSpec().friction_mu * scenario.friction_scale},
    }
    if controller is not None:
        plain["controller"] = {"name": controller}
    probe = ScenarioSpec.from_plain(_minimal() | {"road": plain["road"]})
    geometry = road_source(probe.road).geometry(probe, cache_dir)
    obstacles = []
    for body in scenario.bodies:
        where = f"Entities/ScenarioObject[{body.name}]"
        place = _placed(world, body.place, f"Init/Private[{body.name}]", facing=False)
        x_m, y_m = _centre(world, place, body.center_m, _heading(world, body.place, place))
        (s_m,), (d_m,) = geometry.to_frenet([[x_m, y_m]])
        if not 0.0 <= s_m <= geometry.length_m or abs(d_m) > OFF_ROUTE_M:
            raise SpecError(where, f"stands {s_m:.1f} m along and {d_m:.1f} m beside the ego's "
                            "route: sdc places bodies along the ego's route")
        kind = THING if body.kind == "box" else body.kind
        obstacle = {"kind": kind, "lane": 0, "position_m": float(s_m),
                    "lateral_offset_m": float(d_m)}
        if tuple(body.size_m[:2]) != OBSTACLE_SIZES_M[kind]:
            obstacle |= {"length_m": body.size_m[0], "width_m": body.size_m[1]}
        obstacles.append(obstacle)
    plain["obstacles"] = obstacles
    return XoscSpec(ScenarioSpec.from_plain(plain), scenario,
                    (*scenario.notes, *_ego_notes(scenario, world, start, model)))


def _ego_notes(scenario: XoscScenario, world: XodrMap, start: MapPlace, model) -> list[str]:
    """What sdc's ego holds differently from the file's: its size, its place across
    its lane (it starts on the lane's centre) and its heading (along its lane)."""
    notes, name = [], scenario.ego_name
    length_m, width_m = scenario.ego_size_m[:2]
    if max(abs(length_m - model.length_m), abs(width_m - model.width_m)) > SIZE_NOTE_M:
        notes.append(f"{name}: {length_m:g} x {width_m:g} m in the file, sdc's car is "
                     f"{model.length_m:g} x {model.width_m:g} m")
    off_m = start.lateral_m + scenario.ego_center_m[1]
    if abs(off_m) > OFF_CENTRE_NOTE_M:
        notes.append(f"{name}: its centre {off_m:+.2f} m from its lane's centre in the file "
                     "(+ left); sdc's ego starts on the lane's centre")
    turned = _heading(world, scenario.ego_place, start) - start.heading_rad
    turned = math.degrees(math.atan2(math.sin(turned), math.cos(turned)))
    if abs(turned) > TURN_NOTE_DEG:
        notes.append(f"{name}: turned {turned:+.1f} degrees from its lane in the file; sdc's "
                     "ego starts along its lane")
    return notes


def _heading(world: XodrMap, place: Place, found: MapPlace) -> float:
    """The way a body placed at ``place`` (found on the map at ``found``) faces: its
    lane's traffic's (a LanePosition), its road's reference line's (a RoadPosition),
    its own ``h`` (a WorldPosition)."""
    if isinstance(place, LanePlace):
        return found.heading_rad
    if isinstance(place, RoadPlace):
        return world.roads[place.road_id].point(place.s_m, place.t_m)[2]
    return place.heading_rad


def _centre(world: XodrMap, place: MapPlace, center_m, heading: float) -> tuple[float, float]:
    """A body's centre: its reference point ``place`` moved ``center_m`` (forward, left)
    as it faces (``heading``)."""
    x_m, y_m = world.lane_frame(place.lane).point(place.pos_m, place.lateral_m)
    return (x_m + center_m[0] * math.cos(heading) - center_m[1] * math.sin(heading),
            y_m + center_m[0] * math.sin(heading) + center_m[1] * math.cos(heading))


def _minimal() -> dict:
    """The least a spec is: what :func:`_spec` asks of the defaults and the route."""
    return {"scenario": {"name": "probe", "duration_s": 1.0},
            "ego": {"lane": 0, "start_m": 5.0, "speed_mps": 0.0}}
