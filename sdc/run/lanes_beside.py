"""The lanes beside the car's own as a map gives them at each step: how far each
runs on ahead of the car in its direction (:class:`~sdc.car.controller_api.LanesBeside`),
from the road's stretches (:meth:`RoadGeometry.lanes_beside`)."""

from __future__ import annotations

import numpy as np

from sdc.car.controller_api import LanesBeside


def ahead_m(stretches, s_m: float) -> float:
    """How far from ``s_m`` the stretch holding it runs on (0: none holds it);
    ``stretches``: (start, end) pairs [m]."""
    end_m = None
    for start, end in stretches:  # a plain loop: a step asks this twice
        if start <= s_m <= end and (end_m is None or end > end_m):
            end_m = end
    return 0.0 if end_m is None else float(end_m - s_m)


class LanesBesideMap:
    """The road's lanes beside the ego's lane, read at the car's place (a road has a
    few stretches: plain floats read them faster than numpy, every step)."""

    def __init__(self, stretches: tuple[np.ndarray, np.ndarray]):
        self.left, self.right = (np.asarray(side, float).reshape(-1, 2).tolist()
                                 for side in stretches)

    def at(self, s_m: float | None) -> LanesBeside | None:
        """At body centre ``s_m`` along the road (None: off the road, not known)."""
        if s_m is None:
            return None
        return LanesBeside(ahead_m(self.left, s_m), ahead_m(self.right, s_m))
