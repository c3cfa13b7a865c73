"""One run written as an OpenSCENARIO scenario: plain arrays in, a ``.xosc`` out,
built with ``scenariogeneration.xosc`` and checked against ASAM's schema.

The version: OpenSCENARIO **1.0**. Everything written here exists in 1.0 and means
the same there: Vehicle, Pedestrian and MiscObject entities with their bounding
boxes; ``TeleportAction`` with a ``WorldPosition``; ``FollowTrajectoryAction`` with a
``Trajectory`` of a ``Polyline`` of timed ``Vertex`` es and a ``TimeReference``'s
``Timing`` (``domainAbsoluteRelative="absolute"``, scale 1, offset 0); the global
``EntityAction`` s ``AddEntityAction`` and ``DeleteEntityAction``; events started and
the scenario stopped by ``SimulationTimeCondition`` s. 1.0 is what CARLA's
ScenarioRunner reads (only it), esmini reads 1.0 to 1.3, and what 1.1+ would change
here is spelling (``TrajectoryRef``, ``Priority`` ``override``), not meaning. The
files are validated against the 1.0 XSD that scenariogeneration bundles
(:func:`schema_errors`); a file that fails is not left behind.

Frames and reference points. Positions are the trace's: the SUMO network's frame,
which the ``.xodr`` beside the file shares (:mod:`scenarios.asam.xodr_export`);
z = 0, headings counter-clockwise from x [rad]. OpenSCENARIO places a vehicle by its
reference point, the rear axle's centre: the ego's poses are its rear axle (the
trace's ``x_m, y_m``), its bounding box centred ``center_ahead_m`` ahead. Traffic
bodies, people and obstacles are known by their box centres, so their reference
point is the box centre (their bounding box centred on it).

Bodies that enter and leave. The trace holds the bodies in the ego's sensing radius
at each step, so a body appears at its first time and is gone after its last. A player
holds an entity that follows a timed trajectory at its first vertex until the first
vertex's time (esmini snaps a time before the first vertex to it), and OpenSCENARIO
instantiates the entities it declares; so a body that appears later would stand at
its entry point from the start. Instead: a body seen at the first step is placed in
``Init`` (``TeleportAction``) like the ego; a body that appears later is not in
``Init`` and is added at its first time by an ``AddEntityAction`` at its first pose
(esmini keeps an entity that ``Init`` does not place inactive until it is added),
with its ``FollowTrajectoryAction`` in the same event; a body last seen before the
run's end is deleted (``DeleteEntityAction``) one step after its last time. Each
event starts when the simulation time passes its time less half a step
(``SimulationTimeCondition`` greaterThan; 1.0 has no greaterOrEqual), so a player
stepping with the run's step acts at that very step. A body seen at one step only has
a trajectory of its one pose twice, at that time (a polyline needs two vertices).
Obstacles stand where they stood: placed in ``Init``, no story. The stop trigger is
the run's end (simulation time greater than its last step's time).
"""

from __future__ import annotations

import contextlib
import io
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from scenarios.common.errors import SdcError

#: the OpenSCENARIO minor version written (1.0: see the module's docstring)
OSC_MINOR_VERSION = 0
EGO = "ego"
#: SUMO vehicle class (and ``ego``, and the obstacle kinds) -> OpenSCENARIO vehicle
#: category; a class not named here is a car
VEHICLE_CATEGORIES = {
    "ego": "car", "passenger": "car", "car": "car", "taxi": "car", "private": "car",
    "evehicle": "car", "emergency": "car", "authority": "car", "army": "car", "vip": "car",
    "hov": "car", "delivery": "van", "truck": "truck", "trailer": "semitrailer",
    "bus": "bus", "coach": "bus", "motorcycle": "motorbike", "moped": "motorbike",
    "bicycle": "bicycle", "tram": "tram", "rail_urban": "train", "rail": "train",
    "rail_electric": "train", "rail_fast": "train",
}
#: kinds written as a Pedestrian, and as a MiscObject (category obstacle)
PEDESTRIAN_KINDS = ("pedestrian",)
THING_KINDS = ("barrel", "box")
#: bounding-box heights [m] by category (the trace has none)
_HEIGHTS_M = {"car": 1.5, "van": 2.2, "truck": 3.5, "semitrailer": 4.0, "trailer": 4.0,
              "bus": 3.2, "motorbike": 1.4, "bicycle": 1.7, "tram": 3.4, "train": 4.0,
              "pedestrian": 1.8, "obstacle": 1.0}


@dataclass(frozen=True)
class MovingBody:
    """A body's path: ``t_s`` (N,) its times [s], ``xy`` (N, 2) and ``heading_rad`` (N,)
    its reference point's poses; ``kind`` ``ego``, a SUMO vehicle class or
    ``pedestrian``; its box ``length_m`` x ``width_m``, centred ``center_ahead_m``
    ahead of its reference point."""

    name: str
    kind: str
    length_m: float
    width_m: float
    t_s: np.ndarray
    xy: np.ndarray
    heading_rad: np.ndarray
    center_ahead_m: float = 0.0


@dataclass(frozen=True)
class StandingBody:
    """An obstacle: its kind (``scenarios.spec.bodies.OBSTACLE_SIZES_M``' kinds, or a
    SUMO vehicle class) and its box ``[cx, cy, yaw, length, width]``."""

    name: str
    kind: str
    box: tuple[float, float, float, float, float]


def write_xosc(path: Path, *, road_file: str, ego: MovingBody, bodies: Sequence[MovingBody],
               obstacles: Sequence[StandingBody], end_s: float, step_s: float,
               description: str, wheelbase_m: float | None = None) -> None:
    """Write the run to ``path`` (OpenSCENARIO 1.0, its road ``road_file``, a path
    relative to it): the ego and ``bodies`` following their paths, the ``obstacles``
    standing, the stop at ``end_s``. The file is checked against ASAM's schema; one
    that fails is removed and a :class:`SdcError` names why (a fault of this writer)."""
    from scenariogeneration import xosc

    start_s = float(ego.t_s[0])
    entities, init = xosc.Entities(), xosc.Init()
    act = xosc.Act("run", _at_time(xosc, "run starts", start_s - step_s / 2))
    for body in [ego, *bodies]:
        entities.add_scenario_object(body.name, _entity(xosc, body.name, body.kind,
                                                        body.length_m, body.width_m,
                                                        body.center_ahead_m,
                                                        wheelbase_m if body is ego else None))
        act.add_maneuver_group(_path_group(xosc, init, body, start_s, end_s, step_s))
    for obstacle in obstacles:
        x, y, yaw, length, width = (float(v) for v in obstacle.box)
        entities.add_scenario_object(obstacle.name, _entity(xosc, obstacle.name, obstacle.kind,
                                                            length, width, 0.0, None))
        init.add_init_action(obstacle.name, xosc.TeleportAction(_pose(xosc, x, y, yaw)))
    storyboard = xosc.StoryBoard(init, _at_time(xosc, "run ends", end_s, "stop"))
    storyboard.add_story(xosc.Story("run").add_act(act))
    scenario = xosc.Scenario(description, "sdc", xosc.ParameterDeclarations(), entities,
                             storyboard, xosc.RoadNetwork(roadfile=road_file), xosc.Catalog(),
                             osc_minor_version=OSC_MINOR_VERSION)
    path = Path(path)
    scenario.write_xml(str(path))
    errors = schema_errors(path)
    if errors:
        path.unlink(missing_ok=True)
        raise SdcError(f"the OpenSCENARIO written for {path.name} fails ASAM's schema: "
                       f"{errors[0]}")


def _at_time(xosc, name: str, t_s: float, point: str = "start"):
    """A trigger (``point``: a start or a stop trigger): the simulation time passes
    ``t_s``."""
    return xosc.ValueTrigger(name, 0, xosc.ConditionEdge.none,
                             xosc.SimulationTimeCondition(float(t_s), xosc.Rule.greaterThan),
                             point)


def _pose(xosc, x: float, y: float, heading: float):
    return xosc.WorldPosition(float(x), float(y), 0.0, float(heading))


def _entity(xosc, name: str, kind: str, length_m: float, width_m: float,
            center_ahead_m: float, wheelbase_m: float | None):
    """The scenario object of a body: a Pedestrian, a MiscObject or a Vehicle."""
    if kind in PEDESTRIAN_KINDS:
        height = _HEIGHTS_M["pedestrian"]
        box = xosc.BoundingBox(width_m, length_m, height, center_ahead_m, 0.0, height / 2)
        return xosc.Pedestrian(name, 75.0, xosc.PedestrianCategory.pedestrian, box,
                               model=name)
    if kind in THING_KINDS:
        height = _HEIGHTS_M["obstacle"]
        box = xosc.BoundingBox(width_m, length_m, height, center_ahead_m, 0.0, height / 2)
        return xosc.MiscObject(name, 50.0, xosc.MiscObjectCategory.obstacle, box)
    category = VEHICLE_CATEGORIES.get(kind, "car")
    height = _HEIGHTS_M[category]
    box = xosc.BoundingBox(width_m, length_m, height, center_ahead_m, 0.0, height / 2)
    # axles relative to the reference point: the ego's rear axle is its reference
    # point; a body known by its box centre has its axles spread about it
    wheel_m = min(0.8, height / 2)
    if wheelbase_m is not None:
        rear_x, front_x = 0.0, wheelbase_m
    else:
        rear_x, front_x = center_ahead_m - 0.3 * length_m, center_ahead_m + 0.3 * length_m
    front = xosc.Axle(0.6, wheel_m, width_m * 0.85, front_x, wheel_m / 2)
    rear = xosc.Axle(0.0, wheel_m, width_m * 0.85, rear_x, wheel_m / 2)
    return xosc.Vehicle(name, getattr(xosc.VehicleCategory, category), box, front, rear,
                        70.0, 10.0, 10.0)


def _path_group(xosc, init, body: MovingBody, start_s: float, end_s: float, step_s: float):
    """The maneuver group of a moving body: placed in ``Init`` when it is there from the
    start, else added at its first time; its trajectory followed; deleted a step after
    its last time when that is before the run's end."""
    t_s, xy, heading = (np.asarray(a, float) for a in (body.t_s, body.xy, body.heading_rad))
    if len(t_s) == 0:
        raise ValueError(f"{body.name}: a path of no poses")
    if len(t_s) == 1:  # a polyline has two vertices at least: the one pose twice
        t_s, xy, heading = np.repeat(t_s, 2), np.repeat(xy, 2, axis=0), np.repeat(heading, 2)
    first = _pose(xosc, xy[0, 0], xy[0, 1], heading[0])
    polyline = xosc.Polyline([float(t) for t in t_s],
                             [_pose(xosc, x, y, h) for (x, y), h in zip(xy, heading, strict=True)])
    trajectory = xosc.Trajectory(f"{body.name} path", False)
    trajectory.add_shape(polyline)
    follow = xosc.FollowTrajectoryAction(trajectory, xosc.FollowingMode.position,
                                         xosc.ReferenceContext.absolute, 1, 0)
    appear = xosc.Event(f"{body.name} appears", xosc.Priority.parallel)
    from_start = t_s[0] <= start_s + step_s / 2
    if from_start:
        init.add_init_action(body.name, xosc.TeleportAction(first))
    else:
        appear.add_action(f"{body.name} added", xosc.AddEntityAction(body.name, first))
    appear.add_action(f"{body.name} follows its path", follow)
    appear.add_trigger(_at_time(xosc, f"{body.name} first seen", t_s[0] - step_s / 2))
    maneuver = xosc.Maneuver(f"{body.name} path")
    maneuver.add_event(appear)
    if t_s[-1] < end_s - step_s / 2:
        leave = xosc.Event(f"{body.name} leaves", xosc.Priority.parallel)
        leave.add_action(f"{body.name} deleted", xosc.DeleteEntityAction(body.name))
        leave.add_trigger(_at_time(xosc, f"{body.name} gone", t_s[-1] + step_s / 2))
        maneuver.add_event(leave)
    group = xosc.ManeuverGroup(f"{body.name} group")
    group.add_actor(body.name)
    group.add_maneuver(maneuver)
    return group


def schema_path(minor: int = OSC_MINOR_VERSION) -> Path:
    """ASAM's OpenSCENARIO 1.``minor`` XSD, as scenariogeneration bundles it."""
    import scenariogeneration

    name = f"OpenSCENARIO_1_{minor}{'_1' if minor == 3 else ''}.xsd"
    return Path(scenariogeneration.__file__).resolve().parent.parent / "schemas" / name


def schema_errors(path: Path) -> list[str]:
    """Why ``path`` fails ASAM's schema of the version its header names (empty: it is
    valid), as ``xosc.ParseOpenScenario`` checks it (xmlschema and the bundled XSD)."""
    import xml.etree.ElementTree as ET

    import xmlschema

    try:
        tree = ET.parse(path)
        header = tree.getroot().find("FileHeader")
        minor = int(header.get("revMinor")) if header is not None else -1
    except (ET.ParseError, OSError, TypeError, ValueError) as e:
        return [f"not readable OpenSCENARIO ({e})"]
    if header is None or header.get("revMajor") != "1" or not 0 <= minor <= 3:
        return ["no OpenSCENARIO 1.0-1.3 FileHeader"]
    with contextlib.redirect_stdout(io.StringIO()):  # xmlschema's loaders print nothing
        schema = xmlschema.XMLSchema(str(schema_path(minor)))
    return [f"{e.path}: {e.reason}" for e in schema.iter_errors(tree)]


def parse_xosc(path: Path):
    """``xosc.ParseOpenScenario`` of ``path``, its version line kept off stdout."""
    from scenariogeneration import xosc

    with contextlib.redirect_stdout(io.StringIO()):
        return xosc.ParseOpenScenario(os.fspath(path))
