"""A vehicle's body as SUMO's own lanes hold it, whatever angle SUMO reports for it.

Without the sublane model SUMO knows a vehicle by its lane, its lane position (the
front bumper), its lateral offset from the lane's centre (during a continuous lane
change) and its length: its car following, its lane changes and its junctions work
on that body, laid back from the front along the lane. The angle it reports is
drawn from the back to the front, plus a lane-change angle that grows without bound
at a crawl (``MSAbstractLaneChangeModel::calcAngleOffset``, SUMO 1.2x): a rigid box
at that angle spins about its front bumper, which no vehicle can, and a long one
through a junction's curve is one chord across it. :func:`along_lane` lays the body
along its lane's shape (and the lanes before it, where it reaches back into them) in
a few boxes, as SUMO holds it: the witness of whose an overlap is
(:mod:`sdc.run.world_witness`).
"""

from __future__ import annotations

import numpy as np

from scenarios.polyline_frame import PolylineFrame

#: boxes a body is laid in along its lane (a 16.5 m truck: 4 m each)
BODY_PIECES = 4


def along_lane(shape_xy: np.ndarray, lane_length_m: float, front_pos_m: float,
               lateral_m: float, length_m: float, width_m: float,
               pieces: int = BODY_PIECES, behind_xy: np.ndarray | None = None) -> np.ndarray:
    """(``pieces``, 5) boxes ``[cx, cy, yaw, length, width]`` of a body ``length_m`` x
    ``width_m`` whose front is at SUMO lane position ``front_pos_m`` of the lane of
    shape ``shape_xy`` (SUMO measures its positions on ``lane_length_m``, which may
    differ from the shape's length), ``lateral_m`` left of its centre line. Where the
    body reaches back beyond the lane's start it lies along ``behind_xy``, the shapes
    of the lanes before it joined (through the junction), else along the lane's first
    segment, extended."""
    frame = PolylineFrame(shape_xy)
    front_m = front_pos_m * float(frame.seg_len_m.sum()) / lane_length_m
    if behind_xy is not None and len(behind_xy) > 1 and front_m < length_m:
        frame = PolylineFrame(np.vstack([behind_xy, shape_xy]), min_segment_m=1e-9)
        front_m += float(np.hypot(*np.diff(behind_xy, axis=0).T).sum())
    stations_m = front_m - length_m * np.linspace(1.0, 0.0, pieces + 1)
    points = frame.points_off(stations_m, lateral_m)
    back, front = points[:-1], points[1:]
    delta = front - back
    return np.column_stack([(back + front) / 2, np.arctan2(delta[:, 1], delta[:, 0]),
                            np.hypot(delta[:, 0], delta[:, 1]), np.full(pieces, width_m)])
