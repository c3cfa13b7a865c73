"""An OpenSCENARIO scenario's ``Storyboard`` beyond its entities' Init: the Stories
(checked to hold nothing sdc would have to run), the stop time, and Init's global
actions (background traffic).

- Stories: any ``Maneuver`` (or catalogued one) in a Story is refused, naming the
  action it holds: sdc runs Init only. Empty Stories, Acts and ManeuverGroups (as
  scenariogeneration writes for 1.0) are fine.
- Duration: the ``Storyboard/StopTrigger``'s ``SimulationTimeCondition``s (rule
  ``greaterThan`` or ``greaterOrEqual``, edge rising, risingOrFalling or none) plus
  their delay: the latest of a group's (all must hold), the earliest group (any
  stops); a stop at or before 0 s is refused, and so is any other condition. No
  StopTrigger: None.
- Traffic: an Init ``TrafficSwarmAction`` centred on the ego gives the count of
  background vehicles (its ``numberOfVehicles``; 0 with none). Only the count is
  kept: sdc's traffic is that many random trips over the whole network at its speed
  limits, not a swarm in an ellipse around the ego. A second swarm, one centred on
  another entity and any other global action are refused.
- Environment: an Init ``EnvironmentAction``'s ``RoadCondition frictionScaleFactor``
  scales the road's grip (the ego's friction coefficient); its weather and time of
  day are not modelled (sdc's lidar and road are the same in any weather), which
  :func:`environment` says in a note rather than in silence. A catalogued
  environment is refused.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Iterable

from scenarios.asam.xosc_document import Doc, attr_float, attr_int, attr_text

_STOP_RULES = ("greaterThan", "greaterOrEqual")
_STOP_EDGES = ("rising", "risingOrFalling", "none")


def _chain(element: ET.Element, depth: int = 3) -> str:
    """The tags of ``element``'s first descendants, ``depth`` deep: what an action is."""
    tags = []
    while len(element) and len(tags) < depth:
        element = element[0]
        tags.append(element.tag)
    return "/".join(tags) or element.tag


def check_stories(doc: Doc, storyboard: ET.Element) -> None:
    for story in storyboard.findall("Story"):
        for act in story.findall("Act"):
            for group in act.findall("ManeuverGroup"):
                for maneuver in group:
                    if maneuver.tag in ("Maneuver", "CatalogReference"):
                        action = maneuver.find("Event/Action")
                        what = ("" if action is None
                                else f"; its first action is {_chain(action)}")
                        raise doc.error(maneuver, f"{maneuver.tag} in a Story is outside the "
                                                  "subset sdc runs: sdc runs a scenario's Init "
                                                  f"only{what}")


def duration(doc: Doc, storyboard: ET.Element) -> float | None:
    stop = storyboard.find("StopTrigger")
    ends = []
    for group in [] if stop is None else stop:
        if group.tag != "ConditionGroup":
            raise doc.outside(group)
        times = [_stop_time(doc, condition) for condition in group]
        if times:
            ends.append(max(times))
    return min(ends) if ends else None


def _stop_time(doc: Doc, condition: ET.Element) -> float:
    kind = condition.find("ByValueCondition/SimulationTimeCondition")
    if condition.tag != "Condition" or kind is None or len(condition) != 1:
        inner = condition.find("*/*") if len(condition) == 1 else None
        raise doc.outside(inner if inner is not None else condition,
                          "the StopTrigger is a SimulationTimeCondition")
    edge = attr_text(doc, condition, "conditionEdge")
    if edge not in _STOP_EDGES:
        raise doc.error(condition, f"a conditionEdge {edge} is outside the subset sdc runs "
                                   f"(it reads {', '.join(_STOP_EDGES)})", "conditionEdge")
    rule = attr_text(doc, kind, "rule")
    if rule not in _STOP_RULES:
        raise doc.error(kind, f"a SimulationTimeCondition's rule {rule} is outside the subset "
                              f"sdc runs (it reads {', '.join(_STOP_RULES)})", "rule")
    end = attr_float(doc, kind, "value") + attr_float(doc, condition, "delay", 0.0)
    if end <= 0:
        raise doc.error(kind, f"the run would stop at {end:g} s: it must last a while")
    return end


def environment(doc: Doc, actions: list[ET.Element]) -> tuple[float, tuple[str, ...]]:
    """The road's friction scale factor of Init's ``EnvironmentAction`` (1 without
    one) and what sdc does not model of it, in notes; its actions are taken out of
    ``actions`` (the global actions left for :func:`swarm_vehicles`)."""
    found = [a for a in actions if a.find("EnvironmentAction") is not None and len(a) == 1]
    if len(found) > 1:
        raise doc.error(found[1][0], "a second EnvironmentAction is outside the subset sdc runs")
    for action in found:
        actions.remove(action)
    if not found:
        return 1.0, ()
    setting = found[0][0].find("Environment")
    if setting is None:
        raise doc.outside(found[0][0][0], "an environment from a catalog (give its Environment)")
    road = setting.find("RoadCondition")
    factor = 1.0 if road is None else attr_float(doc, road, "frictionScaleFactor")
    if not 0 < factor <= 2:
        raise doc.error(road, f"a frictionScaleFactor of {factor:g} is outside (0, 2]",
                        "frictionScaleFactor")
    return factor, ("EnvironmentAction: its road's friction scale factor is read; its weather "
                    "and time of day are not modelled (sdc's lidar and road are the same in "
                    "any weather)",)


def swarm_vehicles(doc: Doc, actions: Iterable[ET.Element], ego: str) -> int:
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
        vehicles = attr_int(doc, swarm, "numberOfVehicles")
        if vehicles < 0:
            raise doc.error(swarm, "numberOfVehicles is negative", "numberOfVehicles")
    return vehicles or 0
