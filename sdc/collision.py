"""Our own collision test: the ego's body box against obstacles, traffic and the
road edges, every step (SUMO does not see an ego that straddles two lanes)."""

from __future__ import annotations

import numpy as np

from scenarios.road import RoadGeometry
from scenarios.snapshot import Snapshot
from sdc.geometry import box_corners, boxes_overlap, boxes_within_m

OBSTACLE, VEHICLE, ROAD_EDGE = "obstacle", "vehicle", "road_edge"


def collision_with(ego_box: np.ndarray, snapshot: Snapshot, road: RoadGeometry) -> str | None:
    """What the ego touches (``obstacle``, ``vehicle``, ``road_edge``) or ``None``.

    A body corner off the road (beyond either edge, while alongside it; off the
    drivable area of a network) counts as a road-edge collision.
    """
    ego_half_diag_m = 0.5 * float(np.hypot(ego_box[3], ego_box[4]))
    for kind, boxes in ((OBSTACLE, snapshot.obstacle_boxes), (VEHICLE, snapshot.traffic_boxes)):
        near = boxes[boxes_within_m(ego_box[:2], boxes, ego_half_diag_m)]
        if len(near) and boxes_overlap(ego_box, near).any():
            return kind
    if road.off_road(box_corners(ego_box[None])[0]).any():
        return ROAD_EDGE
    return None
