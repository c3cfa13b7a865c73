"""What one step of the world shows the car: plain numpy arrays, no simulator.

A box is a row ``[cx_m, cy_m, yaw_rad, length_m, width_m]`` (body centre,
heading counter-clockwise from +x, full length and width).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scenarios.road import RoadGeometry
from scenarios.spec import ScenarioSpec

NO_BOXES = np.zeros((0, 5))


@dataclass(frozen=True)
class Snapshot:
    t_s: float
    traffic_boxes: np.ndarray  # (N, 5) moving vehicles other than the ego
    obstacle_boxes: np.ndarray  # (K, 5) the spec's stationary obstacles, in spec order
    traffic_speeds_mps: np.ndarray  # (N,) speeds of the traffic boxes, along their headings


def obstacle_boxes(spec: ScenarioSpec, road: RoadGeometry) -> np.ndarray:
    """The exact boxes of the spec's obstacles, lateral offsets included."""
    if not spec.obstacles:
        return NO_BOXES
    s_m = np.array([o.position_m for o in spec.obstacles])
    d_m = np.array([road.lane_center_d_m(o.lane) + o.lateral_offset_m for o in spec.obstacles])
    xy = road.xy_at(s_m, d_m)
    sizes = np.array([o.size_m for o in spec.obstacles])
    return np.column_stack([xy, road.heading_at(s_m), sizes])
