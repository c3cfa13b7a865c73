"""One ego of a SUMO world: its spec and road, the names SUMO knows it by, and where
it stands now.

A world holds one ego for a run alone, or several that share its traffic
(:mod:`sdc.run.shared_world`). Each ego senses the world on its own: the vehicles
and persons SUMO has around it (a context subscription of its own), and the other
egos and their obstacles where they truly are (our boxes, not where SUMO was shown
them: SUMO holds each inside one lane, and a stand-in in a lane it blocks;
:mod:`scenarios.scene.traffic_model`).
"""

from __future__ import annotations

import numpy as np

from scenarios.scene.road_geometry import RoadGeometry
from scenarios.scene.snapshot import OTHER_EGO, OTHER_OBSTACLE, obstacle_boxes, sensing_radius_m
from scenarios.spec.bodies import VEHICLE_MODELS
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.sumo.routes_xml import EgoNames, ego_names

#: the vehicle class another ego is seen as (SUMO's vClass of a car)
EGO_CLASS = "passenger"


class EgoSlot:
    """One ego of a world (``slot``: its place among the world's egos, 0 the first)."""

    def __init__(self, slot: int, spec: ScenarioSpec, road: RoadGeometry):
        self.slot, self.spec, self.road = slot, spec, road
        self.names: EgoNames = ego_names(slot)
        self.model = VEHICLE_MODELS[spec.vehicle.model]
        self.obstacle_boxes = obstacle_boxes(spec, road)
        #: the classes the other egos see its obstacles as (traffic to them): a
        #: vehicle's or person's class, else the obstacle's kind (a barrel)
        self.obstacle_classes = np.array([o.vehicle_class or o.kind for o in spec.obstacles],
                                         dtype=object)
        #: the SUMO ids of its bodies: its ego, then its obstacles
        self.body_ids = [self.names.ego_id, *(f"{self.names.obstacle_prefix}{i}"
                                              for i in range(len(spec.obstacles)))]
        self.radius_m = sensing_radius_m(spec)
        self.crossings = road.crossings()
        self.s_m = spec.ego.start_m  # where it was last, along its road
        self.subscribed_m = 0.0  # its context subscription's radius
        self.people_subscribed = False  # the persons around it are read too
        self.box: np.ndarray | None = None  # its body box as last pushed
        #: the lanes beside it (-1 right, +1 left) in which a body stands in for it now
        self.stand_ins: set[int] = set()
        self.speed_mps = 0.0
        self.active = True  # in the world: its run has not ended

    def is_mine(self, vehicle_id: str) -> bool:
        """Is ``vehicle_id`` this ego or one of its obstacles?"""
        return vehicle_id == self.names.ego_id or vehicle_id.startswith(
            self.names.obstacle_prefix)


def others_seen(slot: EgoSlot, slots: list[EgoSlot], with_ids: bool = False
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, list[str] | None]:
    """The bodies of the world's other egos in their runs (each ego's box, then its
    obstacles' boxes) whose centres lie within ``slot``'s sensing radius of its body
    centre: (N, 5) boxes, (N,) speeds, (N,) vehicle classes and (N,) owners
    (:data:`~scenarios.scene.snapshot.OTHER_EGO` or ``OTHER_OBSTACLE``), in slot order,
    and their SUMO ids when asked ``with_ids`` (only the world's audit reads them), else
    None."""
    others = [other for other in slots if other is not slot and other.active]
    if not others:
        none = np.zeros(0, dtype=object)
        return np.zeros((0, 5)), np.zeros(0), none, none, [] if with_ids else None
    boxes, speeds, classes, owners = [], [], [], []
    for other in others:
        boxes += [other.box[None, :], other.obstacle_boxes]
        speeds += [[other.speed_mps], np.zeros(len(other.obstacle_boxes))]
        classes += [[EGO_CLASS], other.obstacle_classes]
        owners += [OTHER_EGO, *[OTHER_OBSTACLE] * len(other.obstacle_boxes)]
    all_boxes = np.vstack(boxes)
    d = all_boxes[:, :2] - slot.box[:2]
    near = d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] <= slot.radius_m * slot.radius_m
    ids = None
    if with_ids:
        every_id = [vid for other in others for vid in other.body_ids]
        ids = [vid for vid, seen in zip(every_id, near, strict=True) if seen]
    return (all_boxes[near], np.concatenate(speeds)[near],
            np.concatenate(classes).astype(object)[near], np.array(owners, dtype=object)[near],
            ids)
