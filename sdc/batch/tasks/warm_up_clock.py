"""SUMO's clock of a warm-up running on a worker, for the driver's progress: the
worker writes it beside the warm state's file (a few bytes, at most every
:data:`WRITE_EVERY_S` of wall time), the driver reads it while it waits. Where the
two share no folder (a Ray node elsewhere) the driver reads nothing and counts the
warm-up when it is done; a clock is progress only, never part of a result."""

from __future__ import annotations

import contextlib
import math
import time
from pathlib import Path

#: how often a worker writes its clock [s of wall time]
WRITE_EVERY_S = 1.0


def clock_path(state_path: Path) -> Path:
    """Where the clock of the warm-up whose state goes to ``state_path`` is kept."""
    return state_path.with_name(state_path.name + ".clock")


class ClockWriter:
    """Called with SUMO's clock [s] as a warm-up goes on (``on_sample``); writes it to
    ``path`` now and then, and never fails the warm-up."""

    def __init__(self, path: Path):
        self.path, self.written_at = path, -math.inf

    def __call__(self, t_s: float) -> None:
        now = time.monotonic()
        if now - self.written_at < WRITE_EVERY_S:
            return
        self.written_at = now
        with contextlib.suppress(OSError):
            self.path.write_text(repr(float(t_s)))

    def remove(self) -> None:
        with contextlib.suppress(OSError):
            self.path.unlink(missing_ok=True)


def read_clock(path: Path) -> float | None:
    """The clock a worker last wrote to ``path`` (None: none, or not readable yet)."""
    try:
        return float(path.read_text())
    except (OSError, ValueError):
        return None
