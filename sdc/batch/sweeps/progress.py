"""Sweep progress: runs done of total, runs/s, ETA, the runs by outcome (completed,
collided, stuck, unfinished) and the failed ones. On a terminal a live bar
(:class:`RichReporter`); off one (a log) whole lines (:class:`LineReporter`), which
:func:`progress_reporter` chooses."""

from __future__ import annotations

import sys
import time
from collections import Counter
from typing import TextIO

from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)

from analysis.measures.row_columns import RowCol
from analysis.measures.run_outcome import outcomes_text

#: plans that take under a few seconds to build show no bar [runs]
PLANNING_SHOWN_RUNS = 5000
#: off a terminal (a log): a progress line at most this often, and one at the end [s]
LINE_EVERY_S = 5.0


def progress_reporter(label: str = "sweep", stream: TextIO | None = None):
    """The progress of a sweep on ``stream`` (stderr): a live bar on a terminal, else
    whole lines (:class:`LineReporter`)."""
    stream = sys.stderr if stream is None else stream
    if stream.isatty():
        return RichReporter(Console(file=stream), label)
    return LineReporter(stream, label)


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
        if row.get(RowCol.outcome):
            self._outcomes[row[RowCol.outcome]] += 1
        self._failed += row[RowCol.status] != "ok"
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


def duration_text(seconds: float) -> str:
    """A duration as a log reads it: ``45s``, ``1m35s``, ``2h03m``."""
    whole = round(seconds)
    hours, rest = divmod(whole, 3600)
    minutes, secs = divmod(rest, 60)
    if hours:
        return f"{hours}h{minutes:02d}m"
    return f"{minutes}m{secs:02d}s" if minutes else f"{secs}s"


class LineReporter:
    """Progress off a terminal: whole sentences, a line at most every
    :data:`LINE_EVERY_S` of wall time and one at the end, never cut short:
    ``sweep: 120/1500 runs, 14.3 runs/s, ETA 1m36s, 118 completed, 2 collided, 0 stuck,
    0 unfinished, 0 failed``. Runs/s counts only the runs of this session."""

    def __init__(self, stream: TextIO, label: str = "sweep"):
        self.stream, self.label = stream, label
        self._shown_at: dict[str, float] = {}  # when each kind of line was last written
        self._shown: dict[str, str] = {}  # and what it said
        self._total = self._done = self._session = self._failed = 0
        self._outcomes: Counter = Counter()
        self._t0: float | None = None

    def _line(self, kind: str, text: str, last: bool = False) -> None:
        """Write ``text`` when :data:`LINE_EVERY_S` has passed since the last line of its
        ``kind``, or when it is the ``last`` and says something new."""
        now = time.monotonic()
        due = now - self._shown_at.get(kind, -float("inf")) >= LINE_EVERY_S
        if (due and not last) or (last and self._shown.get(kind) != text):
            self.stream.write(text + "\n")
            self.stream.flush()
            self._shown_at[kind], self._shown[kind] = now, text

    def planning(self, done: int, total: int) -> None:
        if total > PLANNING_SHOWN_RUNS:
            self._line("planning", f"planning the runs: {done} of {total}", last=done >= total)

    def start(self, total: int, done: int, outcomes: Counter, failed: int) -> None:
        self._total, self._done, self._failed = total, done, failed
        self._outcomes, self._session, self._t0 = Counter(outcomes), 0, time.monotonic()
        self._shown_at["runs"] = self._t0  # the first line after LINE_EVERY_S of runs

    def _runs_text(self) -> str:
        elapsed_s = time.monotonic() - self._t0
        rate = self._session / elapsed_s if elapsed_s > 0 else 0.0
        left = max(self._total - self._done, 0)
        eta = duration_text(left / rate if left else 0.0) if rate > 0 or not left else "unknown"
        return (f"{self.label}: {self._done}/{self._total} runs, {rate:.1f} runs/s, ETA {eta}, "
                f"{outcomes_text(self._outcomes)}, {self._failed} failed")

    def advance(self, row: dict) -> None:
        if row.get(RowCol.outcome):
            self._outcomes[row[RowCol.outcome]] += 1
        self._failed += row[RowCol.status] != "ok"
        self._done += 1
        self._session += 1
        self._line("runs", self._runs_text())

    def set_total(self, total: int) -> None:
        self._total = total

    def warm_states(self, done: int, total: int, sumo_s: float, sumo_total_s: float) -> None:
        self._line("warm", f"warm-ups: {done} of {total} warm states, SUMO {sumo_s:,.0f} s "
                           f"of {sumo_total_s:,.0f} s", last=done >= total)

    def stop(self) -> None:
        if self._t0 is not None:
            self._line("runs", self._runs_text(), last=True)


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
