"""The world's per-step questions: compiled (``scenarios/scene/_road_kernels.c``) where it
was built, else their numpy twins below, chosen once at import
(:mod:`scenarios.scene.compiled_kernels`; ``SDC_KERNELS=numpy`` forces the twins).

- :func:`frenet`: road coordinates ``(s, d)`` of points on a polyline and their
  distance to the nearer road edge (:meth:`scenarios.scene.road_geometry.RoadGeometry.to_frenet`);
- :func:`locate`: the same of one point, in plain floats;
- :func:`place_numpy`: boxes and their velocities in the road frame of a lane, in
  numpy only: the compiled placement is part of the car's step
  (``sdc.car.geometry_kernels.step``, through ``scenarios/scene/_polyline.h``);
- :func:`traffic`: SUMO's context subscription results as traffic boxes, speeds
  and vehicle classes (:meth:`scenarios.sumo.traffic_reading.TrafficReader.read`).

Each twin takes the compiled function's arguments, writes the same outputs and
computes in the same order (no fused multiply-adds), so the answers agree to the
last bit (``tests/test_road.py``, ``tests/test_traffic_scale.py``). In numpy a
step's few points cost more than in C: that is what the compiled code is for.
"""

from __future__ import annotations

import math

import numpy as np

from scenarios.scene.compiled_kernels import COMPILED, NUMPY, compiled_extension
from scenarios.scene.lane_bodies import LanePath


def _project(xy: np.ndarray, starts: np.ndarray, directions: np.ndarray, lengths: np.ndarray,
             start_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(s, d)`` of (K, 2) points: each on its nearest segment (the first of equals),
    the first segment extended backwards and the last one forwards."""
    return _project_on_segments(xy, starts, directions, lengths, start_s)[:2]


def _project_on_segments(xy: np.ndarray, starts: np.ndarray, directions: np.ndarray,
                         lengths: np.ndarray, start_s: np.ndarray):
    """:func:`_project`'s ``(s, d)`` and the index of each point's segment."""
    rel_x = xy[:, 0, None] - starts[None, :, 0]  # (K, S)
    rel_y = xy[:, 1, None] - starts[None, :, 1]
    dir_x, dir_y = directions[:, 0], directions[:, 1]
    along = rel_x * dir_x + rel_y * dir_y
    low, high = np.zeros(len(lengths)), lengths.copy()
    low[0], high[-1] = -np.inf, np.inf
    along = np.where(along > low, along, low)
    along = np.where(along < high, along, high)
    off_x = xy[:, 0, None] - (starts[None, :, 0] + along * dir_x)
    off_y = xy[:, 1, None] - (starts[None, :, 1] + along * dir_y)
    seg = np.argmin(off_x * off_x + off_y * off_y, axis=1)
    k = np.arange(len(xy))
    return (start_s[seg] + along[k, seg],
            dir_x[seg] * rel_y[k, seg] - dir_y[seg] * rel_x[k, seg], seg)


def frenet_numpy(xy: np.ndarray, starts: np.ndarray, directions: np.ndarray,
                 lengths: np.ndarray, start_s: np.ndarray, s_out: np.ndarray,
                 d_out: np.ndarray, half_width_m: float, length_m: float,
                 gaps_out: np.ndarray) -> None:
    """Into ``s_out``, ``d_out``: the road coordinates of (K, 2) points on the polyline of
    segments (``starts`` (S, 2), unit ``directions`` (S, 2), ``lengths`` (S,), ``start_s``
    (S,)); into ``gaps_out``: ``half_width_m - |d|`` where ``0 <= s <= length_m``, else inf."""
    s_m, d_m = _project(xy, starts, directions, lengths, start_s)
    s_out[:], d_out[:] = s_m, d_m
    gaps_out[:] = np.where((s_m >= 0.0) & (s_m <= length_m), half_width_m - np.abs(d_m), np.inf)


def locate_numpy(x_m: float, y_m: float, starts: np.ndarray, directions: np.ndarray,
                 lengths: np.ndarray, start_s: np.ndarray) -> tuple[float, float]:
    """``(s, d)`` of one point, as :func:`frenet_numpy` finds them."""
    s_m, d_m = _project(np.array([[x_m, y_m]]), starts, directions, lengths, start_s)
    return float(s_m[0]), float(d_m[0])


def place_numpy(ego: np.ndarray, ego_speed_mps: float, obstacles: np.ndarray,
                traffic: np.ndarray, traffic_speeds_mps: np.ndarray, starts: np.ndarray,
                directions: np.ndarray, lengths: np.ndarray, start_s: np.ndarray,
                headings_rad: np.ndarray, curvature_1pm: float, lane_scale: float,
                out_boxes: np.ndarray, out_velocities: np.ndarray) -> None:
    """Into ``out_boxes`` (1 + K + N, 5) and ``out_velocities`` (1 + K + N, 2): the ego,
    the K obstacles (standing still) and the N traffic boxes (at their speeds along
    their headings), in the road frame of a lane ``lane_scale`` times as long as the
    polyline: ``[s * lane_scale, d, yaw - the segment's heading, length, width]`` and
    ``[speed cos(yaw) * lane_scale / (1 - curvature d), speed sin(yaw)]`` (the
    factor only where the curvature is not 0)."""
    boxes = np.vstack([np.reshape(ego, (1, 5)), obstacles, traffic])
    speeds = np.concatenate([[ego_speed_mps], np.zeros(len(obstacles)), traffic_speeds_mps])
    s_m, d_m, seg = _project_on_segments(boxes[:, :2], starts, directions, lengths, start_s)
    yaw = boxes[:, 2] - headings_rad[seg]
    along = speeds * np.cos(yaw)
    if curvature_1pm != 0.0:
        along = along * (lane_scale / (1.0 - curvature_1pm * d_m))
    out_boxes[:] = np.column_stack([s_m * lane_scale, d_m, yaw, boxes[:, 3], boxes[:, 4]])
    out_velocities[:] = np.column_stack([along, speeds * np.sin(yaw)])


def traffic_numpy(nearby: dict, keys: tuple, ego_id: str, skip_prefix: str, sizes: dict,
                  lanes: dict, cx_m: float, cy_m: float, radius_m: float, tolerance_m: float,
                  stretch_min_m: float, boxes: np.ndarray, speeds_mps: np.ndarray,
                  kinds: np.ndarray, laid: np.ndarray) -> tuple[int, int]:
    """Into ``boxes``, ``speeds_mps`` and ``kinds``: the vehicles of ``nearby`` (id ->
    {position key: front bumper (x, y), angle key: SUMO degrees clockwise from north,
    speed key: m/s, lateral key: its offset from its lane's centre, lane position key,
    lane key: its lane's id}, ``keys`` = (position, angle, speed, lateral, lane
    position, lane)) other than ``ego_id`` and the ids starting with ``skip_prefix``,
    whose body centre by SUMO's angle lies within ``radius_m`` of (cx, cy), in the
    dict's order; a vehicle's length, width and class index (``kinds``) are
    ``sizes[its id]``, an id not there a ``KeyError`` of it.

    A box is ``[cx, cy, yaw, length, width]``: a person's by SUMO's angle (its yaw
    ``(90 - angle) * pi / 180``, its centre half a length behind its front), a
    vehicle's laid along its lane in one box where its lane is among ``lanes`` (lane
    id -> :attr:`scenarios.scene.lane_bodies.LanePath.flat`) and one box keeps it within
    ``tolerance_m`` (:meth:`scenarios.scene.lane_bodies.LanePath.body`). Into ``laid``: the
    index in ``nearby`` of each vehicle left to lay (in pieces, reaching back off its
    lane, or on a lane not among ``lanes``), -1 for the others. Returns how many boxes
    and how many are left to lay."""
    ids, rows, keep = _nearby_rows(nearby, keys, ego_id, skip_prefix, sizes, cx_m, cy_m,
                                   radius_m)
    count = int(np.count_nonzero(keep))
    boxes[:count] = rows[keep, :5]
    speeds_mps[:count] = rows[keep, 5]
    kinds[:count] = rows[keep, 6]
    place = {vid: k for k, vid in enumerate(nearby)}
    left = 0
    for row, k in enumerate(np.flatnonzero(keep).tolist()):
        box = _one_box(nearby[ids[k]], keys, lanes, float(rows[k, 3]), float(rows[k, 4]),
                       tolerance_m, stretch_min_m)
        if box is True:  # a person: SUMO's box
            laid[row] = -1.0
        elif box is None:
            laid[row] = place[ids[k]]
            left += 1
        else:
            boxes[row] = box
            laid[row] = -1.0
    return count, left


def _one_box(values: dict, keys: tuple, lanes: dict, length_m: float, width_m: float,
             tolerance_m: float, stretch_min_m: float):
    """:func:`traffic_numpy`'s laying of one vehicle: its one box, None if it is left
    to lay, True for a person (no lateral offset among its ``values``)."""
    lateral, lane_position, lane = keys[3:]
    if lateral not in values:
        return True
    flat = lanes.get(values[lane])
    pos_m = values[lane_position]
    if flat is None or pos_m - length_m < 0.0:
        return None
    path = LanePath.from_flat(flat)
    if not path.segments:
        return None
    body = path.body(pos_m, values[lateral], length_m, width_m, tolerance_m=tolerance_m,
                     stretch_min_m=stretch_min_m)
    return body[0] if len(body) == 1 else None


def traffic_ids(nearby: dict, keys: tuple, ego_id: str, skip_prefix: str, sizes: dict,
                cx_m: float, cy_m: float, radius_m: float) -> list[str]:
    """The ids of the vehicles :func:`traffic` reads from ``nearby``, in its order."""
    ids, _, keep = _nearby_rows(nearby, keys, ego_id, skip_prefix, sizes, cx_m, cy_m,
                                radius_m)
    return [vid for vid, kept in zip(ids, keep, strict=True) if kept]


def _nearby_rows(nearby: dict, keys: tuple, ego_id: str, skip_prefix: str, sizes: dict,
                 cx_m: float, cy_m: float, radius_m: float):
    """:func:`traffic_numpy`'s reading: the ids looked at, their rows ``[cx, cy, yaw,
    length, width, speed, class index]`` and which lie within the radius."""
    position, angle, speed = keys[:3]
    ids = [vid for vid in nearby if vid != ego_id and not vid.startswith(skip_prefix)]
    values = np.array([(*nearby[vid][position], nearby[vid][angle], nearby[vid][speed],
                        *sizes[vid]) for vid in ids], dtype=np.float64).reshape(-1, 7)
    yaw = (90.0 - values[:, 2]) * (math.pi / 180.0)
    length_m = values[:, 4]
    centre_x = values[:, 0] - length_m / 2 * np.cos(yaw)
    centre_y = values[:, 1] - length_m / 2 * np.sin(yaw)
    dx, dy = centre_x - cx_m, centre_y - cy_m
    keep = dx * dx + dy * dy <= radius_m * radius_m
    rows = np.column_stack([centre_x, centre_y, yaw, length_m, values[:, 5], values[:, 3],
                            values[:, 6]])
    return ids, rows, keep


_compiled = compiled_extension("scenarios.scene._road_kernels")
#: which kernels run: "compiled" or "numpy"
KERNELS = NUMPY if _compiled is None else COMPILED
frenet = frenet_numpy if _compiled is None else _compiled.frenet
locate = locate_numpy if _compiled is None else _compiled.locate
traffic = traffic_numpy if _compiled is None else _compiled.traffic
