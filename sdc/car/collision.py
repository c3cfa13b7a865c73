"""Our own collision test: the ego's body box against obstacles, traffic, people and
the road edges, every step; and, for a collision, which part of the ego was hit and
who moved into whom. A contact with a person (one of SUMO's pedestrians, or a
standing person among the obstacles) is a ``pedestrian`` collision, whatever else the
ego touches at that step: every contact with a person is counted under one name."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from analysis.measures.run_outcome import STUCK_SPEED_MPS
from scenarios.scene.boxes import box_corners
from scenarios.scene.road_geometry import RoadGeometry
from scenarios.scene.snapshot import TRAFFIC, Snapshot
from scenarios.spec.bodies import PEDESTRIAN, are_people
from sdc.car.geometry import boxes_overlap, one_box_corners
from sdc.car.geometry_kernels import Contacts

OBSTACLE, VEHICLE, ROAD_EDGE = "obstacle", "vehicle", "road_edge"
FRONT, SIDE, REAR = "front", "side", "rear"
#: the ego moved into the contact faster than the other body did / the other body did
RAN_INTO, WAS_HIT = "ran_into", "was_hit"


class Collision(NamedTuple):
    with_: str  # PEDESTRIAN, OBSTACLE, VEHICLE or ROAD_EDGE
    part: str  # FRONT, SIDE or REAR: the part of the ego's body that was hit
    role: str  # RAN_INTO or WAS_HIT
    vehicle_class: str | None = None  # a vehicle's SUMO vClass (passenger, truck, ...)
    #: whose the body hit was: OBSTACLE (the run's own), TRAFFIC (SUMO's), OTHER_EGO or
    #: OTHER_OBSTACLE (another run's, a shared world: scenarios.scene.snapshot); None: a
    #: road edge
    body: str | None = None


def person_touched(ego_box: np.ndarray, snapshot: Snapshot, obstacle_classes: tuple[str | None, ...]
                   ) -> tuple[np.ndarray, float, str] | None:
    """The box and speed [m/s] of a person the ego's box touches (a standing person
    among the obstacles, whose ``obstacle_classes`` say which, before SUMO's persons),
    and whose the person is (:func:`owner`), or None."""
    for boxes, people, speeds in (
            (snapshot.obstacle_boxes, are_people(obstacle_classes), None),
            (snapshot.traffic_boxes, are_people(snapshot.traffic_classes),
             snapshot.traffic_speeds_mps)):
        touched = np.flatnonzero(people)
        touched = touched[boxes_overlap(ego_box, boxes[touched])] if len(touched) else touched
        if len(touched):
            if speeds is None:
                return boxes[touched[0]], 0.0, OBSTACLE
            return (boxes[touched[0]], float(speeds[touched[0]]),
                    owner(snapshot, int(touched[0])))
    return None


def owner(snapshot: Snapshot, index: int) -> str:
    """Whose traffic box ``index`` of ``snapshot`` is: SUMO's traffic, or another run's
    ego or obstacle in a shared world."""
    owners = snapshot.traffic_owners
    return TRAFFIC if owners is None else str(owners[index])


def collision_with(ego_box: np.ndarray, contacts: Contacts, road: RoadGeometry,
                   snapshot: Snapshot | None = None,
                   obstacle_classes: tuple[str | None, ...] = ()) -> str | None:
    """What the ego touches (``pedestrian``, ``obstacle``, ``vehicle``, ``road_edge``)
    or ``None``, given its box's ``contacts`` with the obstacles and traffic of
    ``snapshot`` (the obstacles' ``obstacle_classes``: which is a person).

    A body corner off the road (beyond either edge, while alongside it; off the
    drivable area of a network) counts as a road-edge collision, unless it is past
    the route's end (where the route leaves the network there is no kerb: SUMO's
    vehicles leave it; the run ends there).
    """
    if contacts.obstacle >= 0 or contacts.vehicle >= 0:
        if snapshot is not None and person_touched(ego_box, snapshot,
                                                   obstacle_classes) is not None:
            return PEDESTRIAN
        return OBSTACLE if contacts.obstacle >= 0 else VEHICLE
    if road.any_off_road(one_box_corners(ego_box)):
        return ROAD_EDGE
    return None


def _in_frame(box: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(K, 2) points in ``box``'s frame: along its length, across it (left positive)."""
    c, s = math.cos(box[2]), math.sin(box[2])
    d = np.asarray(points, float).reshape(-1, 2) - box[:2]
    return np.column_stack([d[:, 0] * c + d[:, 1] * s, -d[:, 0] * s + d[:, 1] * c])


def _inside(box: np.ndarray, points: np.ndarray) -> np.ndarray:
    local = _in_frame(box, points)
    return (np.abs(local[:, 0]) <= box[3] / 2) & (np.abs(local[:, 1]) <= box[4] / 2)


def contact_point(ego_box: np.ndarray, other: np.ndarray) -> np.ndarray:
    """Where two overlapping boxes touch: the mean of the corners of each inside the
    other (the other box's centre when no corner is: a crossing through both sides)."""
    ego_corners, other_corners = box_corners(ego_box)[0], box_corners(other)[0]
    inside = np.vstack([other_corners[_inside(ego_box, other_corners)],
                        ego_corners[_inside(other, ego_corners)]])
    return inside.mean(axis=0) if len(inside) else np.asarray(other[:2], float)


def hit_part(ego_box: np.ndarray, point_xy: np.ndarray) -> str:
    """The part of the ego's body nearest to ``point_xy``: the edge whose line it is
    closest to."""
    (x, y), = _in_frame(ego_box, point_xy)
    to_edge = {FRONT: ego_box[3] / 2 - x, REAR: ego_box[3] / 2 + x, SIDE: ego_box[4] / 2 - abs(y)}
    return min(to_edge, key=to_edge.get)


def _velocity(yaw_rad: float, speed_mps: float) -> np.ndarray:
    return speed_mps * np.array([math.cos(yaw_rad), math.sin(yaw_rad)])


def describe(hit: str, ego_box: np.ndarray, ego_speed_mps: float, contacts: Contacts,
             snapshot: Snapshot, road: RoadGeometry | None, road_heading_rad: float,
             obstacle_classes: tuple[str | None, ...] = ()) -> Collision:
    """The :class:`Collision` of a step where the ego touched ``hit``: the part of its
    body nearest the contact, and who moved into it, judged in the road's frame (the
    road heading ``road_heading_rad`` there): for a side contact across the road, for a
    front or rear one along it, the ego ``ran_into`` it when it closed in on the
    contact faster than the other body did, else it ``was_hit``. Obstacles, road edges,
    standing cars and standing people are always run into; a standing ego (under
    ``STUCK_SPEED_MPS``) touched by a moving body was always hit, whichever way that
    body moved (a car turning away can swing its corner into it). A vehicle's class comes
    with it (``pedestrian`` for a person), and whose the body hit was."""
    ego_box = np.asarray(ego_box, float)
    vehicle_class, body = None, None
    if hit == PEDESTRIAN:
        other, other_speed_mps, body = person_touched(ego_box, snapshot, obstacle_classes)
        point = contact_point(ego_box, other)
        other_mps = _velocity(float(other[2]), other_speed_mps)
        vehicle_class = PEDESTRIAN
    elif hit == ROAD_EDGE:
        corners = one_box_corners(ego_box)
        point, other_mps = corners[road.off_road(corners)].mean(axis=0), np.zeros(2)
    elif hit == OBSTACLE:
        point = contact_point(ego_box, snapshot.obstacle_boxes[contacts.obstacle])
        other_mps, body = np.zeros(2), OBSTACLE
    else:
        other = snapshot.traffic_boxes[contacts.vehicle]
        point = contact_point(ego_box, other)
        other_mps = _velocity(float(other[2]),
                              float(snapshot.traffic_speeds_mps[contacts.vehicle]))
        vehicle_class = str(snapshot.traffic_classes[contacts.vehicle])
        body = owner(snapshot, contacts.vehicle)
    part = hit_part(ego_box, point)
    c, s = math.cos(road_heading_rad), math.sin(road_heading_rad)
    axis = np.array([-s, c]) if part == SIDE else np.array([c, s])
    toward = axis if float((point - ego_box[:2]) @ axis) >= 0 else -axis
    ego_closing = float(_velocity(float(ego_box[2]), ego_speed_mps) @ toward)
    other_closing = float(-other_mps @ toward)
    standing = ego_speed_mps < STUCK_SPEED_MPS and other_mps.any()  # it moved, not the ego
    moved_in = not standing and (ego_closing > other_closing or not other_mps.any())
    return Collision(hit, part, RAN_INTO if moved_in else WAS_HIT, vehicle_class, body)
