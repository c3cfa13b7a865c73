"""Vectorised 2D geometry for the lidar, the gap checks and the time to collision (numpy,
float64).

Conventions
-----------
* ISO 8855 world frame: x forward, y left, angles in radians counter-clockwise from +x.
* An oriented box is a row ``[cx_m, cy_m, yaw_rad, length_m, width_m]``: centre, heading of
  its length axis, full length and full width. A set of boxes is an ``(N, 5)`` array.
* A segment set is an ``(S, 4)`` array ``[x0_m, y0_m, x1_m, y1_m]``.
* Corners come in counter-clockwise order: front-left, rear-left, rear-right, front-right
  (front = +length axis, left = +width axis).
* Boxes are closed sets: touching boxes overlap (gap 0.0), an origin on a box's outline is
  inside it (range 0.0), and a ray running exactly along a box edge hits that box.
* Ranges are distances along the ray in metres; ``np.inf`` means no hit within
  ``max_range_m`` (a hit exactly at ``max_range_m`` counts).
* Of equal values the first wins (0.0 against -0.0: the nearer one's sign), as in the
  compiled kernels (numpy's own ``minimum``, ``maximum`` and ``min`` keep the second).

No function loops in Python over beams, boxes or segments.
"""

from __future__ import annotations

import math

import numpy as np

from scenarios.scene.boxes import as_boxes, box_corners, one_box_corners

__all__ = ["box_corners", "one_box_corners"]  # the world's boxes, re-exported beside the kernels

def box_edges(boxes: np.ndarray) -> np.ndarray:
    """Outline of oriented boxes as segments: (N, 5) boxes -> (N, 4, 4) ``[x0, y0, x1, y1]`` (m).

    Edge k runs from corner k to corner k+1 (counter-clockwise, see :func:`box_corners`).
    """
    return _edges_from_corners(box_corners(boxes))


def _edges_from_corners(corners_m: np.ndarray) -> np.ndarray:
    return np.concatenate([corners_m, np.roll(corners_m, -1, axis=-2)], axis=-1)


def _lesser(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Elementwise minimum, ``a`` on ties."""
    return np.where(a <= b, a, b)


def _greater(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Elementwise maximum, ``a`` on ties."""
    return np.where(a >= b, a, b)


def _nearest(ranges_m: np.ndarray) -> np.ndarray:
    """Minimum along the last axis, the first of equals; ``inf`` over none."""
    if ranges_m.shape[-1] == 0:
        return np.full(ranges_m.shape[:-1], np.inf)
    first = np.argmin(ranges_m, axis=-1)[..., None]
    return np.take_along_axis(ranges_m, first, axis=-1)[..., 0]


def _slab(origin_m: np.ndarray, dir_m: np.ndarray, half_m: np.ndarray):
    """Entry/exit ray parameters of one slab ``|s| <= half_m`` (all arrays broadcast (B, N))."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # fixed up below
        t_a = (-half_m - origin_m) / dir_m
        t_b = (half_m - origin_m) / dir_m
    parallel = dir_m == 0.0
    inside = np.abs(origin_m) <= half_m
    t_in = np.where(parallel, np.where(inside, -np.inf, np.inf), _lesser(t_a, t_b))
    t_out = np.where(parallel, np.where(inside, np.inf, -np.inf), _greater(t_a, t_b))
    return t_in, t_out


def _slab_ranges(local_x_m, local_y_m, local_angle_rad, half_len_m, half_wid_m) -> np.ndarray:
    """Entry range of rays into boxes, each given in its box's frame (arrays broadcast);
    ``inf`` where a ray misses, 0 where it starts inside (outline included)."""
    tx_in, tx_out = _slab(local_x_m, np.cos(local_angle_rad), half_len_m)
    ty_in, ty_out = _slab(local_y_m, np.sin(local_angle_rad), half_wid_m)
    t_in, t_out = _greater(tx_in, ty_in), _lesser(tx_out, ty_out)
    hit = (t_in <= t_out) & (t_out >= 0.0)
    return np.where(hit, _greater(t_in, 0.0), np.inf)


def _origin_in_box_frames(origin_m: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    cos_yaw, sin_yaw = np.cos(b[:, 2]), np.sin(b[:, 2])
    rel_x_m, rel_y_m = origin_m[0] - b[:, 0], origin_m[1] - b[:, 1]
    return cos_yaw * rel_x_m + sin_yaw * rel_y_m, -sin_yaw * rel_x_m + cos_yaw * rel_y_m


def ray_box_ranges(
    origin_xy: np.ndarray, angles_rad: np.ndarray, boxes: np.ndarray, max_range_m: float
) -> np.ndarray:
    """Range from one origin to the nearest oriented box along each ray (slab method).

    origin_xy: (2,) ray origin in metres. angles_rad: (B,) world ray angles (CCW from +x).
    boxes: (N, 5) ``[cx_m, cy_m, yaw_rad, length_m, width_m]``. max_range_m: cut-off (m).
    Returns (B,) ranges in metres; ``np.inf`` where no box is hit within ``max_range_m``.
    A box containing the origin (outline included) gives 0.0 for every ray.
    """
    origin_m = np.asarray(origin_xy, dtype=np.float64).reshape(2)
    angles = np.atleast_1d(np.asarray(angles_rad, dtype=np.float64))
    b = as_boxes(boxes)
    local_x_m, local_y_m = _origin_in_box_frames(origin_m, b)
    range_m = _slab_ranges(local_x_m[None, :], local_y_m[None, :],
                           angles[:, None] - b[None, :, 2],  # (B, N); exact 0 stays exact
                           0.5 * b[None, :, 3], 0.5 * b[None, :, 4])
    nearest_m = _nearest(range_m)
    return np.where(nearest_m <= max_range_m, nearest_m, np.inf)


def ray_segment_ranges(
    origin_xy: np.ndarray, angles_rad: np.ndarray, segments: np.ndarray, max_range_m: float
) -> np.ndarray:
    """Range from one origin to the nearest segment along each ray.

    origin_xy: (2,) metres. angles_rad: (B,) world ray angles. segments: (S, 4)
    ``[x0, y0, x1, y1]`` metres. Segment end points count as hits; rays exactly parallel to a
    segment never hit it. Returns (B,) ranges in metres, ``np.inf`` beyond ``max_range_m``.
    """
    origin_m = np.asarray(origin_xy, dtype=np.float64).reshape(2)
    angles = np.atleast_1d(np.asarray(angles_rad, dtype=np.float64))
    seg = np.asarray(segments, dtype=np.float64).reshape(-1, 4)
    dir_x, dir_y = np.cos(angles)[:, None], np.sin(angles)[:, None]  # (B, 1)
    edge_x, edge_y = (seg[:, 2] - seg[:, 0])[None, :], (seg[:, 3] - seg[:, 1])[None, :]
    rel_x, rel_y = (seg[:, 0] - origin_m[0])[None, :], (seg[:, 1] - origin_m[1])[None, :]
    denom = dir_x * edge_y - dir_y * edge_x  # (B, S) cross(dir, edge)
    parallel = denom == 0.0
    safe_denom = np.where(parallel, 1.0, denom)
    with np.errstate(over="ignore"):  # near-parallel: |t|, |u| -> inf, which is a miss
        t_m = (rel_x * edge_y - rel_y * edge_x) / safe_denom  # along the ray
        u = (rel_x * dir_y - rel_y * dir_x) / safe_denom  # along the segment, 0..1
    hit = ~parallel & (t_m >= 0.0) & (u >= 0.0) & (u <= 1.0)
    nearest_m = _nearest(np.where(hit, t_m, np.inf))
    return np.where(nearest_m <= max_range_m, nearest_m, np.inf)


def boxes_overlap(box: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """Whether one box overlaps each of N boxes (separating-axis theorem, 4 axes).

    box: (5,), boxes: (N, 5), both ``[cx_m, cy_m, yaw_rad, length_m, width_m]``.
    Returns (N,) bool. Touching boxes (zero separation) count as overlapping.
    """
    a = as_boxes(box)[0]
    b = as_boxes(boxes)

    def axes(yaw_rad: np.ndarray) -> np.ndarray:  # (..., 2, 2): length axis, width axis
        c, s = np.cos(yaw_rad), np.sin(yaw_rad)
        return np.stack([np.stack([c, s], -1), np.stack([-s, c], -1)], axis=-2)

    axes_a, axes_b = axes(a[2]), axes(b[:, 2])  # (2, 2), (N, 2, 2)
    test_axes = np.concatenate([np.broadcast_to(axes_a, axes_b.shape), axes_b], axis=1)
    half_a_m, half_b_m = 0.5 * a[3:5], 0.5 * b[:, 3:5]  # (2,), (N, 2)
    # projected half-extent of a box on an axis = sum_k half_k * |own_axis_k . axis|
    radius_a_m = np.abs(test_axes @ axes_a.T) @ half_a_m  # (N, 4)
    radius_b_m = np.einsum("nak,nk->na", np.abs(test_axes @ axes_b.transpose(0, 2, 1)), half_b_m)
    centre_gap_m = np.abs(np.einsum("nad,nd->na", test_axes, b[:, :2] - a[:2]))
    return np.all(centre_gap_m <= radius_a_m + radius_b_m, axis=1)


def point_segment_distance(points: np.ndarray, segments: np.ndarray) -> np.ndarray:
    """Euclidean distance from each point to each segment.

    points: (K, 2) metres. segments: (S, 4) ``[x0, y0, x1, y1]`` metres (a zero-length
    segment is a point). Returns (K, S) distances in metres.
    """
    p = np.asarray(points, dtype=np.float64).reshape(-1, 2)[:, None, :]  # (K, 1, 2)
    seg = np.asarray(segments, dtype=np.float64).reshape(-1, 4)
    start, edge = seg[None, :, :2], (seg[:, 2:] - seg[:, :2])[None, :, :]  # (1, S, 2)
    edge_len2 = np.sum(edge * edge, axis=-1)
    proj = np.sum((p - start) * edge, axis=-1) / np.where(edge_len2 > 0.0, edge_len2, 1.0)
    t = np.clip(proj, 0.0, 1.0)[..., None]
    diff = p - (start + t * edge)
    return np.hypot(diff[..., 0], diff[..., 1])


def box_gap_m(box: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """Minimum Euclidean distance between one box outline and each of N box outlines.

    box: (5,), boxes: (N, 5) ``[cx_m, cy_m, yaw_rad, length_m, width_m]``.
    Returns (N,) gaps in metres, 0.0 where :func:`boxes_overlap` is true. For disjoint convex
    rectangles the minimum is attained at a corner of one box against an edge of the other.
    """
    a, b = as_boxes(box)[:1], as_boxes(boxes)
    n = b.shape[0]
    if n == 0:
        return np.zeros(0)
    corners_a_m, corners_b_m = box_corners(a)[0], box_corners(b)  # (4, 2), (N, 4, 2)
    edges_a_m, edges_b_m = _edges_from_corners(corners_a_m), _edges_from_corners(corners_b_m)
    a_to_b_m = point_segment_distance(corners_a_m, edges_b_m.reshape(-1, 4)).reshape(4, n, 4)
    b_to_a_m = point_segment_distance(corners_b_m.reshape(-1, 2), edges_a_m).reshape(n, 4, 4)
    gap_m = np.minimum(a_to_b_m.min(axis=(0, 2)), b_to_a_m.min(axis=(1, 2)))
    return np.where(boxes_overlap(box, boxes), 0.0, gap_m)


def _extents_m(box: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Half extents of boxes along the frame's x and y axes [m]."""
    c, s = np.cos(box[..., 2]), np.sin(box[..., 2])
    half_len_m, half_wid_m = 0.5 * box[..., 3], 0.5 * box[..., 4]
    return (np.abs(half_len_m * c) + np.abs(half_wid_m * s),
            np.abs(half_len_m * s) + np.abs(half_wid_m * c))


def first_contact_s(box: np.ndarray, velocity_mps: np.ndarray, boxes: np.ndarray,
                    velocities_mps: np.ndarray) -> np.ndarray:
    """When one box and each of N boxes first touch, all moving at constant velocities
    without turning [s]: the exact time for oriented boxes (separating axes swept in
    time), 0 where they overlap now, ``inf`` where they never touch.

    box: (5,), boxes: (N, 5) ``[cx_m, cy_m, yaw_rad, length_m, width_m]``;
    velocity_mps: (2,), velocities_mps: (N, 2) ``[vx, vy]`` in the boxes' frame.
    Two convex bodies in translation overlap exactly while their projections overlap
    on every one of the four axes of their sides: on each axis that is an interval of
    time (a slab), and they touch first at the latest entry, if it comes before the
    earliest exit and the exit is not past.
    """
    a, b = as_boxes(box)[0], as_boxes(boxes)
    if len(b) == 0:
        return np.zeros(0)
    w = np.asarray(velocities_mps, np.float64).reshape(-1, 2) - np.asarray(velocity_mps,
                                                                           np.float64)
    ca, sa, cb, sb = math.cos(a[2]), math.sin(a[2]), np.cos(b[:, 2]), np.sin(b[:, 2])
    px, py = b[:, 0] - a[0], b[:, 1] - a[1]
    t_in = t_out = None
    for nx, ny in ((ca, sa), (-sa, ca), (cb, sb), (-sb, cb)):  # the four side axes
        radius_m = (np.abs(nx * ca + ny * sa) * (0.5 * a[3])
                    + np.abs(nx * -sa + ny * ca) * (0.5 * a[4])
                    + (np.abs(nx * cb + ny * sb) * (0.5 * b[:, 3])
                       + np.abs(nx * -sb + ny * cb) * (0.5 * b[:, 4])))
        axis_in, axis_out = _slab(nx * px + ny * py, nx * w[:, 0] + ny * w[:, 1], radius_m)
        t_in = axis_in if t_in is None else _greater(t_in, axis_in)
        t_out = axis_out if t_out is None else _lesser(t_out, axis_out)
    touch = (t_in <= t_out) & (t_out >= 0.0)
    return np.where(touch, np.where(t_in > 0.0, t_in, 0.0), np.inf)


def leader_measures(box: np.ndarray, velocity_mps: np.ndarray, boxes: np.ndarray,
                    velocities_mps: np.ndarray) -> tuple[float, float, float]:
    """The time to collision along the x axis [s], the deceleration rate to avoid a
    crash (DRAC) [m/s^2] and the time headway [s] of a box following the boxes ahead
    of it along x (the road's direction, in the road frame), as SUMO's SSM device
    measures a follower and its leader along their lane.

    A box leads when its centre is ahead (larger x) and its y extent overlaps the
    follower's (the extents of the boxes' outlines on the axes). Its gap is the x
    distance between their facing extents; its closing speed the follower's x
    velocity minus its own. Over the leaders with a gap (> 0): the time to collision
    is the smallest ``gap / closing`` of those being closed in on (``inf``: none),
    DRAC the largest ``closing^2 / (2 gap)`` (0: none), the headway the smallest
    ``gap / follower's x velocity`` (``inf`` while it does not move ahead); a leader
    without a gap gives headway 0 and leaves contact to :func:`first_contact_s`.
    """
    a, b = as_boxes(box)[0], as_boxes(boxes)
    if len(b) == 0:
        return math.inf, 0.0, math.inf
    v = np.asarray(velocities_mps, np.float64).reshape(-1, 2)
    vx = float(velocity_mps[0])
    own_x_m, own_y_m = _extents_m(a)
    ext_x_m, ext_y_m = _extents_m(b)
    ahead_m = b[:, 0] - a[0]
    leads = (np.abs(b[:, 1] - a[1]) < ext_y_m + own_y_m) & (ahead_m > 0.0)
    gap_m = ahead_m - ext_x_m - own_x_m
    closing_mps = vx - v[:, 0]
    closes = leads & (gap_m > 0.0) & (closing_mps > 0.0)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # the masks pick
        ttc = np.where(closes, gap_m / closing_mps, np.inf)
        drac = np.where(closes, closing_mps * closing_mps / (2.0 * gap_m), 0.0)
        headway = np.where(gap_m > 0.0, gap_m / vx if vx > 0.0 else np.inf, 0.0)
    return (float(_nearest(ttc)), float(np.max(drac, initial=0.0)),
            float(np.min(np.where(leads, headway, np.inf), initial=np.inf)))
