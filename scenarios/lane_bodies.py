"""A vehicle's body as SUMO's own lanes hold it, whatever angle SUMO reports for it.

Without the sublane model SUMO knows a vehicle by its lane, its lane position (the
front bumper), its lateral offset from the lane's centre (during a continuous lane
change) and its length: its car following, its lane changes and its junctions work
on that body, laid back from the front along the lane. The angle it reports is
drawn from the back to the front, plus a lane-change angle that grows without bound
at a crawl (``MSAbstractLaneChangeModel::calcAngleOffset``, SUMO 1.2x): a rigid box
at that angle spins about its front bumper, which no vehicle can. :func:`along_lane`
lays the body along the lane's shape in a few boxes, as SUMO holds it: the witness
of whose an overlap is (:mod:`sdc.run.world_witness`).
"""

from __future__ import annotations

import numpy as np

from scenarios.polyline_frame import PolylineFrame

#: boxes a body is laid in along its lane (a 16.5 m truck: 4 m each)
BODY_PIECES = 4


def along_lane(shape_xy: np.ndarray, lane_length_m: float, front_pos_m: float,
               lateral_m: float, length_m: float, width_m: float,
               pieces: int = BODY_PIECES) -> np.ndarray:
    """(``pieces``, 5) boxes ``[cx, cy, yaw, length, width]`` of a body ``length_m`` x
    ``width_m`` whose front is at SUMO lane position ``front_pos_m`` of the lane of
    shape ``shape_xy`` (SUMO measures its positions on ``lane_length_m``, which may
    differ from the shape's length), ``lateral_m`` left of its centre line. Where the
    body reaches back beyond the lane's start it lies along its first segment,
    extended (SUMO's own lane before it is not looked up)."""
    frame = PolylineFrame(shape_xy)
    scale = float(frame.seg_len_m.sum()) / lane_length_m
    stations_m = (front_pos_m - length_m * np.linspace(1.0, 0.0, pieces + 1)) * scale
    points = frame.points_off(stations_m, lateral_m)
    back, front = points[:-1], points[1:]
    delta = front - back
    return np.column_stack([(back + front) / 2, np.arctan2(delta[:, 1], delta[:, 0]),
                            np.hypot(delta[:, 0], delta[:, 1]), np.full(pieces, width_m)])
