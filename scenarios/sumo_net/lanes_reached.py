"""The lanes of other edges a body standing on a network reaches into: the opposite
lanes of a two-way street, over its centre line, or a lane of a road running beside.

SUMO holds a stopped vehicle inside the one lane it stands in, and its traffic sees
nothing else of it; the lanes of the body's own edge beside it are found along the
route (:func:`scenarios.sumo.routes_xml.lanes_blocked`). These are the others, found by
the lanes' own shapes: where the body leaves traffic too little room to pass (the rule
of :func:`scenarios.scene.traffic_model.blocks_neighbour`), it stands there too.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from scenarios.scene import traffic_model
from scenarios.scene.boxes import box_corners
from scenarios.scene.polyline_frame import PolylineFrame
from scenarios.sumo_net.net_xml import NetFile, NetLane


class LaneReached(NamedTuple):
    """A lane a body blocks, and where along it (SUMO's metres) the body's front is,
    in that lane's direction of travel."""

    lane: NetLane
    front_pos_m: float


def lanes_reached(net: NetFile, box: np.ndarray, own_edge: str,
                  traffic_width_m: float) -> list[LaneReached]:
    """Each lane outside junctions open to cars, of an edge other than ``own_edge``,
    that a body at ``box`` (cx, cy, yaw, length, width) reaches into so far that
    traffic ``traffic_width_m`` wide at that lane's centre has under
    :data:`~scenarios.scene.traffic_model.PASS_CLEARANCE_M` beside it."""
    corners = box_corners(box)[0]
    radius_m = float(np.hypot(box[3], box[4])) / 2
    centre = np.asarray(box[:2], float)
    reached = []
    for lane in net.normal_lanes():
        if lane.edge == own_edge or not _near(lane, centre, radius_m):
            continue
        frame = PolylineFrame(lane.shape_xy, min_segment_m=1e-9)
        s_m, d_m, _ = frame.project(corners)
        half_m = lane.width_m / 2
        if s_m.max() < 0 or s_m.min() > lane.length_m:
            continue  # beside its ends: another lane's
        lo_m, hi_m = float(d_m.min()), float(d_m.max())
        # reaching in from whichever side its centre is on (all of it, when it
        # stands across the lane's centre)
        reach_m = half_m - lo_m if lo_m + hi_m > 0 else hi_m + half_m
        if traffic_model.blocks_neighbour(reach_m, lane.width_m, traffic_width_m):
            front_m = min(max(float(s_m.max()), 0.0), lane.length_m)
            reached.append(LaneReached(lane, front_m * lane.sumo_length_m / lane.length_m))
    return reached


def _near(lane: NetLane, centre: np.ndarray, radius_m: float) -> bool:
    """Could a body of ``radius_m`` about ``centre`` touch the lane (its shape's
    bounds, grown by half its width)?"""
    grow_m = radius_m + lane.width_m / 2
    lo, hi = lane.shape_xy.min(axis=0) - grow_m, lane.shape_xy.max(axis=0) + grow_m
    return bool(np.all(centre >= lo) and np.all(centre <= hi))
