"""An OpenSCENARIO scenario's ``Storyboard/Init`` for one entity: where it is placed
and at what speed it starts.

- Places: a ``TeleportAction`` to a ``LanePosition`` (``offset`` 0 when absent; lane
  0 refused), ``RoadPosition`` or ``WorldPosition`` (``h`` 0 when absent; ``z``
  ignored, sdc puts bodies on its road; a non-zero ``p``/``r`` refused). A
  Lane/RoadPosition's ``Orientation`` is accepted only when it turns nothing (every
  angle 0, type relative or absent): bodies face along their lane. Any other position
  is refused. Positions are of the entity's reference point (a vehicle's rear axle).
- Speed: ``LongitudinalAction/SpeedAction`` with an ``AbsoluteTargetSpeed`` (not
  negative); its ``SpeedActionDynamics`` is ignored (the ego starts at the target). No
  SpeedAction: the caller takes 0, OpenSCENARIO's own initial speed (an entity starts
  at rest).
- Every entity must be placed by a TeleportAction in Init; an entity teleported, or
  given a speed, twice is refused. A body (every entity but the ego) may have no other
  Init action but a SpeedAction to 0: sdc's bodies stand still. The ego's
  ``ActivateControllerAction`` / ``AssignControllerAction`` are ignored: sdc drives
  the ego with its own controllers. Any other Init action is refused.
"""

from __future__ import annotations

import dataclasses
import xml.etree.ElementTree as ET
from collections.abc import Iterable

from scenarios.asam.xosc_document import Doc, attr_float, attr_int, attr_text


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


def _orientation_still(doc: Doc, position: ET.Element) -> None:
    for orientation in position.findall("Orientation"):
        turned = any(attr_float(doc, orientation, key, 0.0) != 0 for key in ("h", "p", "r"))
        if turned or orientation.get("type", "relative") != "relative":
            raise doc.outside(orientation, "a body turned from its lane")


def place_of(doc: Doc, teleport: ET.Element) -> Place:
    position = teleport.find("Position")
    if position is None or len(position) != 1:
        raise doc.error(teleport, "TeleportAction has no Position")
    (place,) = position
    if place.tag == "LanePosition":
        _orientation_still(doc, place)
        lane = attr_int(doc, place, "laneId")
        if lane == 0:
            raise doc.error(place, "laneId 0 is OpenDRIVE's reference line, not a lane",
                            "laneId")
        return LanePlace(attr_text(doc, place, "roadId"), lane, attr_float(doc, place, "s"),
                         attr_float(doc, place, "offset", 0.0))
    if place.tag == "RoadPosition":
        _orientation_still(doc, place)
        return RoadPlace(attr_text(doc, place, "roadId"), attr_float(doc, place, "s"),
                         attr_float(doc, place, "t"))
    if place.tag == "WorldPosition":
        for key in ("p", "r"):
            if attr_float(doc, place, key, 0.0) != 0:
                raise doc.error(place, f"a WorldPosition tilted ({key} not 0) is outside "
                                       f"the subset sdc runs", key)
        return WorldPlace(attr_float(doc, place, "x"), attr_float(doc, place, "y"),
                          attr_float(doc, place, "h", 0.0))
    raise doc.outside(place, "positions are LanePosition, RoadPosition or WorldPosition")


def _speed(doc: Doc, longitudinal: ET.Element) -> float:
    action = longitudinal[0] if len(longitudinal) == 1 else None
    if action is None or action.tag != "SpeedAction":
        raise doc.outside(action if action is not None else longitudinal,
                          "Init sets a speed by a SpeedAction")
    target = action.find("SpeedActionTarget")
    absolute = None if target is None else target.find("AbsoluteTargetSpeed")
    if absolute is None:
        raise doc.outside(target[0] if target is not None and len(target) else action,
                          "a speed is an AbsoluteTargetSpeed")
    speed = attr_float(doc, absolute, "value")
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
class Init:
    place: Place
    speed_mps: float | None


def read_init(doc: Doc, name: str, privates: Iterable[ET.Element], is_ego: bool,
          entity: ET.Element) -> Init:
    place = speed = None
    for private in privates:
        for wrapper in private:
            if wrapper.tag != "PrivateAction" or len(wrapper) != 1:
                raise doc.outside(wrapper)
            (action,) = wrapper
            if action.tag == "TeleportAction":
                if place is not None:
                    raise doc.error(action, f"{name} is teleported twice in Init")
                place = place_of(doc, action)
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
    return Init(place, speed)
