"""The per-step hot path in compiled code (``sdc/_kernels.c``), called like numpy.

Each function equals its numpy reference bit for bit (the property tests in
``tests/test_kernels.py`` hold them to it): the lidar scan equals
:func:`sdc.geometry.ray_box_ranges` and :func:`sdc.geometry.ray_segment_ranges`
and their minimum, :func:`first_overlap` the first true of
:func:`sdc.geometry.boxes_overlap`, :func:`box_gap_m` and
:func:`time_to_collision_s` their namesakes in :mod:`sdc.geometry` and
:mod:`analysis.safety`. The numpy versions say plainly what is computed; these
do it without numpy's per-call cost, which dominates a step's few small arrays.
"""

from __future__ import annotations

import numpy as np

from sdc import _kernels


def _rows(array: np.ndarray, columns: int) -> np.ndarray:
    return np.ascontiguousarray(array, dtype=np.float64).reshape(-1, columns)


def lidar_ranges_m(origin_xy: np.ndarray, angles_rad: np.ndarray, boxes: np.ndarray,
                   segments: np.ndarray, max_range_m: float) -> np.ndarray:
    """Range along each ray (world angles) to the nearest box or segment [m];
    ``inf`` where nothing is hit within ``max_range_m``."""
    angles = np.ascontiguousarray(angles_rad, dtype=np.float64).reshape(-1)
    out = np.empty(len(angles))
    _kernels.scan(float(origin_xy[0]), float(origin_xy[1]), angles, _rows(boxes, 5),
                  _rows(segments, 4), float(max_range_m), out)
    return out


def first_overlap(box: np.ndarray, boxes: np.ndarray) -> int:
    """Index of the first of ``boxes`` that ``box`` overlaps (touching counts), or -1."""
    return _kernels.first_overlap(_rows(box, 5), _rows(boxes, 5))


def box_gap_m(box: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """Distance between the outline of ``box`` and each of ``boxes`` [m], 0 where
    they overlap (see :func:`sdc.geometry.box_gap_m`)."""
    boxes = _rows(boxes, 5)
    out = np.empty(len(boxes))
    _kernels.gaps(_rows(box, 5), boxes, out)
    return out


def time_to_collision_s(ego_box: np.ndarray, ego_speed_mps: float, boxes: np.ndarray,
                        speeds_mps: np.ndarray) -> float:
    """See :func:`analysis.safety.time_to_collision_s`."""
    return _kernels.ttc(_rows(ego_box, 5), float(ego_speed_mps), _rows(boxes, 5),
                        np.ascontiguousarray(speeds_mps, dtype=np.float64).reshape(-1))
