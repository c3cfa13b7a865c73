"""Sweeps for real: local processes and a local Ray, crashes, hangs, kills and resumes."""

from __future__ import annotations

import contextlib
import inspect
import json
import os
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from analysis.measures.commands import program_words
from analysis.measures.sweep_manifest import SweepManifest
from scenarios import CATALOG_DIR
from scenarios.scene import traffic_model
from scenarios.spec.sweep_plan import expand
from scenarios.spec.sweep_spec import load_sweep
from sdc.batch.executors.local_executor import LocalExecutor
from sdc.batch.executors.ray_executor import RayExecutor
from sdc.batch.sweeps.progress import QuietReporter
from sdc.batch.sweeps.result_store import ResultStore
from sdc.batch.sweeps.sweep_runner import run_sweep, sweep_columns
from sdc.batch.tasks.run_task import RunTask
from sdc.batch.tasks.task import execute
from sdc.cli import main
from sdc.run.result_row import RUN_COLUMNS, result_schema

pytestmark = pytest.mark.slow

BASE = CATALOG_DIR / "seed-lesson.toml"
#: the lesson on the scripted backend (a world without a simulator): the base of the sweeps
#: here but those whose workers are watched for libsumo (:func:`_in_a_run`)
SCRIPTED = Path(__file__).resolve().parent / "data" / "seed-lesson-scripted.toml"
SDC = [sys.executable, "-m", "sdc"]
# 6 samples x 2 controllers of short lesson runs, with and without traffic
TINY_ON = """[sweep]
name = "tiny"
base = "{base}"
sampler = "grid"
controllers = ["seed", "lane-keep"]

[sweep.params]
"ego.speed_mps" = {{ choice = [3.0, 3.74, 9.0] }}
"traffic.flow_vph_per_lane" = {{ choice = [0, 1200] }}
"road.speed_limit_mps" = {{ choice = [27.78] }}
"scenario.duration_s" = {{ choice = [12.0] }}
"""
TINY = TINY_ON.format(base=SCRIPTED)
TINY_SUMO = TINY_ON.format(base=BASE)
# three short lane-keep runs; the first one hangs under _hangs
HANGS = f"""[sweep]
name = "hangs"
base = "{SCRIPTED}"
sampler = "grid"
controllers = ["lane-keep"]

[sweep.params]
"ego.speed_mps" = {{ choice = [3.0, 3.74, 9.0] }}
"scenario.duration_s" = {{ choice = [12.0] }}
"""
# a new manifest's keys and a session's, in the order they are written
MANIFEST_KEYS = ["sweep", "base_scenario", "plan_sha256", "runs", "samples", "versions",
                 "traffic_model", "sumo_config", "controllers", "files", "git", "started_at",
                 "ended_at", "status", "counts", "collisions", "sessions"]
SESSION_KEYS = ["started_at", "ended_at", "executor", "workers", "traces", "runs_to_do"]
HUNG_RUN = "00000-lane-keep"
HANG_S = 3600.0  # far past any run timeout below: only a stopped worker ends it
#: a short lesson run takes well under a second: on SUMO with traffic, its first in a
#: worker with a cold cache took at most 1.3 s on a loaded 2-core machine
RUN_TIMEOUT_S = 5.0
#: the scripted backend's lesson runs took at most 0.05 s there: the local hung run's
SCRIPTED_RUN_TIMEOUT_S = 2.5


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


def sweep_here(*args):
    """:func:`sweep_cli`'s command run in this process (no interpreter to start): its
    click result (``exit_code``, ``stdout``, ``stderr``)."""
    return CliRunner().invoke(main, ["sweep", *map(str, args), "--quiet"])


def _wait_for(predicate, timeout_s: float):
    """Poll ``predicate`` until it returns something true, and return that."""
    deadline = time.monotonic() + timeout_s
    while not (value := predicate()):
        assert time.monotonic() < deadline, "timed out waiting"
        time.sleep(0.05)
    return value


def _gone(pid: int) -> bool:
    """Whether process ``pid`` has ended (a zombie has ended)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] == "Z"
    except FileNotFoundError:
        return True


def _workers(driver_pid: int) -> list[int]:
    """The worker processes of a local sweep: its driver's spawned children."""
    pids = []
    for thread in Path(f"/proc/{driver_pid}/task").iterdir():
        try:
            children = (thread / "children").read_text().split()
        except FileNotFoundError:  # a thread that ended since the listing
            continue
        for pid in children:
            with contextlib.suppress(FileNotFoundError):
                if b"spawn_main" in Path(f"/proc/{pid}/cmdline").read_bytes():
                    pids.append(int(pid))
    return pids


def _in_a_run(pid: int) -> bool:
    """Whether worker ``pid`` has taken a run (libsumo is loaded lazily, by the first).
    The driver hands such a worker runs: while any remain, it always holds one."""
    with contextlib.suppress(FileNotFoundError):
        return "/_libsumo" in Path(f"/proc/{pid}/maps").read_text()
    return False


def test_local_and_ray_executors_give_identical_results(tmp_path, ray_session):
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
        replay = CliRunner().invoke(main, ["replay", str(tmp_path / "ray"), "--run", run_id,
                                           "--verify"])
        assert replay.exit_code == 0 and "identical" in replay.stdout, replay.output
    # the same spec run alone, in this process, gives the same row
    first = expand(sweep)[0]
    alone = execute(RunTask(first.run_id, first.spec))
    assert alone["trace_sha256"] == reference.trace_sha256[0]


def test_traces_for_failures_only(tmp_path):
    out = tmp_path / "out"
    result = sweep_here(write(tmp_path, "tiny", TINY), "--out", out, "--workers", "2")
    assert result.exit_code == 0, result.output
    results = pd.read_parquet(out / "results.parquet")
    written = sorted(p.stem for p in (out / "traces").glob("*.parquet"))
    assert written == sorted(results.run_id[results.collision])
    text = (out / "manifest.json").read_text()
    manifest = json.loads(text)
    # the typed manifest the runner wrote: its keys as a dict made them, read back to the byte
    assert list(manifest) == [*MANIFEST_KEYS, "warm_states", "outcomes"]
    assert list(manifest["sessions"][0]) == [*SESSION_KEYS, "warm_states", "files"]
    assert json.dumps(SweepManifest.from_dict(manifest).to_dict(), indent=2) + "\n" == text
    assert manifest["status"] == "complete"
    assert manifest["counts"] == {"ok": 12, "error": 0, "timeout": 0, "missing": 0}
    assert manifest["collisions"] == int(results.collision.sum())
    assert manifest["versions"]["libsumo"] and manifest["versions"]["numpy"]
    assert manifest["traffic_model"] == traffic_model.description()
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


def _hangs(task: RunTask) -> dict:
    """HUNG_RUN sleeps for HANG_S (its process id in ``$SDC_TEST_PID_DIR/<run_id>.pid``:
    a worker writes its trace in a folder of its own); the others run."""
    if task.run_id == HUNG_RUN:
        (Path(os.environ["SDC_TEST_PID_DIR"]) / f"{task.run_id}.pid").write_text(
            str(os.getpid()))
        time.sleep(HANG_S)
    return execute(task)


def test_a_hung_run_becomes_a_timeout_row_and_the_sweep_goes_on(tmp_path, monkeypatch):
    monkeypatch.setenv("SDC_TEST_PID_DIR", str(tmp_path))
    out = tmp_path / "out"
    executor = LocalExecutor(1, run_timeout_s=SCRIPTED_RUN_TIMEOUT_S, task_fn=_hangs)
    outcome = run_sweep(load_sweep(write(tmp_path, "hangs", HANGS)), out, executor,
                        QuietReporter(), traces="all")
    assert outcome.counts == {"ok": 2, "error": 0, "timeout": 1, "missing": 0}
    results = pd.read_parquet(out / "results.parquet").set_index("run_id")
    assert results.status.to_dict() == {HUNG_RUN: "timeout", "00001-lane-keep": "ok",
                                        "00002-lane-keep": "ok"}  # on a new worker
    assert f"run timeout of {SCRIPTED_RUN_TIMEOUT_S:g} s" in results.error[HUNG_RUN]
    assert results.wall_time_s[HUNG_RUN] >= SCRIPTED_RUN_TIMEOUT_S
    assert _gone(int((tmp_path / f"{HUNG_RUN}.pid").read_text()))  # its worker


def test_ray_stops_a_hung_run(tmp_path, ray_pids):
    # the session's workers find _hangs by importing this module, and note its pid in ray_pids
    sweep = load_sweep(write(tmp_path, "hangs", HANGS))
    tasks = [RunTask(run.run_id, run.spec, trace_path=tmp_path / f"{run.run_id}.parquet")
             for run in expand(sweep)]
    # a Ray task's clock starts at submission, and a worker's first run on a loaded
    # machine (Ray's own processes included) has taken over 10 s: more room here
    timeout_s = 30.0
    with RayExecutor(2, run_timeout_s=timeout_s, task_fn=_hangs) as executor:
        rows = {row["run_id"]: row for row in executor.map(tasks)}
        hung_pid = int((ray_pids / f"{HUNG_RUN}.pid").read_text())
        _wait_for(lambda: _gone(hung_pid), 60)  # Ray's force cancel ends its worker
    assert {run_id: row["status"] for run_id, row in rows.items()} == {
        HUNG_RUN: "timeout", "00001-lane-keep": "ok", "00002-lane-keep": "ok"}
    assert rows[HUNG_RUN]["wall_time_s"] >= timeout_s
    assert all(list(row) == list(RUN_COLUMNS) for row in rows.values())


def test_a_run_that_never_ends_becomes_a_timeout_row_on_the_command_line(tmp_path):
    out = tmp_path / "out"
    proc = subprocess.Popen([*SDC, "sweep", str(write(tmp_path, "tiny", TINY_SUMO)), "--out",
                             str(out), "--workers", "2", "--run-timeout", f"{RUN_TIMEOUT_S:g}",
                             "--quiet"], start_new_session=True, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        held = _wait_for(lambda: [p for p in _workers(proc.pid) if _in_a_run(p)], 120)[0]
        os.kill(held, signal.SIGSTOP)  # its run will never end
        stdout, stderr = proc.communicate(timeout=300)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == 1, stderr
    assert "12 runs: 11 ok, 0 error, 1 timeout, 0 not run" in stdout
    results = pd.read_parquet(out / "results.parquet")
    timeout = results[results.status == "timeout"].iloc[0]
    assert f"run timeout of {RUN_TIMEOUT_S:g} s" in timeout.error
    assert timeout.wall_time_s >= RUN_TIMEOUT_S
    assert _gone(held)


# 48 short lesson runs: many more than one worker runs while the other starts (and
# than the runs _hold_in_flight's poll may see go by)
MANY = TINY_SUMO.replace('"scenario.duration_s" = { choice = [12.0] }',
                         '"scenario.duration_s" = { choice = [12.0] }\n'
                         '"obstacles[0].kind" = { choice = ["barrel", "car"] }\n'
                         '"lidar.noise_std_m" = { choice = [0.0, 0.02] }')
MANY_RUNS = 48
FLUSH_S = inspect.signature(ResultStore).parameters["flush_s"].default


def _hold_in_flight(proc: subprocess.Popen, out: Path) -> None:
    """Hold a 2-worker ``sdc sweep`` in flight with rows in a part, whatever the speed.

    A worker that has taken a run is stopped (SIGSTOP): it holds a run that will never
    end, so the sweep cannot finish. The other is stopped too for longer than the
    result store's flush interval, and once it resumes, its rows reach a part."""
    held = _wait_for(lambda: [p for p in _workers(proc.pid) if _in_a_run(p)], 120)[0]
    others = [pid for pid in _workers(proc.pid) if pid != held]
    for pid in [held, *others]:
        os.kill(pid, signal.SIGSTOP)
    time.sleep(1.5 * FLUSH_S)
    for pid in others:
        os.kill(pid, signal.SIGCONT)
    _wait_for(lambda: any((out / "parts").glob("part-*.parquet")), 120)


def _rows_kept(out: Path) -> int:
    files = [out / "results.parquet"] + sorted((out / "parts").glob("part-*.parquet"))
    return pd.concat([pd.read_parquet(f) for f in files if f.exists()]).run_id.nunique()


@pytest.fixture(scope="module")
def many_reference(tmp_path_factory) -> Path:
    """The MANY sweep, run through uninterrupted: what each interrupted one must equal."""
    reference = tmp_path_factory.mktemp("many") / "reference"
    path = write(reference.parent, "many", MANY)
    done = sweep_here(path, "--out", reference, "--workers", "2")
    assert done.exit_code == 0, done.output
    return reference


@pytest.mark.parametrize("how", ["kill -9", "ctrl-c"])
def test_an_interrupted_sweep_resumes_to_the_uninterrupted_result(tmp_path, how,
                                                                  many_reference):
    path = write(tmp_path, "many", MANY)
    reference, out = many_reference, tmp_path / "out"

    # a shell starts a background job with SIGINT ignored, and children inherit that:
    # the sweep gets the disposition of a foreground command, as for a user's Ctrl-C
    proc = subprocess.Popen([*SDC, "sweep", str(path), "--out", str(out), "--workers", "2",
                             "--quiet"], start_new_session=True, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        _hold_in_flight(proc, out)
        if how == "kill -9":  # the driver and its workers, all at once
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait(timeout=30)
            assert not (out / "results.parquet").exists()
        else:
            os.killpg(proc.pid, signal.SIGINT)
            assert proc.wait(timeout=60) == 130, proc.stderr.read()
            hint = proc.stderr.read().split("interrupted; to finish: ", 1)[1].splitlines()[0]
            manifest = json.loads((out / "manifest.json").read_text())
            assert manifest["status"] == "interrupted" and manifest["counts"]["missing"] > 0
            partial = pd.read_parquet(out / "results.parquet")
            assert partial.run_id.is_unique and not (out / "parts").exists()
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    kept = _rows_kept(out)
    assert 0 < kept < MANY_RUNS

    again = sweep_here(path, "--out", out, "--workers", "2")
    assert again.exit_code == 2 and "--resume" in again.stderr  # no silent overwrite
    if how == "ctrl-c":  # the command it printed, as printed
        words = shlex.split(hint)  # the interpreter that ran it, then -m sdc
        assert words[:3] == program_words()
        assert words[3] == "sweep" and words[-1] == "--resume"
        resumed = subprocess.run([*words, "--quiet"], capture_output=True, text=True,
                                 timeout=600)
        assert resumed.returncode == 0, resumed.stderr
    else:
        resumed = sweep_here(path, "--out", out, "--workers", "2", "--resume")
        assert resumed.exit_code == 0, resumed.output
    manifest = json.loads((out / "manifest.json").read_text())
    assert [s["runs_to_do"] for s in manifest["sessions"]] == [MANY_RUNS, MANY_RUNS - kept]
    pd.testing.assert_frame_equal(comparable(out), comparable(reference))


def test_resume_refuses_another_sweep(tmp_path):
    out = tmp_path / "out"
    assert sweep_here(write(tmp_path, "hangs", HANGS), "--out", out, "--dry-run").exit_code == 0
    tiny = write(tmp_path, "tiny", TINY.replace('choice = [3.0, 3.74, 9.0]', 'choice = [3.0]'))
    assert sweep_here(tiny, "--out", out, "--workers", "1").exit_code == 0
    other = write(tmp_path, "other", TINY.replace('choice = [3.0, 3.74, 9.0]', 'choice = [4.0]'))
    result = sweep_here(other, "--out", out, "--resume")
    assert result.exit_code == 2
    assert "holds a different sweep" in result.stderr


def test_a_directory_left_before_its_manifest_is_taken_and_others_are_refused(tmp_path):
    """A kill between the plan and the manifest leaves only plan.parquet (or its temporary
    file): a new sweep takes the directory. Any other file makes it not a sweep's."""
    sweep = write(tmp_path, "hangs", HANGS.replace("[3.0, 3.74, 9.0]", "[3.0]"))
    left = tmp_path / "left"
    left.mkdir()
    (left / "plan.parquet").write_bytes(b"half a plan")
    (left / f".plan.parquet.{os.getpid()}.tmp").write_bytes(b"")
    assert sweep_cli(sweep, "--out", left, "--workers", "1").returncode == 0
    assert len(pd.read_parquet(left / "results.parquet")) == 1
    other = tmp_path / "other"
    other.mkdir()
    (other / "notes.txt").write_text("mine")
    refused = sweep_cli(sweep, "--out", other, "--workers", "1")
    assert refused.returncode == 2 and "exists and is not a sweep directory" in refused.stderr


def test_the_resume_hint_repeats_the_options_that_shaped_the_plan(tmp_path):
    from sdc.cli.sweep import resume_command

    hint = resume_command(tmp_path / "my sweep.toml", tmp_path / "out", samples=200,
                          traces="all", executor="ray", workers=4, ray_address="10.0.0.1:6379",
                          run_timeout=30.0, batch_runs=None)
    assert shlex.split(hint) == [
        *program_words(), "sweep", str(tmp_path / "my sweep.toml"), "--out", str(tmp_path / "out"),
        "--samples", "200", "--traces", "all", "--executor", "ray", "--workers", "4",
        "--ray-address", "10.0.0.1:6379", "--run-timeout", "30.0", "--resume"]


def test_the_resume_hint_repeats_the_set_options(tmp_path):
    from sdc.cli.sweep import resume_command

    hint = resume_command(tmp_path / "s.toml", tmp_path / "out", samples=None, traces="failures",
                          executor="local", workers=2, ray_address=None, run_timeout=None,
                          batch_runs=None, overrides=("scenario.duration_s=4",
                                                      "sweep.params.ego.lane={ choice = [1] }"))
    assert shlex.split(hint)[3:] == [
        "sweep", str(tmp_path / "s.toml"), "--out", str(tmp_path / "out"),
        "--set", "scenario.duration_s=4", "--set", "sweep.params.ego.lane={ choice = [1] }",
        "--workers", "2", "--resume"]


# two short lane-keep runs: the base's duration and obstacle offset changed by --set
SET_SWEEP = f"""[sweep]
name = "set"
base = "{SCRIPTED}"
sampler = "grid"
controllers = ["lane-keep"]

[sweep.params]
"ego.speed_mps" = {{ choice = [3.0, 9.0] }}
"""
SETS = ("scenario.duration_s=4", "obstacles[0].lateral_offset_m=0.5")


def test_a_sweep_made_with_set_resumes_and_replays_with_its_values(tmp_path):
    import pyarrow.parquet as pq

    path = write(tmp_path, "set", SET_SWEEP)
    sets = [word for text in SETS for word in ("--set", text)]
    out = tmp_path / "out"
    made = sweep_here(path, "--out", out, "--workers", "1", "--traces", "all", *sets)
    assert made.exit_code == 0, made.output
    full = comparable(out)
    assert (full.sim_time_s <= 4.0).all() and len(full) == 2
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["overrides"] == list(SETS)
    assert manifest["base_scenario"]["scenario"]["duration_s"] == 4.0
    assert manifest["base_scenario"]["obstacles"][0]["lateral_offset_m"] == 0.5
    # a sweep killed after its first row: the second run has none
    results = pq.read_table(out / "results.parquet")
    pq.write_table(results.slice(0, 1), out / "results.parquet")

    refused = sweep_here(path, "--out", out, "--workers", "1", "--resume")
    assert refused.exit_code == 2
    assert ("resume it with the sweep file and options that started it (it was made with "
            "--set scenario.duration_s=4 --set 'obstacles[0].lateral_offset_m=0.5')"
            in refused.stderr)
    resumed = sweep_here(path, "--out", out, "--workers", "1", "--traces", "all", "--resume",
                         *sets)
    assert resumed.exit_code == 0, resumed.output
    manifest = json.loads((out / "manifest.json").read_text())
    assert [s["runs_to_do"] for s in manifest["sessions"]] == [2, 1]
    assert manifest["overrides"] == list(SETS)
    pd.testing.assert_frame_equal(comparable(out).sort_values("run_id").reset_index(drop=True),
                                  full.sort_values("run_id").reset_index(drop=True))
    replayed = CliRunner().invoke(main, ["replay", str(out), "--run", "00001-lane-keep",
                                         "--verify"])
    assert replayed.exit_code == 0, replayed.output
    assert "identical" in replayed.stdout


@pytest.mark.slow
def test_a_ray_session_the_process_holds_is_used_and_left_running(tmp_path, ray_session):
    import ray

    from scenarios.common.errors import SdcError

    run = expand(load_sweep(write(tmp_path, "one", TINY)))[0]
    with RayExecutor(2) as executor:
        (row,) = executor.map([RunTask(run.run_id, run.spec)])
    assert row["status"] == "ok" and ray.is_initialized()
    with pytest.raises(SdcError, match="already holds a Ray session"), \
            RayExecutor(2, address="127.0.0.1:1"):
        pass
