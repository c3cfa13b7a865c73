"""An OpenSCENARIO 1.x scenario (``.xosc``, revMajor 1, revMinor 0-3) read into a plain
description of the subset sdc runs: an ego placed on an OpenDRIVE road at a speed,
stationary bodies (vehicles, people, things) placed beside it, a duration, and a count
of background vehicles. Turning it into a ``ScenarioSpec`` on the road is the caller's.

Read with ``xml.etree.ElementTree`` rather than scenariogeneration's
``xosc.ParseOpenScenario``: that one prints to stdout, warns rather than raises, keeps
``$name`` references unresolved and drops what it does not know, where this reader
names every element it refuses.

What is read, and the choices made (each part in the module that reads it):

- Parameters (``xosc_parameters.py``): the top-level ``ParameterDeclarations``, typed
  by ``parameterType``, overridden by the ``parameters`` argument (names with or
  without ``$``; an undeclared name is an error), checked against their
  ``ConstraintGroup``s, and every ``$name`` attribute replaced by its value (nested
  declarations in scope); references in declarations and 1.2's ``${...}`` expressions
  are refused. ``XoscScenario.parameters`` holds the top-level values, resolved.
- The ego: the entity named by ``ego``, else the one of ``Ego``, ``ego``, ``hero``
  (exactly so spelled) the file has; it must be a ``Vehicle``. Its ``ObjectController``
  and any ``ActivateControllerAction`` / ``AssignControllerAction`` for it in Init
  are ignored: sdc drives the ego with its own controllers.
- Places and the ego's speed (``xosc_init.py``): ``Init``'s ``TeleportAction`` to a
  Lane, Road or World position, facing along the lane; the ego's ``SpeedAction``
  target (0 without one). Positions are of the entity's reference point (a vehicle's
  rear axle); ``center_m`` is its bounding box's centre from that point (x forward, y
  left, z up), for the caller to place the body's centre.
- Bodies: every other entity; it must be placed by a TeleportAction in Init and may
  have no other Init action but a SpeedAction to 0 (``xosc_init.py``). Its kind by
  its ``Vehicle``, ``Pedestrian`` or ``MiscObject`` category (``xosc_entities.py``:
  car, truck, bicycle, pedestrian, barrel or box; trains, trams, animals and flat
  things refused). Every body keeps its bounding box's size and its category as the
  file gives it. A body with an ``ObjectController`` is refused.
- ``CatalogReference`` entities (``xosc_catalogs.py``): resolved from the
  ``CatalogLocations`` ``VehicleCatalog``, ``PedestrianCatalog`` and
  ``MiscObjectCatalog`` directories by ``catalogName`` and ``entryName``, the
  reference's ``ParameterAssignments`` overriding the entry's own declarations.
- Duration, traffic and Stories (``xosc_storyboard.py``): the ``StopTrigger``'s
  ``SimulationTimeCondition``s (None without a StopTrigger); an Init
  ``TrafficSwarmAction`` centred on the ego gives ``traffic_vehicles`` (the count
  only); any ``Maneuver`` in a Story is refused, empty Stories are fine.
- The road: ``RoadNetwork/LogicFile`` ``filepath``, relative to the scenario's
  folder, must name a file; a ``TrafficSignals`` controller is refused.

Anything else is refused with a :class:`SpecError` whose field is the element's path
(``Storyboard/Story[name=s]/Act[name=a]/ManeuverGroup[name=g]/Maneuver[name=m]``,
``xosc_document.py``) and whose file is the file it is in. A file that is not
OpenSCENARIO 1.0 to 1.3 (``xosc_file.py``), a catalog or no scenario is refused, and
a ``ParameterValueDistribution`` file with a pointer to ``sdc sweep``.
"""

from __future__ import annotations

import dataclasses
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from pathlib import Path
from types import MappingProxyType

from scenarios.asam.xosc_catalogs import ENTITY_CATALOGS, Catalogs
from scenarios.asam.xosc_document import REV_MINORS, Doc, attr_text, parse, version
from scenarios.asam.xosc_entities import (
    BARREL_MAX_M,
    MISC_SOLID,
    PEDESTRIAN_KINDS,
    VEHICLE_KINDS,
    bounding_box,
    kind_of,
)
from scenarios.asam.xosc_file import REV_MAJOR
from scenarios.asam.xosc_init import LanePlace, Place, RoadPlace, WorldPlace, read_init
from scenarios.asam.xosc_parameters import (
    ParameterValue,
    check_constraints,
    declared_parameters,
    override,
    substitute,
)
from scenarios.asam.xosc_storyboard import (
    check_stories,
    duration,
    environment,
    swarm_vehicles,
)
from scenarios.common.errors import FileError, SpecError
from scenarios.common.file_read import check_file

__all__ = ["BARREL_MAX_M", "EGO_NAMES", "ENTITY_CATALOGS", "MISC_SOLID", "PEDESTRIAN_KINDS",
           "REV_MAJOR", "REV_MINORS", "VEHICLE_KINDS", "WHAT", "Body", "LanePlace",
           "ParameterValue", "Place", "RoadPlace", "WorldPlace", "XoscScenario",
           "read_scenario"]

#: the names an ego goes by when the caller names none (exactly so spelled)
EGO_NAMES = ("Ego", "ego", "hero")
WHAT = "the OpenSCENARIO file"


@dataclasses.dataclass(frozen=True)
class Body:
    """An entity other than the ego, standing still."""

    name: str
    kind: str  # "car" | "truck" | "bicycle" | "pedestrian" | "barrel" | "box"
    category: str  # the file's vehicleCategory, pedestrianCategory or miscObjectCategory
    size_m: tuple[float, float, float]  # length, width, height of its BoundingBox
    center_m: tuple[float, float, float]  # its BoundingBox's centre from its reference point
    place: Place


@dataclasses.dataclass(frozen=True)
class XoscScenario:
    path: Path  # absolute
    rev_minor: int  # OpenSCENARIO 1.<rev_minor>
    xodr_file: Path  # absolute
    ego_name: str
    ego_kind: str  # its vehicleCategory's kind, as a body's ("car", "truck", ...)
    ego_place: Place
    ego_speed_mps: float
    ego_size_m: tuple[float, float, float]
    ego_center_m: tuple[float, float, float]
    bodies: tuple[Body, ...]
    duration_s: float | None
    traffic_vehicles: int
    parameters: dict[str, ParameterValue]  # the top-level parameters, resolved
    #: an EnvironmentAction's RoadCondition frictionScaleFactor (1 without one)
    friction_scale: float = 1.0
    #: what the file says that sdc reads but does not model, in sentences
    notes: tuple[str, ...] = ()


def read_scenario(path: str | Path,
                  parameters: Mapping[str, ParameterValue] = MappingProxyType({}),
                  ego: str | None = None) -> XoscScenario:
    """The scenario in the OpenSCENARIO file at ``path``, its parameters overridden by
    ``parameters`` (names with or without ``$``), its ego the entity named ``ego``
    (default: the one named Ego, ego or hero). Anything outside the subset sdc runs is
    a :class:`SpecError` naming the element and the file (the module's docstring)."""
    path = Path(path)
    doc = parse(path, WHAT)
    if doc.root.find("ParameterValueDistribution") is not None:
        raise doc.error(doc.root.find("ParameterValueDistribution"),
                        "a ParameterValueDistribution file is a sweep over a scenario: run it "
                        "with `sdc sweep`")
    if doc.root.find("Storyboard") is None:
        what = "a Catalog" if doc.root.find("Catalog") is not None else "no scenario"
        raise doc.error(doc.root, f"the file is {what}, not a scenario (no Storyboard)")
    rev_minor = version(doc)

    declared = declared_parameters(doc, doc.root.find("ParameterDeclarations"))
    override(doc, declared, parameters, lambda given: f"parameters[{given}]", "the file")
    check_constraints(doc, declared)
    values = {name: d.value for name, d in declared.items()}
    substitute(doc, doc.root, values)

    xodr_file = _road_file(doc)
    objects: dict[str, ET.Element] = {}
    entities = doc.root.find("Entities")
    for obj in [] if entities is None else entities:
        if obj.tag != "ScenarioObject":
            raise doc.outside(obj, "entities are ScenarioObjects")
        name = attr_text(doc, obj, "name")
        if name in objects:
            raise doc.error(obj, f"two entities are named {name}")
        objects[name] = obj
    ego_name = _ego_name(doc, objects, ego, entities)

    storyboard = doc.root.find("Storyboard")
    check_stories(doc, storyboard)
    privates: dict[str, list[ET.Element]] = {name: [] for name in objects}
    global_actions = []
    for action in storyboard.findall("Init/Actions/*"):
        if action.tag == "Private":
            ref = attr_text(doc, action, "entityRef")
            if ref not in privates:
                raise doc.error(action, f"entityRef {ref} names no entity (entities: "
                                        f"{', '.join(objects)})", "entityRef")
            privates[ref].append(action)
        elif action.tag == "GlobalAction":
            global_actions.append(action)
        else:
            raise doc.outside(action, "Init's actions are Private ones and a TrafficSwarmAction")

    catalogs = Catalogs(doc)
    ego_kind = ego_size = ego_center = None
    ego_init = None
    bodies = []
    for name, obj in sorted(objects.items(), key=lambda item: item[0] != ego_name):
        is_ego = name == ego_name  # the ego first: it is refused before its bodies
        entity = next((child for child in obj if child.tag != "ObjectController"), None)
        if entity is None:
            raise doc.error(obj, f"ScenarioObject {name} has no entity")
        if obj.find("ObjectController") is not None and not is_ego:
            raise doc.outside(obj.find("ObjectController"), f"a controller for {name}, a body "
                                                            f"standing still")
        edoc = doc
        if entity.tag == "CatalogReference":
            edoc, entity = catalogs.entry(entity)
        kind, category = kind_of(edoc, entity)
        size, center = bounding_box(edoc, entity)
        init = read_init(doc, name, privates[name], is_ego, obj)
        if is_ego:
            if entity.tag != "Vehicle":
                raise edoc.error(entity, f"the ego {name} is a {entity.tag}: sdc's ego is a "
                                         f"Vehicle")
            ego_kind, ego_size, ego_center, ego_init = kind, size, center, init
        else:
            bodies.append(Body(name, kind, category, size, center, init.place))

    friction_scale, notes = environment(doc, global_actions)
    return XoscScenario(
        path=path.absolute(), rev_minor=rev_minor, xodr_file=xodr_file, ego_name=ego_name,
        ego_kind=ego_kind, ego_place=ego_init.place, ego_speed_mps=ego_init.speed_mps or 0.0,
        ego_size_m=ego_size, ego_center_m=ego_center, bodies=tuple(bodies),
        duration_s=duration(doc, storyboard),
        traffic_vehicles=swarm_vehicles(doc, global_actions, ego_name), parameters=values,
        friction_scale=friction_scale, notes=notes)


def _ego_name(doc: Doc, objects: dict[str, ET.Element], ego: str | None,
              entities: ET.Element | None) -> str:
    listed = ", ".join(objects) or "none"
    where = entities if entities is not None else doc.root
    if ego is not None:
        if ego not in objects:
            raise SpecError("ego", f"the file has no entity {ego} (its entities: {listed})",
                            doc.path)
        return ego
    named = [name for name in EGO_NAMES if name in objects]
    if not named:
        raise doc.error(where, f"no entity is named {', '.join(EGO_NAMES)}: name the ego "
                               f"(its entities: {listed})")
    if len(named) > 1:
        raise doc.error(where, f"entities {' and '.join(named)} could each be the ego: "
                               f"name the ego")
    return named[0]


def _road_file(doc: Doc) -> Path:
    network = doc.root.find("RoadNetwork")
    logic = None if network is None else network.find("LogicFile")
    if logic is None:
        raise doc.error(network if network is not None else doc.root,
                        "no RoadNetwork/LogicFile: sdc runs a scenario on its OpenDRIVE road")
    signals = network.find("TrafficSignals")
    if signals is not None and len(signals):
        raise doc.outside(signals[0], "traffic signal controllers")
    path = doc.path.parent / attr_text(doc, logic, "filepath")
    try:
        check_file(path, "the OpenDRIVE road")
    except FileError as e:
        raise doc.error(logic, e.message, "filepath") from None
    return path.absolute()
