"""ASAM files for the tests, written by scenariogeneration (ASAM's formats from a
library that is not ours): an OpenDRIVE road (a straight, an arc, a spiral into it
where asked, and a straight again, lanes each way), an OpenSCENARIO scenario on it,
and a file changed through ElementTree (a fault the library would not write)."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

from scenariogeneration import xodr


def write_arc_road(path: Path, lane_width_m: float = 3.2, radius_m: float = 80.0,
                   lanes_each_way: int = 2, spiral_m: float = 0.0,
                   turn_rad: float = math.pi / 2, first_m: float = 100.0,
                   last_m: float = 100.0) -> Path:
    """Road ``1``: ``first_m`` straight, a left arc of ``radius_m`` turning
    ``turn_rad`` (entered by a ``spiral_m`` spiral), ``last_m`` straight."""
    pieces = [xodr.Line(first_m)]
    if spiral_m:
        pieces.append(xodr.Spiral(1e-6, 1 / radius_m, spiral_m))
    pieces += [xodr.Arc(1 / radius_m, angle=turn_rad), xodr.Line(last_m)]
    road = xodr.create_road(pieces, id=1, left_lanes=lanes_each_way,
                            right_lanes=lanes_each_way, lane_width=lane_width_m)
    drive = xodr.OpenDrive(path.stem)
    drive.add_road(road)
    drive.adjust_roads_and_lanes()
    drive.write_xml(str(path))
    return path


def write_parked_car_xosc(path: Path, xodr_name: str = "road.xodr", ego_lane: int = -2,
                          ego_s_m: str | float = 10.0, speed_mps: str | float = 12.0,
                          parked_s_m: str | float = 150.0, duration_s: float = 25.0,
                          minor: int = 2, parameters: dict[str, float] | None = None,
                          others=(), friction_scale: float | None = None) -> Path:
    """An OpenSCENARIO file (written by scenariogeneration): the ego on road 1's lane
    ``ego_lane`` at ``ego_s_m``, driving ``speed_mps``, a car parked in the same lane at
    ``parked_s_m``, the run ending at
    ``duration_s``. ``parameters`` are declared (doubles) for ``$name`` values;
    ``others``: more bodies, each (name, scenariogeneration entity, position);
    ``friction_scale``: an EnvironmentAction with that RoadCondition."""
    from scenariogeneration import xosc

    box = xosc.BoundingBox(2.0, 5.0, 1.8, 1.4, 0.0, 0.9)
    front = xosc.Axle(0.5, 0.8, 1.68, 2.98, 0.4)
    rear = xosc.Axle(0.0, 0.8, 1.68, 0.0, 0.4)
    entities = xosc.Entities()
    entities.add_scenario_object("Ego", xosc.Vehicle("Ego", xosc.VehicleCategory.car, box,
                                                     front, rear, 69, 10, 10))
    entities.add_scenario_object("Parked", xosc.Vehicle("Parked", xosc.VehicleCategory.car,
                                                        box, front, rear, 69, 10, 10))
    init = xosc.Init()
    step = xosc.TransitionDynamics(xosc.DynamicsShapes.step, xosc.DynamicsDimension.time, 0)
    init.add_init_action("Ego", xosc.TeleportAction(xosc.LanePosition(ego_s_m, 0, ego_lane,
                                                                      "1")))
    init.add_init_action("Ego", xosc.AbsoluteSpeedAction(speed_mps, step))
    init.add_init_action("Parked", xosc.TeleportAction(xosc.LanePosition(parked_s_m, 0,
                                                                         ego_lane, "1")))
    if friction_scale is not None:
        init.add_global_action(xosc.EnvironmentAction(xosc.Environment(
            "road", xosc.TimeOfDay(True, 2024, 6, 1, 12, 0, 0), xosc.Weather(),
            xosc.RoadCondition(friction_scale))))
    for name, entity, position in others:
        entities.add_scenario_object(name, entity)
        init.add_init_action(name, xosc.TeleportAction(position))
    stop = xosc.ValueTrigger("end", 0, xosc.ConditionEdge.rising,
                             xosc.SimulationTimeCondition(duration_s, xosc.Rule.greaterThan),
                             "stop")
    declared = xosc.ParameterDeclarations()
    for name, value in (parameters or {}).items():
        declared.add_parameter(xosc.Parameter(name, xosc.ParameterType.double, str(value)))
    scenario = xosc.Scenario("parked car", "sdc tests", declared, entities,
                             xosc.StoryBoard(init, stop), xosc.RoadNetwork(roadfile=xodr_name),
                             xosc.Catalog(), osc_minor_version=minor)
    scenario.write_xml(str(path))
    return path


def edited(path: Path, change) -> Path:
    """``path`` rewritten with ``change(root)`` applied (through ElementTree)."""
    tree = ET.parse(path)
    change(tree.getroot())
    tree.write(path, encoding="utf-8", xml_declaration=True)
    return path
