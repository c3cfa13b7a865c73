"""Obstacles entering SUMO under way: those of a run entering a shared world that has
started, in their own lanes (:func:`stand_obstacles`), and those shown to SUMO in the
lanes beside their own: on a network, an obstacle
standing too far into a lane beside its own for the traffic to pass
(:func:`~scenarios.sumo.routes_xml.lanes_blocked`, for the widest type SUMO has
loaded) stands there too, as a second stopped vehicle; so does one reaching into
another edge's lanes (the opposite lanes of a two-way street,
:func:`~scenarios.sumo_net.lanes_reached.lanes_reached`). A built road's obstacles
stand beside from the start (``scenarios/sumo/routes_xml.py``).
"""

from __future__ import annotations

from collections.abc import Callable

from scenarios.spec.scenario_tables import ObstacleSpec
from scenarios.sumo.ego_slot import EgoSlot
from scenarios.sumo.routes_xml import OBSTACLE_TYPE_PREFIX, lanes_blocked, obstacle_spot
from scenarios.sumo.start_zone import clear_lane
from scenarios.sumo_net.lanes_reached import lanes_reached
from scenarios.sumo_net.net_xml import NetFile, NetLane


def show_beside(sim, slot: EgoSlot, width_m: float, is_traffic: Callable[[str], bool]
                ) -> None:
    """Each of ``slot``'s obstacles in the lanes it blocks beside its own for traffic
    ``width_m`` wide: its edge's (``obstacle.<i>.<lane index>``) and other edges'
    (``obstacle.<i>.<lane id>``). ``sim``: libsumo or traci."""
    road = slot.road
    for i, (obstacle, box) in enumerate(zip(slot.spec.obstacles, slot.obstacle_boxes,
                                            strict=True)):
        edge, own, front_m = obstacle_spot(road, obstacle)
        own_length_m = road.net.lanes[f"{edge}_{own}"].sumo_length_m
        prefix = f"{slot.names.obstacle_prefix}{i}"
        for step in lanes_blocked(road, box, 0, width_m):
            beside = road.net.lanes.get(f"{edge}_{own + step}")
            if beside is not None:  # else its front is on an edge without that lane
                _stand(sim, f"{prefix}.{beside.index}", obstacle, beside,
                       front_m * beside.sumo_length_m / own_length_m, road.net, is_traffic)
        for lane, pos_m in lanes_reached(road.net, box, edge, width_m):
            _stand(sim, f"{prefix}.{lane.id}", obstacle, lane, pos_m, road.net, is_traffic)


def stand_obstacles(sim, slot: EgoSlot, is_traffic: Callable[[str], bool]) -> None:
    """Each of ``slot``'s obstacles stopped for good in its own lane, where it stands from
    the start in a run that starts with the world (``routes_xml``'s placement), the
    traffic too close to stop for it taken off, and put there at once: SUMO's
    insertion checks (a vehicle just ahead, a junction) would hold it back, as the
    start's ``insertionChecks="none"`` does not. ``sim``: libsumo or traci."""
    road = slot.road
    for i, obstacle in enumerate(slot.spec.obstacles):
        edge, lane, front_m = obstacle_spot(road, obstacle, obstacle.lane)
        _stand(sim, f"{slot.names.obstacle_prefix}{i}", obstacle,
               road.net.lanes[f"{edge}_{lane}"], front_m, road.net, is_traffic, forced=True)


def _stand(sim, vid: str, obstacle: ObstacleSpec, lane: NetLane, pos_m: float, net: NetFile,
           is_traffic: Callable[[str], bool], forced: bool = False) -> None:
    """A vehicle of ``obstacle``'s kind stopped for good on ``lane`` of ``net``, its
    front at ``pos_m``, the traffic too close to stop for it taken off; ``forced``:
    moved there at once (SUMO's way round its insertion checks, which
    ``vehicle.add`` cannot turn off)."""
    # one number for its departure and its stop: a departure rounded past its
    # stop is refused
    pos_m = round(pos_m, 6)
    clear_lane(sim, net, lane, pos_m - obstacle.size_m[0], pos_m, is_traffic)
    sim.route.add(vid, [lane.edge])
    sim.vehicle.add(vid, vid, typeID=f"{OBSTACLE_TYPE_PREFIX}{obstacle.type_name}",
                    depart="now", departLane=str(lane.index), departPos=f"{pos_m:.6f}",
                    departSpeed="0")
    if forced:
        sim.vehicle.moveTo(vid, lane.id, pos_m)
    sim.vehicle.setStop(vid, lane.edge, pos=pos_m, laneIndex=lane.index, duration=1e9)
