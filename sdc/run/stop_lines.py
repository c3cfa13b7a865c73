"""The stop lines along the ego's route as a map and a camera give them to a
car: the next one ahead, its distance, its signal and whether the car gives
way there; and the red lights the car drove past.

The lines are the road's (:meth:`RoadGeometry.stops`); their lights' states
are the world's at each step (``Snapshot.signals``, SUMO's link states).
"""

from __future__ import annotations

from collections.abc import Mapping

from scenarios.scene.road_geometry import RouteStop
from sdc.car.controller_api import GREEN, NO_SIGNAL, RED, YELLOW, StopLine

#: SUMO's link states read as a driver reads the light: (signal, gives way)
LINK_SIGNALS: dict[str, tuple[str, bool]] = {
    "r": (RED, False), "u": (RED, False),  # red, red-yellow
    "y": (YELLOW, False),
    "G": (GREEN, False),  # green with priority
    "g": (GREEN, True),  # green without priority: give way to the oncoming
    "s": (GREEN, True),  # a green right-turn arrow: stop, then go
    "o": (NO_SIGNAL, True),  # off, blinking: give way
    "O": (NO_SIGNAL, False),  # off
}


def stop_line(stop: RouteStop, distance_m: float, signals: Mapping[str, str]) -> StopLine:
    """What the car sees of ``stop``, ``distance_m`` ahead of its front bumper."""
    if stop.tl is None:
        return StopLine(distance_m, NO_SIGNAL, stop.give_way)
    states = signals.get(stop.tl, "")
    if not 0 <= stop.link_index < len(states):
        return StopLine(distance_m, NO_SIGNAL, stop.give_way)
    signal, give_way = LINK_SIGNALS.get(states[stop.link_index], (NO_SIGNAL, False))
    return StopLine(distance_m, signal, give_way)


class StopLineWatch:
    """The next stop line ahead of the car's front bumper at each step, and the
    stop lines it crossed while their light was red (``red_light_violations``)."""

    def __init__(self, stops: tuple[RouteStop, ...]):
        self.stops = stops
        self.red_light_violations = 0
        self._next = 0  # the first line not yet crossed
        self._line: StopLine | None = None

    def update(self, front_s_m: float | None, signals: Mapping[str, str]) -> StopLine | None:
        """The line ahead of a front bumper at ``front_s_m`` along the road (None:
        off the road, or no line ahead); a line crossed since the last step counts
        as a violation if its light was red then."""
        if front_s_m is None:
            self._line = None
            return None
        while self._next < len(self.stops) and self.stops[self._next].s_m <= front_s_m:
            if self._line is not None and self._line.signal == RED:
                self.red_light_violations += 1
            self._line = None
            self._next += 1
        if self._next == len(self.stops):
            self._line = None
            return None
        stop = self.stops[self._next]
        self._line = stop_line(stop, stop.s_m - front_s_m, signals)
        return self._line
