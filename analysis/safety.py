"""Safety margins of a run: time-to-collision and the closest approach to the road edge.

Plain numpy on boxes ``[cx_m, cy_m, yaw_rad, length_m, width_m]``; no simulator.
"""

from __future__ import annotations

import math

import numpy as np

from scenarios.boxes import box_corners
from scenarios.road_geometry import RoadGeometry


def time_to_collision_s(ego_box: np.ndarray, ego_speed_mps: float, boxes: np.ndarray,
                        speeds_mps: np.ndarray) -> float:
    """Time until the ego reaches the nearest object in its path at constant velocities [s].

    In the ego's frame (x along its heading), an object is in the path when its
    lateral extent overlaps the ego's and it lies ahead of the ego's front. The
    ego closes in at ``ego_speed - speed * cos(relative heading)``; the TTC is
    the longitudinal gap over that closing speed, ``inf`` when nothing in the
    path is being closed in on, 0 when an object in the path already touches.
    """
    if len(boxes) == 0:
        return math.inf
    cx, cy, yaw, length, width = ego_box
    cos_yaw, sin_yaw = math.cos(yaw), math.sin(yaw)
    dx, dy = boxes[:, 0] - cx, boxes[:, 1] - cy
    ahead_m = dx * cos_yaw + dy * sin_yaw
    lateral_m = -dx * sin_yaw + dy * cos_yaw
    rel_yaw = boxes[:, 2] - yaw
    half_len_m, half_wid_m = boxes[:, 3] / 2, boxes[:, 4] / 2
    extent_x_m = np.abs(half_len_m * np.cos(rel_yaw)) + np.abs(half_wid_m * np.sin(rel_yaw))
    extent_y_m = np.abs(half_len_m * np.sin(rel_yaw)) + np.abs(half_wid_m * np.cos(rel_yaw))
    gap_m = ahead_m - extent_x_m - length / 2
    in_path = (np.abs(lateral_m) < extent_y_m + width / 2) & (ahead_m + extent_x_m > length / 2)
    closing_mps = ego_speed_mps - speeds_mps * np.cos(rel_yaw)
    with np.errstate(over="ignore"):  # closing at a crawl: inf, which is right
        ttc = np.where(gap_m <= 0, 0.0, gap_m / np.where(closing_mps > 0, closing_mps, np.nan))
    ttc = ttc[in_path & ((gap_m <= 0) | (closing_mps > 0))]
    return float(ttc.min()) if ttc.size else math.inf


def road_edge_gaps_m(body_boxes: np.ndarray, road: RoadGeometry) -> np.ndarray:
    """Per box, the distance from its outermost corner to the nearer road edge [m]
    (negative beyond it; ``nan`` while no corner is alongside the road)."""
    corners = box_corners(body_boxes)  # (N, 4, 2)
    gaps = road.edge_gaps_m(corners.reshape(-1, 2)).reshape(-1, 4).min(axis=1)
    return np.where(np.isposinf(gaps), np.nan, gaps)
