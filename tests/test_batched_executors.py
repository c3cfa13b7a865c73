"""Ray tasks carrying batches of runs, and executors entered once for many maps:
one row per run whatever the batch, its own timeout and failure, same results."""

from __future__ import annotations

import dataclasses
import os
import time
from pathlib import Path

import pytest

from scenarios import CATALOG_DIR
from scenarios.spec.toml_io import load_spec
from sdc.batch.executors.batch_size import MAX_RUNS, BatchSizer
from sdc.batch.executors.local_executor import LocalExecutor
from sdc.batch.executors.ray_executor import RayExecutor
from sdc.batch.tasks.run_task import RunTask
from sdc.batch.tasks.task import execute
from sdc.run.result_row import RUN_COLUMNS

KILLER, SLEEPER = "run-05", "run-01"
SCRIPTED_LESSON = Path(__file__).resolve().parent / "data" / "seed-lesson-scripted.toml"
RUN_TIMEOUT_S = 10.0


def lesson_tasks(count: int = 12) -> list[RunTask]:
    """Short lesson runs under seed and lane-keep, each of another seed and speed (on the
    scripted backend: a world without a simulator)."""
    base = load_spec(SCRIPTED_LESSON)
    tasks = []
    for i in range(count):
        spec = base.with_seed(i).with_controller("seed" if i % 2 else "lane-keep")
        spec = dataclasses.replace(spec, ego=dataclasses.replace(spec.ego,
                                                                 speed_mps=3.0 + 0.5 * i))
        tasks.append(RunTask(f"run-{i:02d}", spec))
    return tasks


def _noting_pid(task: RunTask) -> dict:
    """Runs ``task`` and leaves the worker's process id in $SDC_TEST_PID_DIR."""
    (Path(os.environ["SDC_TEST_PID_DIR"]) / f"{os.getpid()}.pid").touch()
    return execute(task)


def _kills_its_worker(task: RunTask) -> dict:
    if task.run_id == KILLER:
        os.kill(os.getpid(), 9)
    return execute(task)


def _sleeps(task: RunTask) -> dict:
    if task.run_id == SLEEPER:
        (Path(os.environ["SDC_TEST_PID_DIR"]) / "sleeper.pid").write_text(str(os.getpid()))
        time.sleep(3600)
    return execute(task)


@pytest.fixture
def ray_finds_this_module(tmp_path, monkeypatch, fresh_ray):
    """Ray's workers unpickle this module's task functions by importing it: a session of
    each executor's own, whose workers are the executor's alone."""
    monkeypatch.setenv("SDC_TEST_PID_DIR", str(tmp_path))
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(
        [str(Path(__file__).parent), *filter(None, [os.environ.get("PYTHONPATH")])]))


def test_batch_sizes_follow_run_times_and_leave_every_slot_work():
    sizer = BatchSizer()
    assert sizer.size(pending=400, slots=2) == 1  # nothing measured yet
    for _ in range(50):
        sizer.observe(0.02)
    assert sizer.size(pending=400, slots=2) == 15  # 0.3 s of 20 ms runs
    assert sizer.size(pending=20, slots=2) == 5  # 20 runs: four tasks, none waits
    assert sizer.size(pending=1, slots=2) == 1
    sizer.observe(10.0)  # a long run pulls the size down at once
    assert sizer.size(pending=400, slots=2) == 1
    fast = BatchSizer()
    fast.observe(1e-5)
    assert fast.size(pending=10_000, slots=1) == MAX_RUNS
    fixed = BatchSizer(fixed_runs=8)
    assert fixed.size(pending=400, slots=2) == 8 and fixed.size(pending=12, slots=2) == 3


@pytest.mark.slow
def test_many_maps_in_one_with_block_reuse_the_workers_and_agree(tmp_path,
                                                                 ray_finds_this_module):
    tasks = lesson_tasks(12)
    chunks = [tasks[:5], tasks[5:10], tasks[10:]]
    results = {}
    for name, executor in [("local", LocalExecutor(2, task_fn=_noting_pid)),
                           ("ray", RayExecutor(2, task_fn=_noting_pid)),
                           ("ray-batch-4", RayExecutor(2, task_fn=_noting_pid, batch_runs=4))]:
        for old in tmp_path.glob("*.pid"):
            old.unlink()
        rows = {}
        with executor:
            for chunk in chunks:
                got = list(executor.map(chunk))
                assert sorted(r["run_id"] for r in got) == [t.run_id for t in chunk]
                rows.update((r["run_id"], r) for r in got)
            # the same two workers throughout
            assert len(list(tmp_path.glob("*.pid"))) <= 2, name
            # a map left after its first row leaves nothing behind for the next one
            left = executor.map(tasks[:6])
            next(left)
            left.close()
            got = list(executor.map(tasks[6:8]))
            assert sorted(r["run_id"] for r in got) == [t.run_id for t in tasks[6:8]], name
        results[name] = {run_id: (row["status"], row["trace_sha256"])
                         for run_id, row in rows.items()}
    assert all(status == "ok" for status, _ in results["local"].values())
    assert results["ray"] == results["local"] and results["ray-batch-4"] == results["local"]
    alone = execute(tasks[7])
    assert alone["trace_sha256"] == results["local"][tasks[7].run_id][1]


@pytest.mark.slow
def test_a_run_that_kills_its_ray_worker_costs_only_its_own_row(ray_pids):
    tasks = lesson_tasks(12)
    with RayExecutor(2, task_fn=_kills_its_worker, batch_runs=3) as executor:
        rows = {row["run_id"]: row for row in executor.map(tasks)}
    assert sorted(rows) == [t.run_id for t in tasks]
    assert all(list(row) == list(RUN_COLUMNS) for row in rows.values())
    dead = rows.pop(KILLER)
    assert dead["status"] == "error" and "WorkerCrashedError" in dead["error"]
    assert {row["status"] for row in rows.values()} == {"ok"}  # its batch mates ran again


@pytest.mark.slow
def test_a_hung_run_in_the_middle_of_a_ray_batch_times_out_alone(ray_pids):
    tasks = lesson_tasks(12)  # batches of 3: the sleeper is the second of the first
    with RayExecutor(2, run_timeout_s=RUN_TIMEOUT_S, task_fn=_sleeps,
                     batch_runs=3) as executor:
        rows = {row["run_id"]: row for row in executor.map(tasks)}
        sleeper_pid = int((ray_pids / "sleeper.pid").read_text())
        deadline = time.monotonic() + 60
        while not _gone(sleeper_pid):  # Ray's force cancel ends its worker
            assert time.monotonic() < deadline, "the hung run's worker lives on"
            time.sleep(0.1)
    assert sorted(rows) == [t.run_id for t in tasks]
    late = rows.pop(SLEEPER)
    assert late["status"] == "timeout" and late["wall_time_s"] >= RUN_TIMEOUT_S
    assert f"run timeout of {RUN_TIMEOUT_S:g} s" in late["error"]
    assert {row["status"] for row in rows.values()} == {"ok"}  # run-02 ran in another task


def _gone(pid: int) -> bool:
    """Whether process ``pid`` has ended (a zombie has ended)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] == "Z"
    except FileNotFoundError:
        return True


def test_batch_is_refused_without_ray(tmp_path):
    from click.testing import CliRunner

    from sdc.cli import main

    sweep = CATALOG_DIR / "sweeps" / "seed-envelope.toml"
    result = CliRunner().invoke(main, ["sweep", str(sweep), "--out", str(tmp_path / "out"),
                                       "--batch", "4"])
    assert result.exit_code == 2 and "--batch: only applies with --executor ray" in \
        result.stderr
    assert not (tmp_path / "out").exists()
