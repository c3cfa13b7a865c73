"""Files that travel with a job: gathered and hashed on the driver, copied and
checked by the workers; a file a worker cannot have is an error row naming it."""

from __future__ import annotations

import dataclasses
import hashlib
import os
import re
from pathlib import Path

import pytest

from scenarios import CATALOG_DIR
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.spec.toml_io import load_spec
from scenarios.sumo_net.road_source import road_source
from sdc.batch.executors.local_executor import LocalExecutor
from sdc.batch.executors.ray_executor import RayExecutor
from sdc.batch.executors.worker_files import FileLost, WorkerFiles
from sdc.batch.executors.worker_run import deliver, run_in_worker
from sdc.batch.tasks.job_files import FileCatalog
from sdc.batch.tasks.run_task import RunTask
from sdc.batch.tasks.task import execute

PLUGIN = Path(__file__).resolve().parent.parent / "examples" / "cautious.py"
# a controller of the same name that drives differently: what a stale copy would run
IMPOSTOR = """from sdc import Command
class Cautious:
    def __init__(self, params):
        self.phase = "impostor"
    def step(self, obs):
        return Command(steer_rad=0.5, accel_mps2=0.0)
"""


def sha256(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def lesson(controller: str = f"{PLUGIN}:Cautious", seed: int = 0,
           duration_s: float = 6.0) -> ScenarioSpec:
    spec = load_spec(CATALOG_DIR / "seed-lesson.toml").with_controller(controller)
    return dataclasses.replace(spec, scenario=dataclasses.replace(
        spec.scenario, seed=seed, duration_s=duration_s))


def test_the_catalog_names_what_a_run_reads_besides_its_spec():
    catalog = FileCatalog()
    files = {f.field: f for f in catalog.files(lesson())}
    assert set(files) == {"network", "controller.name"}
    built = road_source(lesson().road).network_file()
    assert files["network"].sha256 == sha256(built) and files["network"].name == built.name
    assert files["controller.name"].driver_path == str(PLUGIN)
    assert files["controller.name"].sha256 == sha256(PLUGIN)
    assert catalog.payload(sha256(PLUGIN)) == PLUGIN.read_bytes()

    highway = lesson("seed")
    highway = dataclasses.replace(highway, scenario=dataclasses.replace(
        highway.scenario, backend="highway"))
    assert catalog.files(highway) == ()  # no SUMO network, a built-in controller

    town = load_spec(CATALOG_DIR / "grid-town.toml")
    files = {f.field: f for f in catalog.files(town)}
    assert set(files) == {"road.net_file", "road edges"}
    assert files["road.net_file"].sha256 == sha256(town.road.net_file)
    assert files["road edges"].name.startswith(files["road.net_file"].sha256[:20])
    assert set(catalog.manifest_entries()) == {str(built), str(PLUGIN), town.road.net_file,
                                               files["road edges"].driver_path}


@pytest.mark.slow
def test_a_worker_runs_on_its_own_copies_and_records_the_driver_paths(tmp_path):
    catalog = FileCatalog()
    spec = lesson()
    task = RunTask("r", spec, trace_path=tmp_path / "driver" / "r.parquet",
                   files=catalog.files(spec))
    (tmp_path / "driver").mkdir()
    worker = WorkerFiles(tmp_path / "worker")
    local = worker.localise(task, lambda f: catalog.payload(f.sha256))
    plugin_copy = tmp_path / "worker" / sha256(PLUGIN) / "cautious.py"
    assert local.spec.controller.name == f"{plugin_copy}:Cautious"
    assert plugin_copy.read_bytes() == PLUGIN.read_bytes()
    assert local.cache_dir == tmp_path / "worker" / sha256(road_source(spec.road).network_file())
    assert local.recorded_spec == spec

    row = deliver(task, run_in_worker(task, execute, worker, lambda f: None))
    assert row["status"] == "ok" and row["controller"] == "Cautious"
    alone = execute(RunTask("r", spec, trace_path=tmp_path / "alone.parquet"))
    assert row["trace_sha256"] == alone["trace_sha256"]
    # the trace the driver wrote is the one a run in this process writes, metadata and all
    assert task.trace_path.read_bytes() == (tmp_path / "alone.parquet").read_bytes()


def test_bytes_that_do_not_match_the_hash_are_refused(tmp_path):
    catalog = FileCatalog()
    (plugin,) = [f for f in catalog.files(lesson()) if f.field == "controller.name"]
    with pytest.raises(FileLost, match=f"controller.name: {PLUGIN} .*received have sha256"):
        WorkerFiles(tmp_path).ensure(plugin, lambda f: IMPOSTOR.encode())
    with pytest.raises(FileLost, match="is missing, and the job's bytes are not at hand"):
        WorkerFiles(tmp_path).ensure(plugin, lambda f: None)
    assert not (tmp_path / plugin.sha256 / "cautious.py").exists()


@pytest.mark.slow
def test_a_local_worker_that_lost_its_copy_gives_an_error_row_naming_the_file(
        tmp_path, monkeypatch):
    monkeypatch.setenv("SDC_CACHE_DIR", str(tmp_path / "cache"))  # the workers' too
    copy = tmp_path / "cache" / "job-files" / sha256(PLUGIN) / "cautious.py"
    with LocalExecutor(1) as executor:
        (first,) = executor.map([RunTask("first", lesson(seed=1))])
        assert first["status"] == "ok" and copy.read_bytes() == PLUGIN.read_bytes()
        copy.write_text(IMPOSTOR)  # the worker was sent the bytes once: they are gone
        (changed,) = executor.map([RunTask("changed", lesson(seed=2))])
        copy.unlink()
        (missing,) = executor.map([RunTask("missing", lesson(seed=3))])
    assert changed["status"] == "error" and missing["status"] == "error"
    assert f"controller.name: {PLUGIN} (sha256 {sha256(PLUGIN)[:12]}...)" in changed["error"]
    assert f"has sha256 {hashlib.sha256(IMPOSTOR.encode()).hexdigest()[:12]}" in changed["error"]
    assert "not run" in changed["error"] and changed["steps"] is None
    assert "is missing" in missing["error"] and str(PLUGIN) in missing["error"]


@pytest.mark.slow
def test_a_ray_worker_mends_a_lost_copy_from_the_job_bytes(tmp_path, monkeypatch,
                                                          fresh_ray):
    monkeypatch.setenv("SDC_CACHE_DIR", str(tmp_path / "cache"))  # Ray's workers inherit it
    copy = tmp_path / "cache" / "job-files" / sha256(PLUGIN) / "cautious.py"
    with RayExecutor(1) as executor:
        (first,) = executor.map([RunTask("first", lesson(seed=1))])
        copy.write_text(IMPOSTOR)
        (again,) = executor.map([RunTask("again", lesson(seed=1))])
    assert first["status"] == again["status"] == "ok"
    assert again["trace_sha256"] == first["trace_sha256"]  # the driver's bytes ran
    assert copy.read_bytes() == PLUGIN.read_bytes()


def test_a_file_the_driver_cannot_read_is_an_error_row_naming_it(tmp_path):
    gone = tmp_path / "gone.py"
    with LocalExecutor(1) as executor:
        (row,) = executor.map([RunTask("r", lesson(f"{gone}:Cautious"))])
    assert row["status"] == "error" and str(gone) in row["error"]
    assert os.path.basename(str(gone)) in row["error"]


TOWN_SWEEP = """[sweep]
name = "town"
base = "town.toml"
samples = 2
sampler = "random"
controllers = ["seed"]

[sweep.params]
"ego.speed_mps" = { uniform = [3.0, 6.0] }
"""


@pytest.mark.slow
def test_the_manifest_records_the_network_file_and_resume_refuses_a_changed_one(tmp_path):
    import json
    import shutil

    from scenarios.common.errors import SdcError
    from scenarios.spec.sweep_spec import load_sweep
    from sdc.batch.sweeps.progress import QuietReporter
    from sdc.batch.sweeps.sweep_runner import run_sweep

    net = tmp_path / "town.net.xml"
    shutil.copy(CATALOG_DIR / "networks" / "grid-10x10.net.xml", net)
    town = (CATALOG_DIR / "grid-town.toml").read_text()
    town = town.replace('"networks/grid-10x10.net.xml"', '"town.net.xml"')
    town = re.sub(r"warm_up_s = [0-9.]+", "warm_up_s = 0.0",
                  town.replace("vehicles = 2000", "vehicles = 10"))
    (tmp_path / "town.toml").write_text(town.replace("duration_s = 30.0", "duration_s = 3.0"))
    (tmp_path / "sweep.toml").write_text(TOWN_SWEEP)
    out = tmp_path / "out"
    outcome = run_sweep(load_sweep(tmp_path / "sweep.toml"), out, LocalExecutor(1),
                        QuietReporter(), traces="none")
    assert outcome.counts["ok"] == 2
    files = json.loads((out / "manifest.json").read_text())["files"]
    assert files[str(net)] == {"field": "road.net_file", "sha256": sha256(net)}
    assert {entry["field"] for entry in files.values()} == {"road.net_file", "road edges"}

    net.write_text(net.read_text().replace("</net>", "<!-- edited -->\n</net>"))
    with pytest.raises(SdcError, match=f"--resume: the network file {net} changed since"):
        run_sweep(load_sweep(tmp_path / "sweep.toml"), out, LocalExecutor(1),
                  QuietReporter(), resume=True)
