"""A sweep's warm-ups tell their progress in seconds of SUMO as they go: each worker
writes its clock beside the warm state it computes, the driver reads them."""

from __future__ import annotations

import dataclasses
import time

import pytest

from scenarios import CATALOG_DIR
from scenarios.spec.toml_io import load_spec
from scenarios.world_backends import warm_up_span_s
from sdc.batch.executors.local_executor import LocalExecutor
from sdc.batch.sweeps import warm_states
from sdc.batch.tasks import warm_up_clock
from sdc.batch.tasks.run_task import RunTask
from sdc.batch.tasks.task import execute
from sdc.batch.tasks.warm_up_clock import ClockWriter, clock_path, read_clock

WARM_UP_S = 8.0
#: a warm-up of several seconds of wall time on the highway (at 600 s it took under
#: one, and on a loaded machine it once ended between two of the driver's reads of
#: its clock) [s of SUMO]
LONG_WARM_UP_S = 2400.0


def warm_task(seed: int, warm_up_s: float = WARM_UP_S) -> RunTask:
    spec = load_spec(CATALOG_DIR / "highway-obstacle.toml")
    spec = dataclasses.replace(spec, traffic=dataclasses.replace(
        spec.traffic, warm_up_s=warm_up_s, warm_seed=seed))
    return RunTask(f"run-{seed}", spec.with_seed(seed))


@pytest.fixture(autouse=True)
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SDC_CACHE_DIR", str(tmp_path / "cache"))


class HalfwayExecutor:
    """Each warm-up's worker gets halfway (its clock written), then finishes."""

    def map(self, tasks):
        for task in tasks:
            begin_s, end_s = warm_up_span_s(task.spec)
            ClockWriter(task.clock_path)((begin_s + end_s) / 2)
            time.sleep(0.2)  # the driver reads the clocks every 0.01 s here
            ClockWriter(task.clock_path).remove()
            yield {"run_id": task.run_id, "status": "ok"}


def test_the_driver_counts_finished_warm_ups_and_the_clocks_of_those_under_way(monkeypatch):
    monkeypatch.setattr(warm_states, "CLOCKS_READ_EVERY_S", 0.01)
    calls = []
    tasks = [warm_task(1), warm_task(2, warm_up_s=2 * WARM_UP_S)]
    summary, _ = warm_states.prepare_warm_states(tasks, HalfwayExecutor(),
                                                 lambda *told: calls.append(told))
    total_s = pytest.approx(3 * WARM_UP_S)
    assert calls[0] == (0, 2, 0.0, total_s)
    assert (0, 2, pytest.approx(WARM_UP_S / 2), total_s) in calls  # the first halfway
    assert (1, 2, pytest.approx(2 * WARM_UP_S), total_s) in calls  # then the second halfway
    assert calls[-1] == (2, 2, total_s, total_s)
    assert all(a[2] <= b[2] for a, b in zip(calls, calls[1:], strict=False))  # never back
    assert summary["computed"] == 2


def test_a_worker_writes_its_clock_as_it_goes_and_takes_it_away(monkeypatch):
    """A real warm-up on a worker: its clock written on the way (SUMO's time, within
    the warm-up, read back from the file), gone when the warm state is."""
    monkeypatch.setattr(warm_up_clock, "WRITE_EVERY_S", 0.0)
    written, write = [], ClockWriter.__call__

    def recording(self, t_s):
        write(self, t_s)
        written.append((t_s, read_clock(self.path)))

    monkeypatch.setattr(ClockWriter, "__call__", recording)
    task = warm_states.warm_up_tasks([warm_task(3)], {"run-3": "k" * 64})[0]
    task.state_path.parent.mkdir(parents=True)
    assert execute(task)["status"] == "ok" and task.state_path.is_file()
    assert len(written) > 1 and all(t_s == read for t_s, read in written)
    assert written[0][0] > 0 and written[-1][0] == pytest.approx(WARM_UP_S)
    assert not clock_path(task.state_path).exists()


@pytest.mark.slow
def test_a_warm_up_in_a_worker_process_moves_the_drivers_bar_as_it_goes():
    """Through a real worker process: the driver sees SUMO's clock between the start
    and the end of a warm-up that takes some seconds."""
    calls = []
    with LocalExecutor(1) as executor:
        summary, _ = warm_states.prepare_warm_states(
            [warm_task(5, warm_up_s=LONG_WARM_UP_S)], executor, lambda *t: calls.append(t))
    assert summary["computed"] == 1
    midway = [sumo_s for done, _, sumo_s, _ in calls if done == 0 and sumo_s > 0]
    assert midway and max(midway) < LONG_WARM_UP_S
    assert calls[-1] == (1, 1, pytest.approx(LONG_WARM_UP_S), pytest.approx(LONG_WARM_UP_S))
