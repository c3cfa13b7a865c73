"""What each ego of a SUMO world sees of SUMO's traffic: the vehicles and persons on
foot within its sensing radius, read from a context subscription around it (only
those are read, whatever the size of the network), each one's size and class its
type's (:mod:`scenarios.sumo.vehicle_types`), a vehicle's body laid along its lane
where SUMO holds it (:mod:`scenarios.scene.lane_bodies`); then the world's other
egos and their obstacles where they are in their runs
(:func:`scenarios.sumo.ego_slot.others_seen`).
"""

from __future__ import annotations

import functools
from collections.abc import Callable

import numpy as np
import traci.constants as tc  # plain numbers, shared by libsumo and traci

from scenarios.scene import road_kernels
from scenarios.scene.lane_bodies import PIECE_TOLERANCE_M, STRETCH_MIN_M, LanePaths
from scenarios.scene.snapshot import TRAFFIC
from scenarios.sumo.ego_slot import EgoSlot, others_seen
from scenarios.sumo.lane_laying import lanes_behind, lay
from scenarios.sumo.routes_xml import EGO_TYPE, OBSTACLE_TYPE_PREFIX
from scenarios.sumo.vehicle_types import VehicleTypes
from scenarios.sumo_net.grade_separation import LEVEL_REACH_M

#: what is read of each nearby body every step (each variable read costs, and a step
#: may read dozens); its size and class are read once (scenarios.sumo.vehicle_types)
_BODY_VARS = (tc.VAR_POSITION, tc.VAR_ANGLE, tc.VAR_SPEED)
#: of a vehicle, also where SUMO holds it on its lane (its lateral offset, its lane
#: position, its lane), to lay its body there (scenarios.scene.lane_bodies)
_TRAFFIC_VARS = (*_BODY_VARS, tc.VAR_LANEPOSITION_LAT, tc.VAR_LANEPOSITION, tc.VAR_LANE_ID)
#: and of a person: the vehicle it rides in ("" on foot: a person riding is inside
#: that vehicle's body, not a body of its own); SUMO places a person by its front
#: too, and angles it as a vehicle
_PERSON_VARS = (*_BODY_VARS, tc.VAR_VEHICLE)

#: what one ego reads: boxes, speeds, vehicle classes, which body each box is of
#: (None: each its own) and whose each box is (None: a world of one ego)
Read = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None, np.ndarray | None]


def subscription_slack_m(longest_m: float, ego_length_m: float) -> float:
    """SUMO measures the context radius between front bumpers: a body centre within
    the sensing radius has its front bumper within it plus half of each body's length
    (the longest vehicle type's for the other's) [m]."""
    return 1.0 + (longest_m + ego_length_m) / 2


def _is_person(values: dict) -> bool:
    """Are these subscription results a person's (not a vehicle's)?"""
    return tc.VAR_VEHICLE in values


def _riding(nearby: dict) -> frozenset[str]:
    """The persons of ``nearby`` riding in a vehicle (inside its body)."""
    return frozenset(pid for pid, values in nearby.items() if values.get(tc.VAR_VEHICLE))


def _with_others(slot: EgoSlot, slots: list[EgoSlot], boxes: np.ndarray, speeds: np.ndarray,
                 classes: np.ndarray, bodies: np.ndarray | None, ids: list[str] | None) -> Read:
    """The traffic ``slot`` reads from SUMO, and after it the other egos and their
    obstacles within its sensing radius, each a body of its own (their SUMO ids added
    to ``ids``, when kept); and whose each box is (SUMO's traffic, another run's)."""
    more_boxes, more_speeds, more_classes, more_owners, more_ids = others_seen(
        slot, slots, with_ids=ids is not None)
    if ids is not None:
        ids += more_ids
    owners = np.concatenate([np.full(len(boxes), TRAFFIC, dtype=object), more_owners])
    if not len(more_boxes):
        return boxes, speeds, classes, bodies, owners
    if bodies is not None:
        first = int(bodies[-1]) + 1 if len(bodies) else 0
        bodies = np.concatenate([bodies, first + np.arange(len(more_boxes))])
    return (np.vstack([boxes, more_boxes]), np.concatenate([speeds, more_speeds]),
            np.concatenate([classes, more_classes]), bodies, owners)


class TrafficReader:
    """The traffic around each ego of ``slots`` in SUMO (``sim``: libsumo or traci, as
    it started), sizes and classes from ``types`` (the world's, read as vehicles are
    met), ``is_traffic`` telling background traffic from the world's egos and their
    obstacles. ``paths``: the lanes' shapes, read as bodies are laid."""

    def __init__(self, sim, slots: list[EgoSlot], types: VehicleTypes,
                 is_traffic: Callable[[str], bool]):
        self.sim, self.slots, self.types, self.is_traffic = sim, slots, types, is_traffic
        self.paths = LanePaths(sim.lane, functools.partial(lanes_behind, sim))

    def watch(self) -> None:
        """Read the vehicle types SUMO has newly loaded; subscribe to the vehicles
        around each ego within a radius that holds the longest type's, and to the
        persons too from the step SUMO has loaded any (its count holds them before
        they depart, so none is missed)."""
        sim = self.sim
        self.types.refresh(sim.vehicletype, (EGO_TYPE, OBSTACLE_TYPE_PREFIX))
        vehicle = sim.vehicle
        for slot in self.slots:
            if not slot.active:
                continue
            radius_m = slot.radius_m + subscription_slack_m(self.types.longest_m,
                                                            slot.model.length_m)
            people = slot.people_subscribed or sim.person.getIDCount() > 0
            if radius_m > slot.subscribed_m or people != slot.people_subscribed:
                # libsumo hands both back in one dict (vehicle.getContextSubscriptionResults)
                vehicle.subscribeContext(slot.names.ego_id, tc.CMD_GET_VEHICLE_VARIABLE,
                                         radius_m, _TRAFFIC_VARS)
                if people:
                    vehicle.subscribeContext(slot.names.ego_id, tc.CMD_GET_PERSON_VARIABLE,
                                             radius_m, _PERSON_VARS)
                slot.subscribed_m, slot.people_subscribed = radius_m, people

    def unwatch(self, slot: EgoSlot) -> None:
        """End ``slot``'s subscriptions (SUMO would read the context of a vehicle it no
        longer has)."""
        if slot.subscribed_m:
            vehicle = self.sim.vehicle
            vehicle.unsubscribeContext(slot.names.ego_id, tc.CMD_GET_VEHICLE_VARIABLE,
                                       slot.subscribed_m)
            if slot.people_subscribed:
                vehicle.unsubscribeContext(slot.names.ego_id, tc.CMD_GET_PERSON_VARIABLE,
                                           slot.subscribed_m)

    def read(self, slot: EgoSlot, taken: frozenset[str] = frozenset(),
             last_ids: dict[int, list[str]] | None = None) -> Read:
        """Boxes, speeds and vehicle classes of the vehicles and the persons on foot
        within ``slot``'s sensing radius, its ego and obstacles aside and those
        ``taken`` off since the step, in SUMO's order, then the world's other egos and
        their obstacles (SUMO's copies of them aside); each one's size and class its
        type's, a person's class ``pedestrian``; which body each box is of (None: each
        its own); and whose each box is in a shared world (None: a world of one ego).
        With ``last_ids``, the SUMO ids of the rows go to ``last_ids[slot.slot]``.

        A vehicle's body is laid along its lane where SUMO holds it (its lane
        position, its lateral offset), in as many boxes as its path bends under it;
        SUMO's angle, which swings with a lane change, only says which vehicles are
        near (a body centre half a length behind the front bumper, within the sensing
        radius) and how a person on foot stands. The read of the dict of dicts libsumo
        and traci hand over, with the one-box bodies, is
        :func:`scenarios.scene.road_kernels.traffic` (compiled where built: in Python it
        cost more than the step's geometry); the rest are laid by
        :func:`scenarios.sumo.lane_laying.lay`.
        """
        sim, types = self.sim, self.types
        ego_box = slot.box
        nearby = sim.vehicle.getContextSubscriptionResults(slot.names.ego_id)
        # the results are the step's, from before they were taken off
        hidden = taken | self._on_other_levels(slot, nearby)
        if slot.people_subscribed:
            hidden |= _riding(nearby)
        if hidden or len(self.slots) > 1:
            nearby = {vid: values for vid, values in nearby.items()
                      if vid not in hidden and self.is_traffic(vid)}
        n = len(nearby)
        boxes, speeds, kinds, laid = np.empty((n, 5)), np.empty(n), np.empty(n), np.empty(n)
        try:
            count, laid_count = self._read(slot, nearby, boxes, speeds, kinds, laid)
        except KeyError:  # vehicles or persons met for the first time
            new = [v for v in nearby if v not in types.sizes and self.is_traffic(v)]
            types.add([v for v in new if not _is_person(nearby[v])], sim)
            types.add_persons([v for v in new if _is_person(nearby[v])], sim)
            count, laid_count = self._read(slot, nearby, boxes, speeds, kinds, laid)
        boxes, speeds, kinds = boxes[:count], speeds[:count], kinds[:count]
        bodies = None
        if laid_count:
            boxes, bodies = lay(self.paths, nearby, boxes, laid[:count])
            if bodies is not None:
                speeds, kinds = speeds[bodies], kinds[bodies]
        if last_ids is not None:
            ids = road_kernels.traffic_ids(
                nearby, _TRAFFIC_VARS, slot.names.ego_id, slot.names.obstacle_prefix,
                types.sizes, float(ego_box[0]), float(ego_box[1]), slot.radius_m)
            last_ids[slot.slot] = list(ids) if bodies is None else [ids[b] for b in bodies]
        classes = types.names(kinds)
        if len(self.slots) > 1:
            return _with_others(slot, self.slots, boxes, speeds, classes, bodies,
                                last_ids[slot.slot] if last_ids is not None else None)
        return boxes, speeds, classes, bodies, None

    def _on_other_levels(self, slot: EgoSlot, nearby: dict) -> frozenset[str]:
        """The vehicles around the ego of ``slot`` on a road that crosses its route
        without a junction (a bridge or a tunnel: :meth:`RoadGeometry.crossings`), their
        front bumpers within ``LEVEL_REACH_M`` of where it crosses."""
        points, lanes = slot.crossings.points_xy, slot.crossings.lanes
        if not nearby or not len(points):
            return frozenset()
        if np.min(np.hypot(*(points - slot.box[:2]).T)) > slot.radius_m + LEVEL_REACH_M:
            return frozenset()
        hidden = []
        for vid, values in nearby.items():
            x_m, y_m = values[tc.VAR_POSITION]
            near = np.min(np.hypot(points[:, 0] - x_m, points[:, 1] - y_m)) <= LEVEL_REACH_M
            domain = self.sim.person if _is_person(values) else self.sim.vehicle
            if near and self.is_traffic(vid) and domain.getLaneID(vid) in lanes:
                hidden.append(vid)
        return frozenset(hidden)

    def _read(self, slot: EgoSlot, nearby: dict, boxes: np.ndarray, speeds: np.ndarray,
              kinds: np.ndarray, laid: np.ndarray) -> tuple[int, int]:
        names = slot.names
        return road_kernels.traffic(nearby, _TRAFFIC_VARS, names.ego_id, names.obstacle_prefix,
                                    self.types.sizes, self.paths.flat, float(slot.box[0]),
                                    float(slot.box[1]), slot.radius_m, PIECE_TOLERANCE_M,
                                    STRETCH_MIN_M, boxes, speeds, kinds, laid)
