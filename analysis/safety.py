"""Safety margins of a run: the closest approach to the road edge (the time to
collision is the car's, recorded in the trace: ``sdc.car.geometry.time_to_collision_s``).

Plain numpy on boxes ``[cx_m, cy_m, yaw_rad, length_m, width_m]``; no simulator.
"""

from __future__ import annotations

import numpy as np

from scenarios.boxes import box_corners
from scenarios.road_geometry import RoadGeometry


def road_edge_gaps_m(body_boxes: np.ndarray, road: RoadGeometry) -> np.ndarray:
    """Per box, the distance from its outermost corner to the nearer road edge [m]
    (negative beyond it; ``nan`` while no corner is alongside the road)."""
    corners = box_corners(body_boxes)  # (N, 4, 2)
    gaps = road.edge_gaps_m(corners.reshape(-1, 2)).reshape(-1, 4).min(axis=1)
    return np.where(np.isposinf(gaps), np.nan, gaps)
