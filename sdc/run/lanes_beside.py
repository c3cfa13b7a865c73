"""The lanes beside the car's own as a map gives them at each step: how far each
runs on ahead of the car in its direction (:class:`~sdc.car.controller_api.LanesBeside`),
from the road's stretches (:meth:`RoadGeometry.lanes_beside`)."""

from __future__ import annotations

import numpy as np

from sdc.car.controller_api import LanesBeside


def ahead_m(stretches: np.ndarray, s_m: float) -> float:
    """How far from ``s_m`` the stretch holding it runs on (0: none holds it)."""
    inside = (stretches[:, 0] <= s_m) & (s_m <= stretches[:, 1])
    return float(stretches[inside, 1].max() - s_m) if inside.any() else 0.0


class LanesBesideMap:
    """The road's lanes beside the ego's lane, read at the car's place."""

    def __init__(self, stretches: tuple[np.ndarray, np.ndarray]):
        self.left, self.right = stretches

    def at(self, s_m: float | None) -> LanesBeside | None:
        """At body centre ``s_m`` along the road (None: off the road, not known)."""
        if s_m is None:
            return None
        return LanesBeside(ahead_m(self.left, s_m), ahead_m(self.right, s_m))
