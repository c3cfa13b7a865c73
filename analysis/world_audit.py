"""Is the world one world? Overlaps between bodies other than the ego, from a trace.

In a consistent world no two bodies overlap: SUMO's traffic sees every body where it
stands (``scenarios/traffic_model.py``). :func:`world_overlaps` counts the steps in
which a traffic vehicle overlaps another traffic vehicle or an obstacle, among the
bodies a trace holds (those within the sensing radius). It must read 0; anything
else is a world that made something up (traffic driving through an obstacle, or
through another car during a lane change).
"""

from __future__ import annotations

import numpy as np

from scenarios.boxes import as_boxes

#: a collision's ``collision_role`` (sdc.car.collision) as the report and the CLI say it
ROLE_TEXT = {"ran_into": "ran into", "was_hit": "was hit"}
#: bodies overlapping by less than this are touching, not through each other [m]
OVERLAP_TOLERANCE_M = 0.01


def _axes(yaw_rad: np.ndarray) -> np.ndarray:
    """(M, 2, 2): each box's length and width axes."""
    c, s = np.cos(yaw_rad), np.sin(yaw_rad)
    return np.stack([np.stack([c, s], -1), np.stack([-s, c], -1)], axis=-2)


def pairs_overlap(a: np.ndarray, b: np.ndarray, tolerance_m: float = OVERLAP_TOLERANCE_M
                  ) -> np.ndarray:
    """(M,) bool: does box ``a[k]`` overlap box ``b[k]`` by more than ``tolerance_m``
    along every separating axis (the separating-axis theorem, 4 axes a pair)?"""
    a, b = as_boxes(a), as_boxes(b)
    axes_a, axes_b = _axes(a[:, 2]), _axes(b[:, 2])
    test = np.concatenate([axes_a, axes_b], axis=1)  # (M, 4, 2)
    radius_a = np.einsum("mak,mk->ma", np.abs(test @ axes_a.transpose(0, 2, 1)), a[:, 3:5] / 2)
    radius_b = np.einsum("mak,mk->ma", np.abs(test @ axes_b.transpose(0, 2, 1)), b[:, 3:5] / 2)
    gap = np.abs(np.einsum("mad,md->ma", test, b[:, :2] - a[:, :2]))
    return np.all(gap < radius_a + radius_b - tolerance_m, axis=1)


def step_overlaps(traffic: np.ndarray, obstacles: np.ndarray) -> int:
    """Pairs of overlapping bodies in one step: traffic with traffic or an obstacle."""
    traffic, obstacles = as_boxes(traffic), as_boxes(obstacles)
    n = len(traffic)
    if n == 0:
        return 0
    bodies = np.vstack([traffic, obstacles])
    reach = np.hypot(bodies[:, 3], bodies[:, 4]) / 2
    d = bodies[:n, None, :2] - bodies[None, :, :2]
    near = (d[..., 0] ** 2 + d[..., 1] ** 2) < (reach[:n, None] + reach[None, :]) ** 2
    i, j = np.nonzero(np.triu(near, k=1))  # pairs with a traffic vehicle first
    if len(i) == 0:
        return 0
    return int(pairs_overlap(bodies[i], bodies[j]).sum())


def world_overlaps(traffic_rows: list[np.ndarray], obstacle_boxes: np.ndarray) -> int:
    """Steps of a trace (``traffic`` rows: N x 5 boxes, flattened) in which a traffic
    vehicle overlaps another one or an obstacle."""
    return sum(step_overlaps(np.asarray(row, float).reshape(-1, 5), obstacle_boxes) > 0
               for row in traffic_rows)
