"""The one loop that steps a world: every run's steps, one ego or many.

A world (:class:`scenarios.world_backends.World`) holds its egos in slots; each slot
has a :class:`Driver` that says where its ego is pushed each step. A run of one ego
is a world with one slot, its driver the run (:class:`sdc.run.episode.Simulation`
under its controller); a shared world's runs are several; the audit's replay pushes
each ego along its trace (:mod:`sdc.run.world_witness`), and SUMO's driver can take
an ego's place (:mod:`sdc.run.sumo_driver`).

Each step, every driver in the world takes its turn in slot order (it senses,
decides, is checked, and either moves or ends), a driver that ended leaves the world,
the :class:`Seating` lets waiting drivers enter (none waits without one: all enter
at the start), then the world advances once with every move: the same drivers give
the same world, bit for bit. The last driver in a world does not leave it: nothing
steps the world again, and what it saw of its ego at its end can still be read.
"""

from __future__ import annotations

import traceback
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from scenarios.scene.snapshot import Pose, Snapshot
from scenarios.world_backends import World


class Driver(Protocol):
    """What drives one slot of a world."""

    #: why its run ended (None: it goes on); read after each :meth:`turn`
    end: str | None

    def place(self) -> Pose: ...  # where its ego starts, before the world starts
    def begin(self, snapshot: Snapshot) -> None: ...  # the world's first answer
    def wants_more(self) -> bool: ...  # does it still need the world to go on?
    def turn(self) -> Pose | None: ...  # this step's move (None: the world's driver)
    def arrive(self, snapshot: Snapshot) -> None: ...  # the world's answer to its move


class Seating(Protocol):
    """Who of a world's waiting drivers enters it, and when."""

    def entering(self, waiting: list[int], present: dict[int, np.ndarray], step: int
                 ) -> list[int]:
        """Of ``waiting`` (slots, in slot order), those that enter at the world's
        ``step`` (0: as it starts), the egos of ``present`` (slot -> its body box this
        step) in the world."""
        ...


@dataclass(frozen=True)
class Failed:
    """A slot whose driver raised (its controller, or the world itself)."""

    error: str  # "ZeroDivisionError: ..."
    traceback: str
    exception: BaseException | None = field(default=None, compare=False)

    @classmethod
    def of(cls, e: BaseException) -> Failed:
        """The failure ``e`` (raised a moment ago: its traceback is the current one)."""
        return cls(f"{type(e).__name__}: {e}", traceback.format_exc(), e)


class WorldLoop:
    """``drivers`` (in slot order) stepping ``world`` together. ``failed``: slots that
    failed before the world started (they never enter it). ``seating``: who enters when
    (None: every driver at the start).

    :meth:`start` starts the world; each :meth:`step` is one step of every driver
    in it; :meth:`run` steps until no driver wants more. ``ends``: slot -> why its run
    ended (its driver's ``end``, or how it failed); ``entered``: slot -> the world's
    step at which its ego entered (0: at the start).
    """

    def __init__(self, world: World, drivers: list[Driver],
                 failed: dict[int, Failed] | None = None, seating: Seating | None = None):
        self.world, self.drivers, self.seating = world, drivers, seating
        self.ends: dict[int, str | Failed] = dict(failed or {})
        self.entered: dict[int, int] = {}
        self.steps = 0  # the world's steps so far

    def _waiting(self) -> list[int]:
        return [i for i in range(len(self.drivers))
                if i not in self.entered and i not in self.ends]

    def start(self) -> None:
        waiting = self._waiting()
        first = waiting if self.seating is None else self.seating.entering(waiting, {}, 0)
        snapshots = self.world.start_all({i: self.drivers[i].place() for i in first})
        for i in first:
            self.entered[i] = 0
            self.drivers[i].begin(snapshots[i])

    def going(self) -> bool:
        """Does a driver in the world, or waiting for it, want it to go on?"""
        return any(i not in self.ends and d.wants_more() for i, d in enumerate(self.drivers))

    def step(self) -> None:
        """Every driver in the world takes its turn; those that ended leave; waiting
        ones enter as the seating lets them; the world advances once with the moves."""
        moves: dict[int, Pose | None] = {}
        for i in sorted(self.entered):
            if i in self.ends:
                continue
            driver = self.drivers[i]
            try:
                move = driver.turn()
                end = driver.end
            except Exception as e:  # noqa: BLE001 - its driver's failure: it alone ends
                end = Failed.of(e)
            if end is None:
                moves[i] = move
            else:
                self.ends[i] = end
                self._leave(i)
        entering = self._entering(moves)
        if not moves:
            return
        self.steps += 1
        snapshots = self.world.step_all(moves)
        for i in moves:
            if i in entering:
                self.entered[i] = self.steps
                self.drivers[i].begin(snapshots[i])
            else:
                self.drivers[i].arrive(snapshots[i])

    def _entering(self, moves: dict[int, Pose | None]) -> list[int]:
        """The waiting drivers the seating lets in at this step, each placed where it
        starts (its pose added to ``moves``), its bodies entering the world."""
        waiting = [] if self.seating is None else self._waiting()
        if not waiting:
            return []
        present = {i: move[0] for i, move in moves.items() if move is not None}
        entering = self.seating.entering(waiting, present, self.steps + 1)
        if not present and not entering:  # nobody would ever step the world again
            raise RuntimeError(f"the seating lets none of slots {waiting} into an empty world")
        for i in entering:
            moves[i] = self.drivers[i].place()
            self.world.enter(i, moves[i])
        return entering

    def _leave(self, slot: int) -> None:
        """``slot``'s run has ended: its ego leaves the world, unless none is left in it
        nor waiting for it."""
        if len(self.ends) < len(self.drivers):
            self.world.leave(slot)

    def run(self) -> dict[int, str | Failed]:
        """Start, then step until no driver wants more; why each run ended."""
        self.start()
        while self.going():
            self.step()
        return self.ends


def run_alone(world: World, driver: Driver) -> str:
    """Run ``driver`` alone in ``world`` (slot 0) until it ends: why it ended. Its
    failure is raised again, as raised."""
    end = WorldLoop(world, [driver]).run()[0]
    if isinstance(end, Failed):
        raise end.exception
    return end
