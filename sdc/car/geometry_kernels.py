"""The per-step hot path in compiled code (``sdc/car/_geometry_kernels.c``), called like numpy.

Each function equals its numpy references bit for bit (the property tests in
``tests/test_kernels.py`` hold them to it): the lidar scan equals
:func:`sdc.car.geometry.ray_box_ranges` and :func:`sdc.car.geometry.ray_segment_ranges`
and their minimum; :func:`contacts` equals :func:`sdc.car.geometry.boxes_overlap`,
:func:`sdc.car.geometry.box_gap_m` and :func:`analysis.safety.time_to_collision_s`.
The numpy versions say plainly what is computed; these do it without numpy's
per-call cost, which dominates a step's few small arrays.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from scenarios.snapshot import NO_BOXES
from sdc.car import _geometry_kernels as _kernels


def _dense(array: np.ndarray) -> np.ndarray:
    """The array as C-contiguous float64 (itself, when it is already)."""
    return np.ascontiguousarray(array, np.float64)


def lidar_ranges_m(origin_xy: np.ndarray, yaw_rad: float, angles_rad: np.ndarray,
                   boxes: np.ndarray, segments: np.ndarray, max_range_m: float,
                   more_boxes: np.ndarray = NO_BOXES) -> np.ndarray:
    """Range along each ray (world angle ``yaw_rad + angles_rad``) to the nearest of
    ``boxes``, ``more_boxes`` and ``segments`` [m]; ``inf`` where nothing is hit
    within ``max_range_m``."""
    out = np.empty(len(angles_rad))
    _kernels.scan(float(origin_xy[0]), float(origin_xy[1]), yaw_rad, _dense(angles_rad),
                  _dense(boxes), _dense(more_boxes), _dense(segments), max_range_m, out)
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
    return Contacts(*_kernels.contacts(_dense(box), speed_mps, _dense(obstacle_boxes),
                                       _dense(traffic_boxes), _dense(traffic_speeds_mps)))
