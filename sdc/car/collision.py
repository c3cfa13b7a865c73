"""Our own collision test: the ego's body box against obstacles, traffic and the
road edges, every step (SUMO does not see an ego that straddles two lanes)."""

from __future__ import annotations

import numpy as np

from scenarios.road_geometry import RoadGeometry
from sdc.car.geometry import one_box_corners
from sdc.car.geometry_kernels import Contacts

OBSTACLE, VEHICLE, ROAD_EDGE = "obstacle", "vehicle", "road_edge"


def collision_with(ego_box: np.ndarray, contacts: Contacts, road: RoadGeometry) -> str | None:
    """What the ego touches (``obstacle``, ``vehicle``, ``road_edge``) or ``None``,
    given its box's ``contacts`` with the obstacles and traffic.

    A body corner off the road (beyond either edge, while alongside it; off the
    drivable area of a network) counts as a road-edge collision.
    """
    if contacts.obstacle >= 0:
        return OBSTACLE
    if contacts.vehicle >= 0:
        return VEHICLE
    if road.off_road(one_box_corners(ego_box)).any():
        return ROAD_EDGE
    return None
