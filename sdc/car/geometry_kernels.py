"""The car's per-step geometry, called like numpy: compiled (``sdc/car/_geometry_kernels.c``)
where it was built, else its numpy twins below, chosen once at import
(:mod:`scenarios.scene.compiled_kernels`; ``SDC_KERNELS=numpy`` forces the twins).

The twins take the compiled functions' arguments and compose the numpy functions
of :mod:`sdc.car.geometry`: the lidar scan is :func:`~sdc.car.geometry.ray_box_ranges`
and :func:`~sdc.car.geometry.ray_segment_ranges` and their minimum; a step's
contacts and conflicts along the road (:func:`step`) are the contacts
(:func:`~sdc.car.geometry.boxes_overlap`, :func:`~sdc.car.geometry.box_gap_m`), the
bodies placed in the road frame (``place_numpy`` of :mod:`scenarios.scene.road_kernels`)
and their conflicts (:func:`~sdc.car.geometry.first_contact_s`,
:func:`~sdc.car.geometry.leader_measures`). Both paths agree bit for bit
(``tests/test_kernels.py``); the compiled one avoids numpy's per-call cost, which
dominates a step's few small arrays.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from scenarios.scene.compiled_kernels import COMPILED, NUMPY, compiled_extension
from scenarios.scene.road_geometry import RoadGeometry
from scenarios.scene.road_kernels import place_numpy
from scenarios.scene.snapshot import NO_BOXES
from sdc.car.geometry import (
    box_gap_m,
    boxes_overlap,
    first_contact_s,
    leader_measures,
    ray_box_ranges,
    ray_segment_ranges,
)


def scan_numpy(origin_x_m: float, origin_y_m: float, yaw_rad: float, angles_rad: np.ndarray,
               boxes: np.ndarray, more_boxes: np.ndarray, segments: np.ndarray,
               max_range_m: float, out: np.ndarray) -> None:
    """Into ``out``: the range along each ray of world angle ``yaw_rad + angles_rad`` to
    the nearest of ``boxes``, ``more_boxes`` and ``segments``, inf beyond ``max_range_m``."""
    origin_m, world_rad = np.array([origin_x_m, origin_y_m]), yaw_rad + angles_rad
    box_m = ray_box_ranges(origin_m, world_rad, np.vstack([boxes, more_boxes]), max_range_m)
    segment_m = ray_segment_ranges(origin_m, world_rad, segments, max_range_m)
    out[:] = np.where(box_m <= segment_m, box_m, segment_m)  # the box of equals, as in C


def _first(mask: np.ndarray) -> int:
    return int(np.argmax(mask)) if mask.any() else -1


def contacts_numpy(box: np.ndarray, obstacle_boxes: np.ndarray,
                   traffic_boxes: np.ndarray) -> tuple[int, int, float]:
    """The fields of :class:`Contacts`, one numpy question at a time."""
    return (_first(boxes_overlap(box, obstacle_boxes)), _first(boxes_overlap(box, traffic_boxes)),
            float(np.min(box_gap_m(box, obstacle_boxes), initial=np.inf)))


def conflicts_numpy(box: np.ndarray, velocity_mps: np.ndarray, boxes: np.ndarray,
                    velocities_mps: np.ndarray) -> tuple[float, float, float]:
    """The fields of :class:`Conflicts`, one numpy question at a time."""
    contact_s = float(np.min(first_contact_s(box, velocity_mps, boxes, velocities_mps),
                             initial=np.inf))
    along_s, drac, headway = leader_measures(box, velocity_mps, boxes, velocities_mps)
    return (contact_s if contact_s <= along_s else along_s), drac, headway


def velocities_mps(boxes: np.ndarray, speeds_mps: np.ndarray) -> np.ndarray:
    """(N, 2) world velocities of boxes moving along their headings [m/s]."""
    return np.column_stack([speeds_mps * np.cos(boxes[:, 2]), speeds_mps * np.sin(boxes[:, 2])])


def step_numpy(box: np.ndarray, speed_mps: float, obstacle_boxes: np.ndarray,
               traffic_boxes: np.ndarray, traffic_speeds_mps: np.ndarray, *polyline_and_frame
               ) -> tuple[int, int, float, float, float, float]:
    """The fields of :class:`Contacts` and :class:`Conflicts` of a step (:func:`step`),
    one numpy question at a time: the contacts, the bodies placed in the road frame
    (``place_numpy`` of :mod:`scenarios.scene.road_kernels`), their conflicts, 0 on contact
    and the world frame's first contact where the unrolled boxes touch but the
    world's do not. ``polyline_and_frame``: the road's polyline (starts, directions,
    lengths, start_s, headings), its curvature and the ego lane's scale."""
    touching = contacts_numpy(box, obstacle_boxes, traffic_boxes)
    n = 1 + len(obstacle_boxes) + len(traffic_boxes)
    if n == 1:
        return (*touching, np.inf, 0.0, np.inf)
    placed, velocity = np.empty((n, 5)), np.empty((n, 2))
    place_numpy(box, speed_mps, obstacle_boxes, traffic_boxes, traffic_speeds_mps,
                *polyline_and_frame, placed, velocity)
    ttc_s, drac, headway = conflicts_numpy(placed[0], velocity[0], placed[1:], velocity[1:])
    if touching[0] >= 0 or touching[1] >= 0:
        ttc_s = 0.0
    elif ttc_s == 0.0:  # unrolled they touch, in the world they do not
        boxes = np.vstack([obstacle_boxes, traffic_boxes])
        speeds = np.concatenate([np.zeros(len(obstacle_boxes)), traffic_speeds_mps])
        world = velocities_mps(np.vstack([box[None, :], boxes]),
                               np.concatenate([[speed_mps], speeds]))
        ttc_s = float(np.min(first_contact_s(box, world[0], boxes, world[1:]),
                             initial=np.inf))
    return (*touching, ttc_s, drac, headway)


_compiled = compiled_extension("sdc.car._geometry_kernels")
#: which kernels run: "compiled" or "numpy"
KERNELS = NUMPY if _compiled is None else COMPILED
_scan = scan_numpy if _compiled is None else _compiled.scan
_step = step_numpy if _compiled is None else _compiled.step


def _always(*args) -> bool:
    return True


#: ``(traffic, obstacles, people, owners, tolerance_m) -> bool``: may two bodies other
#: than the ego overlap by more than ``tolerance_m``? A gate that errs only to True
#: (the in-run audit, :mod:`sdc.run.world_witness`, asks the exact question after it):
#: compiled, a pass over the pairs; else always True. ``traffic``, ``obstacles``: (N,
#: 5), (K, 5) float64 boxes; ``people``: (N + K,) 1.0 for a person, or None (not known:
#: no pair of two persons is left out); ``owners``: (N,) the body each traffic box is
#: of, or None (each its own)
bodies_may_overlap = _always if _compiled is None else _compiled.bodies_may_overlap


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
    _scan(float(origin_xy[0]), float(origin_xy[1]), yaw_rad, _dense(angles_rad),
          _dense(boxes), _dense(more_boxes), _dense(segments), max_range_m, out)
    return out


class Contacts(NamedTuple):
    """What the ego's box meets at one step."""

    obstacle: int  # index of the first obstacle it overlaps (touching counts), -1: none
    vehicle: int  # the same for the traffic
    obstacle_gap_m: float  # its outline's distance to the nearest obstacle, inf: none


class Conflicts(NamedTuple):
    """How close the ego is to a crash with the boxes around it, at constant velocities."""

    ttc_s: float  # time until it first touches any of them, 0: touching, inf: never
    drac_mps2: float  # deceleration it needs to avoid the leaders ahead of it, 0: none
    headway_s: float  # gap to the nearest leader over its speed, inf: no leader


def step(box: np.ndarray, speed_mps: float, obstacle_boxes: np.ndarray,
         traffic_boxes: np.ndarray, traffic_speeds_mps: np.ndarray, road: RoadGeometry,
         lane_scale: float) -> tuple[Contacts, Conflicts]:
    """The ego's :class:`Contacts` and its :class:`Conflicts` measured along the road,
    in one pass (``sdc.car.road_frame`` says how): the obstacles stand still, the
    traffic moves at its speeds along its headings; ``lane_scale`` is the ego lane's
    length per metre of the road's centre line."""
    found = _step(_dense(box), speed_mps, _dense(obstacle_boxes), _dense(traffic_boxes),
                  _dense(traffic_speeds_mps), *road.polyline, road.curvature_1pm, lane_scale)
    return Contacts(*found[:3]), Conflicts(*found[3:])
