"""The stop lines along the ego's route as a map and a camera give them to a
car: the next one ahead, its distance, its signal and whether the car gives
way there; and the red lights the car drove past.

The lines are the road's (:meth:`RoadGeometry.stops`); their lights' states
are the world's at each step (``Snapshot.signals``, SUMO's link states).
"""

from __future__ import annotations

from collections.abc import Mapping

from scenarios.scene.road_geometry import RouteStop
from scenarios.scene.signals import NO_LIGHT, NO_SIGNAL, RED, link_signal
from sdc.car.controller_api import StopLine


def stop_state(stop: RouteStop, signals: Mapping[str, str]) -> str:
    """The link state SUMO's light shows the car's way at ``stop`` (one of
    ``LINK_SIGNALS``' keys), or ``NO_LIGHT``: the line has none, or its light does
    not say."""
    states = signals.get(stop.tl, "") if stop.tl is not None else ""
    return states[stop.link_index] if 0 <= stop.link_index < len(states) else NO_LIGHT


def stop_line(stop: RouteStop, distance_m: float, signals: Mapping[str, str]) -> StopLine:
    """What the car sees of ``stop``, ``distance_m`` ahead of its front bumper."""
    state = stop_state(stop, signals)
    if state == NO_LIGHT:
        return StopLine(distance_m, NO_SIGNAL, stop.give_way)
    return StopLine(distance_m, *link_signal(state))


class StopLineWatch:
    """The next stop line ahead of the car's front bumper at each step, and the
    stop lines it crossed while their light was red (``red_light_violations``)."""

    def __init__(self, stops: tuple[RouteStop, ...]):
        self.stops = stops
        self.red_light_violations = 0
        self._next = 0  # the first line not yet crossed
        self._line: StopLine | None = None
        self._lit = any(stop.tl is not None for stop in stops)

    def states(self, signals: Mapping[str, str]) -> str:
        """What every light along the route shows the car's way at this step, one
        character per stop line in order (:func:`stop_state`); empty on a route
        without lights (the trace's ``signals`` column)."""
        if not self._lit:
            return ""
        return "".join(stop_state(stop, signals) for stop in self.stops)

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
