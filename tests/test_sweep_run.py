"""Sweeps for real: local processes and a local Ray, crashes, hangs, kills and resumes."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

from scenarios import CATALOG_DIR
from scenarios.sweep_spec import expand, load_sweep
from sdc.batch.executors import LocalExecutor, RayExecutor
from sdc.batch.progress import QuietReporter
from sdc.batch.run_task import RunTask, execute
from sdc.batch.sweep_runner import run_sweep, sweep_columns
from sdc.run.result_row import RUN_COLUMNS, result_schema

pytestmark = pytest.mark.slow

BASE = CATALOG_DIR / "seed-lesson.toml"
SDC = [sys.executable, "-m", "sdc"]
# 6 samples x 2 controllers of short lesson runs, with and without traffic
TINY = f"""[sweep]
name = "tiny"
base = "{BASE}"
sampler = "grid"
controllers = ["seed", "lane-keep"]

[sweep.params]
"ego.speed_mps" = {{ choice = [3.0, 3.74, 9.0] }}
"traffic.flow_vph_per_lane" = {{ choice = [0, 1200] }}
"road.speed_limit_mps" = {{ choice = [27.78] }}
"scenario.duration_s" = {{ choice = [12.0] }}
"""
# beside the barrel at 0.5 m/s; the second road is 20 km long: its run lasts the whole
# 10 h of simulated time, over a minute of wall time with the compiled kernels, the
# first a second or two (the timeouts below leave room for a loaded CI)
HANGS = f"""[sweep]
name = "hangs"
base = "{BASE}"
sampler = "grid"
controllers = ["lane-keep"]

[sweep.params]
"road.length_m" = {{ choice = [150.0, 20000.0] }}
"ego.lane" = {{ choice = [1] }}
"ego.speed_mps" = {{ choice = [0.5] }}
"scenario.duration_s" = {{ choice = [36000.0] }}
"""


def write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return path


def comparable(out_dir: Path) -> pd.DataFrame:
    """The results without what may differ between executors: wall time."""
    return pd.read_parquet(out_dir / "results.parquet").drop(columns=["wall_time_s"])


def sweep_cli(*args, **kwargs) -> subprocess.CompletedProcess:
    return subprocess.run([*SDC, "sweep", *map(str, args), "--quiet"], capture_output=True,
                          text=True, timeout=600, **kwargs)


def test_local_and_ray_executors_give_identical_results(tmp_path):
    path = write(tmp_path, "tiny", TINY)
    sweep = load_sweep(path)
    for name, executor in [("w1", LocalExecutor(1)), ("w2", LocalExecutor(2)),
                           ("ray", RayExecutor(2))]:
        outcome = run_sweep(sweep, tmp_path / name, executor, QuietReporter(), traces="all")
        assert outcome.counts == {"ok": 12, "error": 0, "timeout": 0, "missing": 0}
    reference = comparable(tmp_path / "w1")
    assert list(reference.run_id) == [run.run_id for run in expand(sweep)]
    assert reference.collision.any() and not reference.collision.all()
    assert set(reference["p.ego.speed_mps"]) == {3.0, 3.74, 9.0}
    assert reference.trace_sha256.nunique() == 12
    for name in ("w2", "ray"):
        pd.testing.assert_frame_equal(comparable(tmp_path / name), reference)
        traces = sorted(p.stem for p in (tmp_path / name / "traces").glob("*.parquet"))
        assert traces == sorted(reference.run_id)
    for run_id in reference.run_id[:2]:  # a Ray sweep's run replays identically here
        replay = subprocess.run([*SDC, "replay", str(tmp_path / "ray"), "--run", run_id,
                                 "--verify"], capture_output=True, text=True, timeout=120)
        assert replay.returncode == 0 and "identical" in replay.stdout, replay.stdout
    # the same spec run alone, in this process, gives the same row
    first = expand(sweep)[0]
    alone = execute(RunTask(first.run_id, first.spec))
    assert alone["trace_sha256"] == reference.trace_sha256[0]


def test_traces_for_failures_only(tmp_path):
    out = tmp_path / "out"
    result = sweep_cli(write(tmp_path, "tiny", TINY), "--out", out, "--workers", "2")
    assert result.returncode == 0, result.stderr
    results = pd.read_parquet(out / "results.parquet")
    written = sorted(p.stem for p in (out / "traces").glob("*.parquet"))
    assert written == sorted(results.run_id[results.collision])
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["status"] == "complete"
    assert manifest["counts"] == {"ok": 12, "error": 0, "timeout": 0, "missing": 0}
    assert manifest["collisions"] == int(results.collision.sum())
    assert manifest["versions"]["libsumo"] and manifest["versions"]["numpy"]
    assert manifest["sweep"]["sweep"]["name"] == "tiny"
    assert len(manifest["git"]["commit"]) == 40
    assert not (out / "parts").exists()


def _kill_own_worker(task: RunTask) -> dict:
    """A run that takes its worker process down with it (kill -9), like an OOM kill."""
    if task.run_id == "00002-seed":
        os.kill(os.getpid(), signal.SIGKILL)
    return execute(task)


def test_a_killed_worker_costs_one_run_and_the_sweep_goes_on(tmp_path):
    sweep = load_sweep(write(tmp_path, "tiny", TINY))
    tasks = [RunTask(run.run_id, run.spec, sweep_columns(run)) for run in expand(sweep)]
    with LocalExecutor(2, task_fn=_kill_own_worker) as executor:
        rows = {row["run_id"]: row for row in executor.map(tasks)}
    assert sorted(rows) == sorted(task.run_id for task in tasks)
    columns = result_schema(sweep.param_types).names  # every row complete, the dead one too
    assert all(list(row) == columns for row in rows.values())
    dead = rows.pop("00002-seed")
    assert dead["status"] == "error" and dead["sample"] == 2 and dead["traceback"] is None
    assert "worker process died" in dead["error"] and "SIGKILL" in dead["error"]
    assert all(row["status"] == "ok" for row in rows.values())


def test_a_hung_run_becomes_a_timeout_row(tmp_path):
    out = tmp_path / "out"
    started = time.monotonic()
    result = sweep_cli(write(tmp_path, "hangs", HANGS), "--out", out, "--workers", "2",
                       "--run-timeout", "15")
    assert time.monotonic() - started < 90
    assert result.returncode == 1, result.stderr
    results = pd.read_parquet(out / "results.parquet").set_index("p.road.length_m")
    assert results.status.to_dict() == {150.0: "ok", 20000.0: "timeout"}
    assert "run timeout of 15 s" in results.error[20000.0]
    assert results.wall_time_s[20000.0] >= 15
    assert "1 ok, 0 error, 1 timeout" in result.stdout


def test_ray_stops_a_hung_run(tmp_path):
    sweep = load_sweep(write(tmp_path, "hangs", HANGS))
    tasks = [RunTask(run.run_id, run.spec) for run in expand(sweep)]
    with RayExecutor(2, run_timeout_s=15) as executor:
        rows = {row["run_id"]: row for row in executor.map(tasks)}
    assert rows["00000-lane-keep"]["status"] == "ok"
    assert rows["00001-lane-keep"]["status"] == "timeout"
    assert all(list(row) == list(RUN_COLUMNS) for row in rows.values())


def _wait_for(predicate, timeout_s: float) -> None:
    deadline = time.monotonic() + timeout_s
    while not predicate():
        assert time.monotonic() < deadline, "timed out waiting"
        time.sleep(0.05)


# 96 lesson runs of a few tenths of a second each: still running when interrupted
LONGER = TINY.replace('"scenario.duration_s" = { choice = [12.0] }',
                      '"scenario.duration_s" = { choice = [30.0] }\n'
                      '"obstacles[0].kind" = { choice = ["barrel", "car"] }\n'
                      '"lidar.noise_std_m" = { choice = [0.0, 0.01, 0.02, 0.03] }')
LONGER_RUNS = 96


@pytest.mark.parametrize("how", ["kill -9", "ctrl-c"])
def test_an_interrupted_sweep_resumes_to_the_uninterrupted_result(tmp_path, how):
    path = write(tmp_path, "longer", LONGER)
    reference, out = tmp_path / "reference", tmp_path / "out"
    assert sweep_cli(path, "--out", reference, "--workers", "2").returncode == 0

    # a shell starts a background job with SIGINT ignored, and children inherit that:
    # the sweep gets the disposition of a foreground command, as for a user's Ctrl-C
    proc = subprocess.Popen([*SDC, "sweep", str(path), "--out", str(out), "--workers", "2",
                             "--quiet"], start_new_session=True, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    _wait_for(lambda: any((out / "parts").glob("part-*.parquet")), 120)
    if how == "kill -9":  # the driver and its workers, all at once
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
        assert not (out / "results.parquet").exists()
    else:
        os.killpg(proc.pid, signal.SIGINT)
        assert proc.wait(timeout=60) == 130, proc.stderr.read()
        assert "--resume" in proc.stderr.read()
        manifest = json.loads((out / "manifest.json").read_text())
        assert manifest["status"] == "interrupted" and manifest["counts"]["missing"] > 0
        partial = pd.read_parquet(out / "results.parquet")
        assert 0 < len(partial) < LONGER_RUNS and partial.run_id.is_unique

    again = sweep_cli(path, "--out", out, "--workers", "2")
    assert again.returncode == 2 and "--resume" in again.stderr  # no silent overwrite
    resumed = sweep_cli(path, "--out", out, "--workers", "2", "--resume")
    assert resumed.returncode == 0, resumed.stderr
    manifest = json.loads((out / "manifest.json").read_text())
    assert [s["runs_to_do"] for s in manifest["sessions"]][0] == LONGER_RUNS
    assert 0 < manifest["sessions"][1]["runs_to_do"] < LONGER_RUNS
    pd.testing.assert_frame_equal(comparable(out), comparable(reference))


def test_resume_refuses_another_sweep(tmp_path):
    out = tmp_path / "out"
    assert sweep_cli(write(tmp_path, "hangs", HANGS), "--out", out, "--dry-run").returncode == 0
    tiny = write(tmp_path, "tiny", TINY.replace('choice = [3.0, 3.74, 9.0]', 'choice = [3.0]'))
    assert sweep_cli(tiny, "--out", out, "--workers", "1").returncode == 0
    other = write(tmp_path, "other", TINY.replace('choice = [3.0, 3.74, 9.0]', 'choice = [4.0]'))
    result = sweep_cli(other, "--out", out, "--resume")
    assert result.returncode == 2
    assert "holds a different sweep" in result.stderr
