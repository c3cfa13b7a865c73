"""Where a body enters SUMO, the traffic that could not stop for it is taken off: on
each ego's entry (:func:`clear_start`) and where an obstacle stands in a lane
(:func:`clear_lane`). Else SUMO holds the body back until the traffic has passed,
through it.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from scenarios.scene.snapshot import OBSTACLE_ZONE_BEHIND_M, in_start_zone, near_obstacles
from scenarios.sumo.ego_slot import EgoSlot
from scenarios.sumo_net.net_xml import NetFile, NetLane


def clear_start(vehicle, slots: list[EgoSlot], is_traffic: Callable[[str], bool],
                obstacles: bool = False, among: list[str] | None = None) -> frozenset[str]:
    """Take the traffic (``among`` those, default all of SUMO's ``vehicle`` domain)
    off each ego's entry (:func:`~scenarios.scene.snapshot.in_start_zone`: on or near
    it, or too close to stop for it or for it to stop), and with ``obstacles`` off the
    obstacles' spots too; the ids taken off."""
    ids = [v for v in (vehicle.getIDList() if among is None else among) if is_traffic(v)]
    fronts = np.array([vehicle.getPosition(v) for v in ids]).reshape(-1, 2)
    lengths = np.array([vehicle.getLength(v) for v in ids])
    yaws = np.radians(90.0 - np.array([vehicle.getAngle(v) for v in ids]))
    centers = fronts - (lengths / 2)[:, None] * np.column_stack([np.cos(yaws), np.sin(yaws)])
    speeds = np.array([vehicle.getSpeed(v) for v in ids])
    taken = np.zeros(len(ids), bool)
    for slot in slots:
        taken |= in_start_zone(slot.spec, slot.road, centers, lengths, speeds)
        if obstacles:
            taken |= near_obstacles(slot.spec, slot.road, fronts)
    removed = frozenset(str(vid) for vid in np.array(ids)[taken])
    for vid in sorted(removed, key=ids.index):
        vehicle.remove(vid)
    return removed


def clear_lane(sim, net: NetFile, lane: NetLane, back_m: float, front_m: float,
               is_traffic: Callable[[str], bool]) -> None:
    """Take the traffic off where a body appears on ``lane`` (lane positions
    ``back_m`` to ``front_m``) and off the :data:`OBSTACLE_ZONE_BEHIND_M` before it,
    on that lane and on the junction's lanes and lanes leading into it: cars too
    close to stop for it. ``sim``: libsumo or traci."""
    vehicle = sim.vehicle
    # each lane's end is this far before the body's back
    before = {lane.id: back_m - lane.sumo_length_m}
    for from_id, turns in net.turns.items():
        for turn in turns:
            if turn.to == lane.id:
                gap_m = back_m
                for k in (*reversed(turn.via), from_id):
                    before[k] = gap_m
                    gap_m += net.lanes[k].sumo_length_m
    for lane_id, gap_m in before.items():
        length_m = net.lanes[lane_id].sumo_length_m
        for vid in sim.lane.getLastStepVehicleIDs(lane_id):
            to_back_m = length_m - vehicle.getLanePosition(vid) + gap_m
            behind_front_m = to_back_m + (front_m - back_m) + vehicle.getLength(vid)
            if is_traffic(vid) and to_back_m < OBSTACLE_ZONE_BEHIND_M and behind_front_m > 0:
                vehicle.remove(vid)
