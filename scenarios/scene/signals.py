"""A traffic light's signal for the car's way, as a driver reads it: one home for
the words and for how SUMO's link states read (the car's map, the trace's record of
the lights along the route, and what a run that ended standing stood for).
"""

from __future__ import annotations

#: a stop line's signal: its light's colour for the car's way, or none (no light)
RED, YELLOW, GREEN, NO_SIGNAL = "red", "yellow", "green", "none"
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
#: the trace's mark for a stop line without a light at a step
NO_LIGHT = "-"


def link_signal(state: str) -> tuple[str, bool]:
    """A link state's (signal, gives way); no light (``NO_LIGHT``) or an unknown
    state: no signal, no duty of its own."""
    return LINK_SIGNALS.get(state, (NO_SIGNAL, False))


def holds_the_car(state: str) -> bool:
    """Does the light say stop (red, red-yellow or yellow)?"""
    return link_signal(state)[0] in (RED, YELLOW)
