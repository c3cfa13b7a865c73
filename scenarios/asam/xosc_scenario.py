"""An OpenSCENARIO 1.x scenario (``.xosc``, revMajor 1, revMinor 0-3) read into a plain
description of the subset sdc runs: an ego placed on an OpenDRIVE road at a speed,
stationary bodies (vehicles, people, things) placed beside it, a duration, and a count
of background vehicles. Turning it into a ``ScenarioSpec`` on the road is the caller's.

Read with ``xml.etree.ElementTree`` rather than scenariogeneration's
``xosc.ParseOpenScenario``: that one prints to stdout, warns rather than raises, keeps
``$name`` references unresolved and drops what it does not know, where this reader
names every element it refuses.

What is read, and the choices made:

- Parameters: the top-level ``ParameterDeclarations``, typed by ``parameterType``
  (``integer``/``int``/``unsignedInt``/``unsignedShort`` an int, ``double`` a finite
  float, ``boolean`` a bool, ``string``/``dateTime`` a str), overridden by the
  ``parameters`` argument (names with or without ``$``; an undeclared name is an
  error). A Python number given for a string parameter becomes its ``str``. A value
  must satisfy its declaration's ``ConstraintGroup``s (1.1+: any group whose every
  ``ValueConstraint`` holds). Every attribute that is a ``$name`` (but ``parameterRef``
  and ``variableRef``, which name one) is replaced by its value, with the nested
  declarations of a Story, Maneuver or catalog entry in scope inside it; the
  FileHeader's free text is left alone. A declaration whose value is itself a
  reference, and 1.2's ``${...}`` expressions, are refused.
- The ego: the entity named by ``ego``, else the one of ``Ego``, ``ego``, ``hero``
  (exactly so spelled) the file has; it must be a ``Vehicle``. Its ``ObjectController``
  and any ``ActivateControllerAction`` / ``AssignControllerAction`` for it in Init
  are ignored: sdc drives the ego with its own controllers.
- Places: ``Init``'s ``TeleportAction`` to a ``LanePosition`` (``offset`` 0 when
  absent; lane 0 refused), ``RoadPosition`` or ``WorldPosition`` (``h`` 0 when
  absent; ``z`` ignored, sdc puts bodies on its road; a non-zero ``p``/``r`` refused).
  A Lane/RoadPosition's ``Orientation`` is accepted only when it turns nothing (every
  angle 0, type relative or absent): bodies face along their lane. Positions are of
  the entity's reference point (a vehicle's rear axle); ``center_m`` is its bounding
  box's centre from that point (x forward, y left, z up), for the caller to place the
  body's centre.
- The ego's speed: ``LongitudinalAction/SpeedAction`` with an ``AbsoluteTargetSpeed``
  in Init; its ``SpeedActionDynamics`` is ignored (the ego starts at the target).
  No SpeedAction: 0, OpenSCENARIO's own initial speed (an entity starts at rest).
- Bodies: every other entity; it must be placed by a TeleportAction in Init and may
  have no other Init action but a SpeedAction to 0. ``Vehicle`` by
  ``vehicleCategory``: car and van a ``"car"``; truck, bus, semitrailer and trailer a
  ``"truck"``; bicycle and motorbike (a stopped two-wheeler) a ``"bicycle"``; train and
  tram refused. ``Pedestrian``: pedestrian and wheelchair a ``"pedestrian"`` (a
  standing person), animal refused. ``MiscObject``: a ``"barrel"`` when its bounding
  box is at most :data:`BARREL_MAX_M` long and wide, else a ``"box"`` (sdc has no such
  obstacle kind yet: the caller decides); flat categories (parkingSpace, patch,
  crosswalk, roadMark) refused. Every body keeps its bounding box's size and its
  category as the file gives it. A body with an ``ObjectController`` is refused.
- ``CatalogReference`` entities: resolved from the ``*.xosc`` files of the
  ``CatalogLocations`` ``VehicleCatalog``, ``PedestrianCatalog`` and
  ``MiscObjectCatalog`` directories (relative to the scenario's folder) by
  ``catalogName`` and ``entryName``, the reference's ``ParameterAssignments``
  overriding the entry's own declarations. A directory that does not exist is
  skipped; a catalog found in none is an error naming it and the directories.
- Duration: the ``Storyboard/StopTrigger``'s ``SimulationTimeCondition``s (rule
  ``greaterThan`` or ``greaterOrEqual``, edge rising, risingOrFalling or none) plus
  their delay: the latest of a group's (all must hold), the earliest group (any
  stops). No StopTrigger: None.
- Traffic: an Init ``TrafficSwarmAction`` centred on the ego gives
  ``traffic_vehicles`` (its ``numberOfVehicles``; 0 with none). Only the count is
  kept: sdc's traffic is that many random trips over the whole network at its speed
  limits, not a swarm in an ellipse around the ego.
- Stories: any ``Maneuver`` (or catalogued one) in a Story is refused; empty Stories,
  Acts and ManeuverGroups (as scenariogeneration writes for 1.0) are fine.
- The road: ``RoadNetwork/LogicFile`` ``filepath``, relative to the scenario's
  folder, must name a file; a ``TrafficSignals`` controller is refused.

Anything else is refused with a :class:`SpecError` whose field is the element's path
(``Storyboard/Story[name=s]/Act[name=a]/ManeuverGroup[name=g]/Maneuver[name=m]``) and
whose file is the file it is in. A ``ParameterValueDistribution`` file is refused
with a pointer to ``sdc sweep``.
"""

from __future__ import annotations

import dataclasses
import math
import re
import xml.etree.ElementTree as ET
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from types import MappingProxyType

from scenarios.common.errors import FileError, SpecError
from scenarios.common.file_read import check_file, read_bytes

ParameterValue = bool | int | float | str

#: the names an ego goes by when the caller names none (exactly so spelled)
EGO_NAMES = ("Ego", "ego", "hero")
#: the OpenSCENARIO versions read: 1.0 to 1.3
REV_MAJOR = 1
REV_MINORS = (0, 1, 2, 3)
#: vehicleCategory -> sdc's obstacle kind (train and tram are refused)
VEHICLE_KINDS = {"car": "car", "van": "car", "truck": "truck", "bus": "truck",
                 "semitrailer": "truck", "trailer": "truck", "bicycle": "bicycle",
                 "motorbike": "bicycle"}
#: pedestrianCategory -> kind (animal is refused)
PEDESTRIAN_KINDS = {"pedestrian": "pedestrian", "wheelchair": "pedestrian"}
#: the miscObjectCategory values of things that stand on the road (the flat ones,
#: parkingSpace, patch, crosswalk and roadMark, are refused)
MISC_SOLID = ("none", "obstacle", "pole", "tree", "vegetation", "barrier", "building",
              "railing", "trafficIsland", "streetLamp", "gantry", "soundBarrier", "wind")
#: a MiscObject at most this long and wide [m] is a "barrel" (sdc's is 0.6 m), else a "box"
BARREL_MAX_M = 1.0
#: the catalogs entities are looked up in
ENTITY_CATALOGS = ("VehicleCatalog", "PedestrianCatalog", "MiscObjectCatalog")

_INT_TYPES = {"integer": None, "int": None, "unsignedInt": 2**32, "unsignedShort": 2**16}
_TYPES = (*_INT_TYPES, "double", "boolean", "string", "dateTime")
_NUMBER = re.compile(r"[+-]?(\d+(\.\d*)?|\.\d+)([eE][+-]?\d+)?")
_INTEGER = re.compile(r"[+-]?\d+")
_NAME_ATTRIBUTES = ("parameterRef", "variableRef")  # they name a parameter, not use one
_RULES: dict[str, Callable[[object, object], bool]] = {
    "equalTo": lambda a, b: a == b, "notEqualTo": lambda a, b: a != b,
    "greaterThan": lambda a, b: a > b, "lessThan": lambda a, b: a < b,
    "greaterOrEqual": lambda a, b: a >= b, "lessOrEqual": lambda a, b: a <= b,
}
_STOP_RULES = ("greaterThan", "greaterOrEqual")
_STOP_EDGES = ("rising", "risingOrFalling", "none")
_REQUIRED = object()
WHAT = "the OpenSCENARIO file"


@dataclasses.dataclass(frozen=True)
class LanePlace:
    """A ``LanePosition``: OpenDRIVE road and lane (negative: right of the reference
    line), ``s`` along the road and ``offset`` from the lane's centre (left positive)."""

    road_id: str
    lane_id: int
    s_m: float
    offset_m: float


@dataclasses.dataclass(frozen=True)
class RoadPlace:
    """A ``RoadPosition``: ``s`` along the road's reference line, ``t`` left of it."""

    road_id: str
    s_m: float
    t_m: float


@dataclasses.dataclass(frozen=True)
class WorldPlace:
    """A ``WorldPosition``: OpenDRIVE's inertial x, y and heading (counter-clockwise from
    x); its z is not kept."""

    x_m: float
    y_m: float
    heading_rad: float


Place = LanePlace | RoadPlace | WorldPlace


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


class _Doc:
    """One parsed file: names its elements by path, and refuses them."""

    def __init__(self, path: Path, root: ET.Element):
        self.path = path
        self.root = root
        self.parents = {child: parent for parent in root.iter() for child in parent}

    def where(self, element: ET.Element) -> str:
        steps = []
        while element is not self.root:
            parent = self.parents[element]
            steps.append(_step(element, parent))
            element = parent
        return "/".join(reversed(steps)) or self.root.tag

    def error(self, element: ET.Element, message: str, attribute: str | None = None
              ) -> SpecError:
        where = self.where(element) + (f"@{attribute}" if attribute else "")
        return SpecError(where, message, self.path)

    def outside(self, element: ET.Element, what: str = "") -> SpecError:
        return self.error(element, f"{element.tag} is outside the subset sdc runs"
                                   + (f" ({what})" if what else ""))


def _step(element: ET.Element, parent: ET.Element) -> str:
    for key in ("name", "entityRef"):
        if element.get(key) is not None:
            return f"{element.tag}[{key}={element.get(key)}]"
    same = [child for child in parent if child.tag == element.tag]
    if len(same) > 1:
        return f"{element.tag}[{same.index(element) + 1}]"
    return element.tag


def _parse(path: Path, what: str) -> _Doc:
    data = read_bytes(path, what)
    try:
        root = ET.fromstring(data)
    except ET.ParseError as e:
        raise FileError(path, f"{what} is not XML ({e})") from None
    if root.tag != "OpenSCENARIO":
        raise FileError(path, f"{what} is not OpenSCENARIO (its root element is "
                              f"{root.tag}, not OpenSCENARIO)")
    return _Doc(path, root)


def _check_version(doc: _Doc) -> int:
    header = doc.root.find("FileHeader")
    if header is None:
        raise doc.error(doc.root, "OpenSCENARIO has no FileHeader")
    major, minor = header.get("revMajor", ""), header.get("revMinor", "")
    if not (_INTEGER.fullmatch(major) and _INTEGER.fullmatch(minor)) or int(major) != REV_MAJOR \
            or int(minor) not in REV_MINORS:
        raise doc.error(header, f"OpenSCENARIO {major}.{minor} is not read: only "
                                f"{REV_MAJOR}.{REV_MINORS[0]} to {REV_MAJOR}.{REV_MINORS[-1]}")
    return int(minor)


# ---------------------------------------------------------------- attributes


def _text(doc: _Doc, element: ET.Element, name: str, default=_REQUIRED):
    text = element.get(name)
    if text is None:
        if default is _REQUIRED:
            raise doc.error(element, f"{element.tag} has no {name}")
        return default
    return text


def _float(doc: _Doc, element: ET.Element, name: str, default=_REQUIRED) -> float:
    text = _text(doc, element, name, None if default is not _REQUIRED else _REQUIRED)
    if text is None:
        return default
    if not _NUMBER.fullmatch(text.strip()):
        raise doc.error(element, f"{element.tag}'s {name} is {text!r}, not a number", name)
    return float(text)


def _int(doc: _Doc, element: ET.Element, name: str) -> int:
    value = _float(doc, element, name)
    if not value.is_integer():
        raise doc.error(element, f"{element.tag}'s {name} is {element.get(name)!r}, not a "
                                 f"whole number", name)
    return int(value)


# ---------------------------------------------------------------- parameters


def _typed(text: str, kind: str) -> ParameterValue | None:
    """``text`` as a value of parameterType ``kind`` (None: not one)."""
    if kind in _INT_TYPES:
        if not _INTEGER.fullmatch(text.strip()):
            return None
        value = int(text)
        bound = _INT_TYPES[kind]
        return value if bound is None or 0 <= value < bound else None
    if kind == "double":
        return float(text) if _NUMBER.fullmatch(text.strip()) else None
    if kind == "boolean":
        return {"true": True, "1": True, "false": False, "0": False}.get(text.strip())
    return text


def _given(value: object, kind: str) -> ParameterValue | None:
    """A caller's override ``value`` as parameterType ``kind`` (None: not one)."""
    if isinstance(value, str):
        return _typed(value, kind)
    if isinstance(value, bool):
        return value if kind == "boolean" else None
    if isinstance(value, int | float) and math.isfinite(value):
        if kind in _INT_TYPES:
            return _typed(str(int(value)), kind) if float(value).is_integer() else None
        if kind == "double":
            return float(value)
        if kind in ("string", "dateTime"):
            return str(value)
    return None


def _as_text(value: ParameterValue) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(value) if isinstance(value, float) else str(value)


@dataclasses.dataclass
class _Declared:
    element: ET.Element
    kind: str
    value: ParameterValue


def _declarations(doc: _Doc, declarations: ET.Element | None) -> dict[str, _Declared]:
    found: dict[str, _Declared] = {}
    for declaration in [] if declarations is None else declarations:
        if declaration.tag != "ParameterDeclaration":
            raise doc.outside(declaration)
        name = _text(doc, declaration, "name")
        kind = _text(doc, declaration, "parameterType")
        text = _text(doc, declaration, "value")
        if name in found:
            raise doc.error(declaration, f"parameter {name} is declared twice")
        if kind not in _TYPES:
            raise doc.error(declaration, f"parameterType {kind!r} is not one of "
                                         f"{', '.join(_TYPES)}", "parameterType")
        if text.startswith("$"):
            raise doc.error(declaration, f"a ParameterDeclaration's value given as {text!r} "
                                         f"(a reference or expression) is outside the subset "
                                         f"sdc runs", "value")
        value = _typed(text, kind)
        if value is None or isinstance(value, float) and not math.isfinite(value):
            raise doc.error(declaration, f"value {text!r} is not of parameterType {kind}",
                            "value")
        found[name] = _Declared(declaration, kind, value)
    return found


def _override(doc: _Doc, declared: dict[str, _Declared], parameters: Mapping[str, object],
              field: Callable[[str], str], owner: str) -> None:
    seen: dict[str, str] = {}
    for given, value in parameters.items():
        name = given[1:] if given.startswith("$") else given
        if name in seen:
            raise SpecError(field(given), f"parameter {name} is given twice (as {seen[name]} "
                                          f"and {given})", doc.path)
        seen[name] = given
        if name not in declared:
            names = ", ".join(declared) or "none"
            raise SpecError(field(given), f"{owner} declares no parameter {name} (it "
                                          f"declares: {names})", doc.path)
        typed = _given(value, declared[name].kind)
        if typed is None or isinstance(typed, float) and not math.isfinite(typed):
            raise SpecError(field(given), f"{value!r} is not of parameterType "
                                          f"{declared[name].kind}, parameter {name}'s",
                            doc.path)
        declared[name].value = typed


def _check_constraints(doc: _Doc, declared: dict[str, _Declared]) -> None:
    for name, parameter in declared.items():
        groups = parameter.element.findall("ConstraintGroup")
        if not groups:
            continue
        passed = False
        for group in groups:
            holds = True
            for constraint in group:
                rule = _text(doc, constraint, "rule")
                bound = _typed(_text(doc, constraint, "value"), parameter.kind)
                numeric = parameter.kind in _INT_TYPES or parameter.kind == "double"
                if constraint.tag != "ValueConstraint" or rule not in _RULES or bound is None \
                        or not numeric and rule not in ("equalTo", "notEqualTo"):
                    raise doc.outside(constraint, f"rule {rule} on {bound!r}")
                holds = holds and _RULES[rule](parameter.value, bound)
            passed = passed or holds
        if not passed:
            raise doc.error(parameter.element, f"parameter {name} = {parameter.value!r} "
                                               f"breaks its ConstraintGroup")


def _substitute(doc: _Doc, element: ET.Element, scope: Mapping[str, ParameterValue]) -> None:
    """Replace every ``$name`` attribute value under ``element`` (its own too)."""
    for attribute, text in element.attrib.items():
        if not text.startswith("$") or attribute in _NAME_ATTRIBUTES:
            continue
        if text.startswith("${"):
            raise doc.error(element, f"the expression {text} (OpenSCENARIO 1.2's) is "
                                     f"outside the subset sdc runs", attribute)
        name = text[1:]
        if name not in scope:
            names = ", ".join(scope) or "none"
            raise doc.error(element, f"{text} names no declared parameter (declared: "
                                     f"{names})", attribute)
        element.set(attribute, _as_text(scope[name]))
    for child in element:
        if child.tag in ("ParameterDeclarations", "FileHeader"):
            continue
        inner = scope
        local = child.find("ParameterDeclarations")
        if local is not None:
            declared = _declarations(doc, local)
            _check_constraints(doc, declared)
            inner = {**scope, **{name: d.value for name, d in declared.items()}}
        _substitute(doc, child, inner)


# ---------------------------------------------------------------- entities


class _Catalogs:
    """The entity catalogs a scenario's CatalogLocations name."""

    def __init__(self, doc: _Doc):
        self.doc = doc
        self.directories: list[tuple[ET.Element, Path]] = []
        for kind in ENTITY_CATALOGS:
            for directory in doc.root.findall(f"CatalogLocations/{kind}/Directory"):
                path = Path(_text(doc, directory, "path"))
                self.directories.append((directory, doc.path.parent / path))

    def entry(self, reference: ET.Element) -> tuple[_Doc, ET.Element]:
        doc = self.doc
        catalog = _text(doc, reference, "catalogName")
        name = _text(doc, reference, "entryName")
        for _, folder in self.directories:
            for file in sorted(folder.glob("*.xosc")) if folder.is_dir() else ():
                cdoc = _parse(file, "the catalog file")  # afresh: its parameters differ
                found = cdoc.root.find("Catalog")
                if found is None or found.get("name") != catalog:
                    continue
                _check_version(cdoc)
                entries = {e.get("name"): e for e in found}
                if name not in entries:
                    raise doc.error(reference, f"catalog {catalog} ({file}) has no entry "
                                               f"{name} (it has: {', '.join(map(str, entries))})")
                return cdoc, self._resolved(cdoc, entries[name], reference)
        looked = ", ".join(f"{folder}" + ("" if folder.is_dir() else " (no such directory)")
                           for _, folder in self.directories) or \
            "no entity catalog in CatalogLocations"
        raise doc.error(reference, f"cannot find catalog {catalog} (looked in: {looked})",
                        "catalogName")

    def _resolved(self, cdoc: _Doc, entry: ET.Element, reference: ET.Element) -> ET.Element:
        declared = _declarations(cdoc, entry.find("ParameterDeclarations"))
        assignments = {}
        for assignment in reference.findall("ParameterAssignments/ParameterAssignment"):
            assignments[_text(self.doc, assignment, "parameterRef")] = \
                _text(self.doc, assignment, "value")
        where = self.doc.where(reference)
        _override(self.doc, declared, assignments,
                  lambda given: f"{where}/ParameterAssignments/ParameterAssignment"
                                f"[parameterRef={given}]",
                  f"catalog entry {entry.get('name')} ({cdoc.path})")
        _check_constraints(cdoc, declared)
        _substitute(cdoc, entry, {name: d.value for name, d in declared.items()})
        return entry


def _bounding_box(doc: _Doc, entity: ET.Element):
    box = entity.find("BoundingBox")
    dimensions = None if box is None else box.find("Dimensions")
    center = None if box is None else box.find("Center")
    if dimensions is None or center is None:
        raise doc.error(entity, f"{entity.tag} has no BoundingBox with Center and Dimensions")
    size = tuple(_float(doc, dimensions, key) for key in ("length", "width", "height"))
    if min(size) <= 0:
        raise doc.error(dimensions, f"a {entity.tag}'s Dimensions must be positive, got "
                                    f"length, width, height {size}")
    return size, tuple(_float(doc, center, key) for key in ("x", "y", "z"))


def _what(doc: _Doc, entity: ET.Element) -> tuple[str, str]:
    """An entity's (kind, category)."""
    if entity.tag == "Vehicle":
        if entity.find("Trailer") is not None:
            raise doc.outside(entity.find("Trailer"), "a vehicle towing a trailer")
        category = _text(doc, entity, "vehicleCategory")
        kinds = VEHICLE_KINDS
    elif entity.tag == "Pedestrian":
        category = _text(doc, entity, "pedestrianCategory")
        kinds = PEDESTRIAN_KINDS
    elif entity.tag == "MiscObject":
        category = _text(doc, entity, "miscObjectCategory")
        if category not in MISC_SOLID:
            raise doc.error(entity, f"a MiscObject of category {category} is outside the "
                                    f"subset sdc runs (it reads {', '.join(MISC_SOLID)})",
                            "miscObjectCategory")
        (length, width, _), _ = _bounding_box(doc, entity)
        return ("barrel" if max(length, width) <= BARREL_MAX_M else "box"), category
    else:
        raise doc.outside(entity, "an entity is a Vehicle, Pedestrian, MiscObject or a "
                                  "CatalogReference to one")
    if category not in kinds:
        raise doc.error(entity, f"a {entity.tag} of category {category} is outside the "
                                f"subset sdc runs (it reads {', '.join(kinds)})")
    return kinds[category], category


# ---------------------------------------------------------------- places and actions


def _orientation_still(doc: _Doc, position: ET.Element) -> None:
    for orientation in position.findall("Orientation"):
        turned = any(_float(doc, orientation, key, 0.0) != 0 for key in ("h", "p", "r"))
        if turned or orientation.get("type", "relative") != "relative":
            raise doc.outside(orientation, "a body turned from its lane")


def _place(doc: _Doc, teleport: ET.Element) -> Place:
    position = teleport.find("Position")
    if position is None or len(position) != 1:
        raise doc.error(teleport, "TeleportAction has no Position")
    (place,) = position
    if place.tag == "LanePosition":
        _orientation_still(doc, place)
        lane = _int(doc, place, "laneId")
        if lane == 0:
            raise doc.error(place, "laneId 0 is OpenDRIVE's reference line, not a lane",
                            "laneId")
        return LanePlace(_text(doc, place, "roadId"), lane, _float(doc, place, "s"),
                         _float(doc, place, "offset", 0.0))
    if place.tag == "RoadPosition":
        _orientation_still(doc, place)
        return RoadPlace(_text(doc, place, "roadId"), _float(doc, place, "s"),
                         _float(doc, place, "t"))
    if place.tag == "WorldPosition":
        for key in ("p", "r"):
            if _float(doc, place, key, 0.0) != 0:
                raise doc.error(place, f"a WorldPosition tilted ({key} not 0) is outside "
                                       f"the subset sdc runs", key)
        return WorldPlace(_float(doc, place, "x"), _float(doc, place, "y"),
                          _float(doc, place, "h", 0.0))
    raise doc.outside(place, "positions are LanePosition, RoadPosition or WorldPosition")


def _speed(doc: _Doc, longitudinal: ET.Element) -> float:
    action = longitudinal[0] if len(longitudinal) == 1 else None
    if action is None or action.tag != "SpeedAction":
        raise doc.outside(action if action is not None else longitudinal,
                          "Init sets a speed by a SpeedAction")
    target = action.find("SpeedActionTarget")
    absolute = None if target is None else target.find("AbsoluteTargetSpeed")
    if absolute is None:
        raise doc.outside(target[0] if target is not None and len(target) else action,
                          "a speed is an AbsoluteTargetSpeed")
    speed = _float(doc, absolute, "value")
    if speed < 0:
        raise doc.error(absolute, f"a negative speed ({speed:g} m/s) is outside the subset "
                                  f"sdc runs", "value")
    return speed


def _controller_only(action: ET.Element) -> bool:
    """Is the private action one that starts or assigns a controller (nothing else)?"""
    if action.tag == "ActivateControllerAction":
        return True
    return action.tag == "ControllerAction" and len(action) > 0 and all(
        child.tag in ("ActivateControllerAction", "AssignControllerAction") for child in action)


@dataclasses.dataclass
class _Init:
    place: Place
    speed_mps: float | None


def _init(doc: _Doc, name: str, privates: Iterable[ET.Element], is_ego: bool,
          entity: ET.Element) -> _Init:
    place = speed = None
    for private in privates:
        for wrapper in private:
            if wrapper.tag != "PrivateAction" or len(wrapper) != 1:
                raise doc.outside(wrapper)
            (action,) = wrapper
            if action.tag == "TeleportAction":
                if place is not None:
                    raise doc.error(action, f"{name} is teleported twice in Init")
                place = _place(doc, action)
            elif action.tag == "LongitudinalAction":
                if speed is not None:
                    raise doc.error(action, f"{name}'s speed is set twice in Init")
                speed = _speed(doc, action)
                if not is_ego and speed != 0:
                    raise doc.error(action, f"{name} moves (speed {speed:g} m/s): sdc's "
                                            f"bodies stand still")
            elif is_ego and _controller_only(action):
                continue  # sdc drives the ego
            else:
                raise doc.outside(action, f"an action of {name} in Init")
    if place is None:
        raise doc.error(entity, f"{name} has no TeleportAction in Storyboard/Init: sdc "
                                f"places every entity at the start")
    return _Init(place, speed)


def _chain(element: ET.Element, depth: int = 3) -> str:
    """The tags of ``element``'s first descendants, ``depth`` deep: what an action is."""
    tags = []
    while len(element) and len(tags) < depth:
        element = element[0]
        tags.append(element.tag)
    return "/".join(tags) or element.tag


def _check_stories(doc: _Doc, storyboard: ET.Element) -> None:
    for story in storyboard.findall("Story"):
        for act in story.findall("Act"):
            for group in act.findall("ManeuverGroup"):
                for maneuver in group:
                    if maneuver.tag in ("Maneuver", "CatalogReference"):
                        action = maneuver.find("Event/Action")
                        what = "" if action is None else f" ({_chain(action)})"
                        raise doc.error(maneuver, f"{maneuver.tag} in a Story is outside the "
                                                  f"subset sdc runs: it runs Init only{what}")


def _duration(doc: _Doc, storyboard: ET.Element) -> float | None:
    stop = storyboard.find("StopTrigger")
    ends = []
    for group in [] if stop is None else stop:
        if group.tag != "ConditionGroup":
            raise doc.outside(group)
        times = [_stop_time(doc, condition) for condition in group]
        if times:
            ends.append(max(times))
    return min(ends) if ends else None


def _stop_time(doc: _Doc, condition: ET.Element) -> float:
    kind = condition.find("ByValueCondition/SimulationTimeCondition")
    if condition.tag != "Condition" or kind is None or len(condition) != 1:
        inner = condition.find("*/*") if len(condition) == 1 else None
        raise doc.outside(inner if inner is not None else condition,
                          "the StopTrigger is a SimulationTimeCondition")
    edge = _text(doc, condition, "conditionEdge")
    if edge not in _STOP_EDGES:
        raise doc.error(condition, f"a conditionEdge {edge} is outside the subset sdc runs "
                                   f"(it reads {', '.join(_STOP_EDGES)})", "conditionEdge")
    rule = _text(doc, kind, "rule")
    if rule not in _STOP_RULES:
        raise doc.error(kind, f"a SimulationTimeCondition's rule {rule} is outside the subset "
                              f"sdc runs (it reads {', '.join(_STOP_RULES)})", "rule")
    end = _float(doc, kind, "value") + _float(doc, condition, "delay", 0.0)
    if end <= 0:
        raise doc.error(kind, f"the run would stop at {end:g} s: it must last a while")
    return end


def _global_actions(doc: _Doc, actions: Iterable[ET.Element], ego: str) -> int:
    vehicles = None
    for action in actions:
        swarm = action.find("TrafficAction/TrafficSwarmAction")
        if swarm is None or len(action) != 1 or len(action[0]) != 1:
            deepest = action.find("*/*") if action.find("*/*") is not None else action
            raise doc.outside(deepest, "Init's global actions are one TrafficSwarmAction")
        if vehicles is not None:
            raise doc.error(swarm, "a second TrafficSwarmAction is outside the subset sdc runs")
        central = swarm.find("CentralObject")
        if central is None or central.get("entityRef") != ego:
            raise doc.error(swarm, f"a TrafficSwarmAction not centred on the ego ({ego}) is "
                                   f"outside the subset sdc runs")
        vehicles = _int(doc, swarm, "numberOfVehicles")
        if vehicles < 0:
            raise doc.error(swarm, "numberOfVehicles is negative", "numberOfVehicles")
    return vehicles or 0


def _road_file(doc: _Doc) -> Path:
    network = doc.root.find("RoadNetwork")
    logic = None if network is None else network.find("LogicFile")
    if logic is None:
        raise doc.error(network if network is not None else doc.root,
                        "no RoadNetwork/LogicFile: sdc runs a scenario on its OpenDRIVE road")
    signals = network.find("TrafficSignals")
    if signals is not None and len(signals):
        raise doc.outside(signals[0], "traffic signal controllers")
    path = doc.path.parent / _text(doc, logic, "filepath")
    try:
        check_file(path, "the OpenDRIVE road")
    except FileError as e:
        raise doc.error(logic, e.message, "filepath") from None
    return path.absolute()


# ---------------------------------------------------------------- the scenario


def read_scenario(path: str | Path,
                  parameters: Mapping[str, ParameterValue] = MappingProxyType({}),
                  ego: str | None = None) -> XoscScenario:
    """The scenario in the OpenSCENARIO file at ``path``, its parameters overridden by
    ``parameters`` (names with or without ``$``), its ego the entity named ``ego``
    (default: the one named Ego, ego or hero). Anything outside the subset sdc runs is
    a :class:`SpecError` naming the element and the file (the module's docstring)."""
    path = Path(path)
    doc = _parse(path, WHAT)
    if doc.root.find("ParameterValueDistribution") is not None:
        raise doc.error(doc.root.find("ParameterValueDistribution"),
                        "a ParameterValueDistribution file is a sweep over a scenario: run it "
                        "with `sdc sweep`")
    if doc.root.find("Storyboard") is None:
        what = "a Catalog" if doc.root.find("Catalog") is not None else "no scenario"
        raise doc.error(doc.root, f"the file is {what}, not a scenario (no Storyboard)")
    rev_minor = _check_version(doc)

    declared = _declarations(doc, doc.root.find("ParameterDeclarations"))
    _override(doc, declared, parameters, lambda given: f"parameters[{given}]", "the file")
    _check_constraints(doc, declared)
    values = {name: d.value for name, d in declared.items()}
    _substitute(doc, doc.root, values)

    xodr_file = _road_file(doc)
    objects: dict[str, ET.Element] = {}
    entities = doc.root.find("Entities")
    for obj in [] if entities is None else entities:
        if obj.tag != "ScenarioObject":
            raise doc.outside(obj, "entities are ScenarioObjects")
        name = _text(doc, obj, "name")
        if name in objects:
            raise doc.error(obj, f"two entities are named {name}")
        objects[name] = obj
    ego_name = _ego_name(doc, objects, ego, entities)

    storyboard = doc.root.find("Storyboard")
    _check_stories(doc, storyboard)
    privates: dict[str, list[ET.Element]] = {name: [] for name in objects}
    global_actions = []
    for action in storyboard.findall("Init/Actions/*"):
        if action.tag == "Private":
            ref = _text(doc, action, "entityRef")
            if ref not in privates:
                raise doc.error(action, f"entityRef {ref} names no entity (entities: "
                                        f"{', '.join(objects)})", "entityRef")
            privates[ref].append(action)
        elif action.tag == "GlobalAction":
            global_actions.append(action)
        else:
            raise doc.outside(action, "Init's actions are Private ones and a TrafficSwarmAction")

    catalogs = _Catalogs(doc)
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
        kind, category = _what(edoc, entity)
        size, center = _bounding_box(edoc, entity)
        init = _init(doc, name, privates[name], is_ego, obj)
        if is_ego:
            if entity.tag != "Vehicle":
                raise edoc.error(entity, f"the ego {name} is a {entity.tag}: sdc's ego is a "
                                         f"Vehicle")
            ego_kind, ego_size, ego_center, ego_init = kind, size, center, init
        else:
            bodies.append(Body(name, kind, category, size, center, init.place))

    return XoscScenario(
        path=path.absolute(), rev_minor=rev_minor, xodr_file=xodr_file, ego_name=ego_name,
        ego_kind=ego_kind, ego_place=ego_init.place, ego_speed_mps=ego_init.speed_mps or 0.0,
        ego_size_m=ego_size, ego_center_m=ego_center, bodies=tuple(bodies),
        duration_s=_duration(doc, storyboard),
        traffic_vehicles=_global_actions(doc, global_actions, ego_name), parameters=values)


def _ego_name(doc: _Doc, objects: dict[str, ET.Element], ego: str | None,
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
