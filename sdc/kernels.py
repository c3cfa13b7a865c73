"""The per-step hot path in compiled code (``sdc/_kernels.c``), called like numpy.

Each function equals its numpy references bit for bit (the property tests in
``tests/test_kernels.py`` hold them to it): the lidar scan equals
:func:`sdc.geometry.ray_box_ranges` and :func:`sdc.geometry.ray_segment_ranges`
and their minimum; :func:`contacts` equals :func:`sdc.geometry.boxes_overlap`,
:func:`sdc.geometry.box_gap_m` and :func:`analysis.safety.time_to_collision_s`.
The numpy versions say plainly what is computed; these do it without numpy's
per-call cost, which dominates a step's few small arrays.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from scenarios.snapshot import NO_BOXES
from sdc import _kernels


def _rows(array: np.ndarray, columns: int) -> np.ndarray:
    return np.ascontiguousarray(array, dtype=np.float64).reshape(-1, columns)


def lidar_ranges_m(origin_xy: np.ndarray, yaw_rad: float, angles_rad: np.ndarray,
                   boxes: np.ndarray, segments: np.ndarray, max_range_m: float,
                   more_boxes: np.ndarray = NO_BOXES) -> np.ndarray:
    """Range along each ray (world angle ``yaw_rad + angles_rad``) to the nearest of
    ``boxes``, ``more_boxes`` and ``segments`` [m]; ``inf`` where nothing is hit
    within ``max_range_m``."""
    angles = np.ascontiguousarray(angles_rad, dtype=np.float64).reshape(-1)
    out = np.empty(len(angles))
    _kernels.scan(float(origin_xy[0]), float(origin_xy[1]), float(yaw_rad), angles,
                  _rows(boxes, 5), _rows(more_boxes, 5), _rows(segments, 4),
                  float(max_range_m), out)
    return out


class Contacts(NamedTuple):
    """What the ego's box meets at one step."""

    obstacle: int  # index of the first obstacle it overlaps (touching counts), -1: none
    vehicle: int  # the same for the traffic
    obstacle_gap_m: float  # its outline's distance to the nearest obstacle, inf: none
    ttc_s: float  # constant-velocity time to collision with an obstacle or a vehicle


def contacts(box: np.ndarray, speed_mps: float, obstacle_boxes: np.ndarray,
             traffic_boxes: np.ndarray, traffic_speeds_mps: np.ndarray) -> Contacts:
    """The ego's overlaps, obstacle gap and time to collision in one pass; obstacles
    stand still, traffic moves at its speeds along its headings."""
    return Contacts(*_kernels.contacts(
        _rows(box, 5), float(speed_mps), _rows(obstacle_boxes, 5), _rows(traffic_boxes, 5),
        np.ascontiguousarray(traffic_speeds_mps, dtype=np.float64).reshape(-1)))
