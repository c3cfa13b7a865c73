"""A sweep's progress as the commands show it (sdc/batch/sweeps/progress.py): off a terminal (a
log, `make demo > log`) whole lines, one every few seconds and one at the end, nothing
cut short; on a terminal the live bar."""

from __future__ import annotations

import io
import re
import sys
from collections import Counter

import pytest

from sdc.batch.sweeps import progress
from sdc.batch.sweeps.progress import RichReporter
from sdc.cli.common import make_reporter


class Clock:
    """A monotonic clock the test moves by hand [s]."""

    def __init__(self):
        self.now_s = 1000.0

    def monotonic(self) -> float:
        return self.now_s


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


@pytest.fixture
def clock(monkeypatch) -> Clock:
    clock = Clock()
    monkeypatch.setattr(progress, "time", clock)
    return clock


def sweep_of(reporter, clock: Clock, runs: int = 120, total: int = 1500,
             every_s: float = 0.5) -> None:
    """``runs`` runs of ``total`` reported, one each ``every_s``, two collided, one
    failed (an error row)."""
    reporter.start(total=total, done=0, outcomes=Counter(), failed=0)
    for i in range(runs):
        clock.now_s += every_s
        if i in (30, 90):
            row = {"status": "ok", "outcome": "collided"}
        elif i == 100:
            row = {"status": "error", "outcome": None}
        else:
            row = {"status": "ok", "outcome": "completed"}
        reporter.advance(row)
    reporter.stop()


def test_off_a_terminal_the_progress_is_whole_lines_every_few_seconds(monkeypatch, clock):
    log = io.StringIO()  # not a terminal
    monkeypatch.setattr(sys, "stderr", log)
    reporter = make_reporter({"quiet": False})
    sweep_of(reporter, clock)  # 60 s of runs

    text = log.getvalue()
    assert "…" not in text and "\r" not in text and "\x1b" not in text
    lines = text.splitlines()
    pattern = re.compile(r"sweep: (\d+)/1500 runs, ([\d.]+) runs/s, ETA (\S+), (\d+) completed, "
                         r"(\d+) collided, 0 stuck, 0 unfinished, (\d+) failed$")
    assert all(pattern.match(line) for line in lines), lines
    # a line every LINE_EVERY_S of wall time, and the last one at the end
    assert 60 / progress.LINE_EVERY_S <= len(lines) <= 60 / progress.LINE_EVERY_S + 2
    done = [int(pattern.match(line)[1]) for line in lines]
    assert done == sorted(done) and done[-1] == 120
    assert lines[-1] == ("sweep: 120/1500 runs, 2.0 runs/s, ETA 11m30s, 117 completed, "
                         "2 collided, 0 stuck, 0 unfinished, 1 failed")


def test_off_a_terminal_warm_ups_are_whole_lines_too(monkeypatch, clock):
    log = io.StringIO()
    monkeypatch.setattr(sys, "stderr", log)
    reporter = make_reporter({"quiet": False}, label="search")
    reporter.start(total=10, done=0, outcomes=Counter(), failed=0)
    for t_s in range(0, 401, 20):
        clock.now_s += 1.0
        reporter.warm_states(int(t_s == 400), 1, float(t_s), 400.0)
    reporter.stop()
    lines = log.getvalue().splitlines()
    assert "…" not in log.getvalue()
    assert lines[-2] == "warm-ups: 1 of 1 warm states, SUMO 400 s of 400 s"
    assert len(lines) <= 20 / progress.LINE_EVERY_S + 3
    assert lines[-1] == ("search: 0/10 runs, 0.0 runs/s, ETA unknown, 0 completed, "
                         "0 collided, 0 stuck, 0 unfinished, 0 failed")


def test_a_resumed_sweep_with_nothing_left_ends_with_a_whole_line(monkeypatch, clock):
    log = io.StringIO()
    monkeypatch.setattr(sys, "stderr", log)
    reporter = make_reporter({"quiet": False})
    reporter.start(total=4, done=4, outcomes=Counter(completed=4), failed=0)
    reporter.stop()  # no run this session: no rate, nothing left
    assert log.getvalue().splitlines()[-1] == (
        "sweep: 4/4 runs, 0.0 runs/s, ETA 0s, 4 completed, 0 collided, 0 stuck, "
        "0 unfinished, 0 failed")


def test_on_a_terminal_the_progress_stays_a_live_bar(monkeypatch):
    monkeypatch.setattr(sys, "stderr", Terminal())
    assert isinstance(make_reporter({"quiet": False}), RichReporter)
