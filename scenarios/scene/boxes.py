"""Oriented boxes, the world's one shape: every vehicle, obstacle and the ego body is a
row ``[cx_m, cy_m, yaw_rad, length_m, width_m]`` (centre, heading of the length axis
counter-clockwise from +x, full length and width); a set of them is an ``(N, 5)`` array.
"""

from __future__ import annotations

import math

import numpy as np

# Local corner signs (length, width) in the order front-left, rear-left, rear-right, front-right.
_CORNER_SIGNS = np.array([[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]])


def as_boxes(boxes: np.ndarray) -> np.ndarray:
    """``boxes`` as an (N, 5) float64 array (one box becomes (1, 5))."""
    return np.asarray(boxes, dtype=np.float64).reshape(-1, 5)


def box_corners(boxes: np.ndarray) -> np.ndarray:
    """Corners of oriented boxes.

    boxes: (N, 5) ``[cx_m, cy_m, yaw_rad, length_m, width_m]``.
    Returns (N, 4, 2) corner positions in metres, counter-clockwise:
    front-left, rear-left, rear-right, front-right.
    """
    b = as_boxes(boxes)
    cos_yaw, sin_yaw = np.cos(b[:, 2]), np.sin(b[:, 2])
    half_len_m = 0.5 * b[:, 3, None] * _CORNER_SIGNS[None, :, 0]  # (N, 4)
    half_wid_m = 0.5 * b[:, 4, None] * _CORNER_SIGNS[None, :, 1]
    x_m = b[:, 0, None] + cos_yaw[:, None] * half_len_m - sin_yaw[:, None] * half_wid_m
    y_m = b[:, 1, None] + sin_yaw[:, None] * half_len_m + cos_yaw[:, None] * half_wid_m
    return np.stack([x_m, y_m], axis=-1)


def one_box_corners(box: np.ndarray) -> np.ndarray:
    """:func:`box_corners` of a single box ``(5,)``, as (4, 2), bit for bit, in
    scalar arithmetic (a step needs the ego's corners; numpy's broadcasting costs
    more than the arithmetic there)."""
    cx, cy, yaw, length, width = np.asarray(box, dtype=float).tolist()
    c, s = math.cos(yaw), math.sin(yaw)
    half_len, half_wid = 0.5 * length, 0.5 * width
    return np.array([
        [cx + c * half_len - s * half_wid, cy + s * half_len + c * half_wid],
        [cx + c * -half_len - s * half_wid, cy + s * -half_len + c * half_wid],
        [cx + c * -half_len - s * -half_wid, cy + s * -half_len + c * -half_wid],
        [cx + c * half_len - s * -half_wid, cy + s * half_len + c * -half_wid],
    ])
