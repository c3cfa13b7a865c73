"""The next pedestrian crossing along the ego's route, as a map gives it to a car.

The crossings are the road's (:meth:`RoadGeometry.crosswalks`, in order); the one
ahead is the first whose far side the front bumper has not passed.
"""

from __future__ import annotations

from scenarios.scene.road_geometry import RouteCrosswalk
from sdc.car.controller_api import Crosswalk


class CrosswalkAhead:
    """The next crossing ahead of the car's front bumper at each step."""

    def __init__(self, crosswalks: tuple[RouteCrosswalk, ...]):
        self.crosswalks = crosswalks
        self._next = 0  # the first crossing not yet left behind

    def update(self, front_s_m: float | None) -> Crosswalk | None:
        """The crossing whose far side lies ahead of a front bumper at ``front_s_m``
        along the road (None: off the road, or none ahead)."""
        if front_s_m is None:
            return None
        while (self._next < len(self.crosswalks)
               and self.crosswalks[self._next].far_s_m <= front_s_m):
            self._next += 1
        if self._next == len(self.crosswalks):
            return None
        walk = self.crosswalks[self._next]
        return Crosswalk(walk.near_s_m - front_s_m, walk.far_s_m - walk.near_s_m,
                         max(-walk.right_d_m, 0.0), max(walk.left_d_m, 0.0))
