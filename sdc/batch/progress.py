"""Sweep progress on the terminal: runs done of total, runs/s, ETA, the runs by
outcome (completed, collided, stuck, unfinished) and the failed ones."""

from __future__ import annotations

import time
from collections import Counter

from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)

from analysis.measures.run_outcome import outcomes_text

#: plans that take under a few seconds to build show no bar [runs]
PLANNING_SHOWN_RUNS = 5000


class RichReporter:
    """A rich progress bar; runs/s counts only the runs of this session."""

    def __init__(self, console: Console | None = None, label: str = "sweep"):
        self.console, self.label = console or Console(stderr=True), label
        self._progress: Progress | None = None
        self._planning: Progress | None = None
        self._planning_task = None
        self._warm = None

    def planning(self, done: int, total: int) -> None:
        """Runs planned so far, before the runs start: a bar that goes when it is done,
        shown for plans of more than :data:`PLANNING_SHOWN_RUNS` runs."""
        if total <= PLANNING_SHOWN_RUNS:
            return
        if self._planning is None:
            self._planning = Progress(TextColumn("planning the runs"), BarColumn(),
                                      MofNCompleteColumn(), TimeElapsedColumn(),
                                      console=self.console, transient=True)
            self._planning_task = self._planning.add_task("plan", total=total)
            self._planning.start()
        self._planning.update(self._planning_task, completed=done)
        if done >= total:
            self._planning.stop()

    def start(self, total: int, done: int, outcomes: Counter, failed: int) -> None:
        self._progress = Progress(
            TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
            TextColumn("{task.fields[rate]}"), TimeElapsedColumn(), TextColumn("ETA"),
            TimeRemainingColumn(), TextColumn("{task.fields[tally]}"),
            console=self.console,
        )
        self._outcomes, self._failed, self._session = Counter(outcomes), failed, 0
        self._task = self._progress.add_task(self.label, total=total, completed=done,
                                             tally=self._tally(), rate="")
        self._t0 = time.monotonic()
        self._progress.start()

    def _tally(self) -> str:
        return outcomes_text(self._outcomes) + f", {self._failed} failed"

    def advance(self, row: dict) -> None:
        if row.get("outcome"):
            self._outcomes[row["outcome"]] += 1
        self._failed += row["status"] != "ok"
        self._session += 1
        rate = self._session / max(time.monotonic() - self._t0, 1e-9)
        self._progress.update(self._task, advance=1, tally=self._tally(),
                              rate=f"{rate:.1f} runs/s")

    def set_total(self, total: int) -> None:
        """The runs now planned in all: the bar's length, and so its ETA."""
        self._progress.update(self._task, total=total)

    def warm_states(self, done: int, total: int, sumo_s: float, sumo_total_s: float) -> None:
        """Warm states computed before the runs: a bar of their own, in seconds of SUMO
        simulated (a long warm-up moves it as it goes)."""
        tally = f"{done} of {total} warm states, SUMO {sumo_s:,.0f} s of {sumo_total_s:,.0f} s"
        if self._warm is None:
            self._warm = self._progress.add_task("warm-ups", total=max(sumo_total_s, 1e-9),
                                                 completed=sumo_s, tally=tally, rate="")
        self._progress.update(self._warm, completed=sumo_s, tally=tally)

    def stop(self) -> None:
        if self._progress is not None:
            self._progress.stop()


class QuietReporter:
    """No progress output (logs, CI)."""

    def planning(self, done: int, total: int) -> None:
        pass

    def start(self, total: int, done: int, outcomes: Counter, failed: int) -> None:
        pass

    def advance(self, row: dict) -> None:
        pass

    def set_total(self, total: int) -> None:
        pass

    def warm_states(self, done: int, total: int, sumo_s: float, sumo_total_s: float) -> None:
        pass

    def stop(self) -> None:
        pass
