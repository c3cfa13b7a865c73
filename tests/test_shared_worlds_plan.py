"""Shared worlds in a sweep's plan ([sweep] egos_per_world): which runs share a world,
their seats and their traffic seed; and a sweep of them for real, resumed and on Ray.

Only the last tests run SUMO (marked slow)."""

from __future__ import annotations

import dataclasses
import json
import shutil
import subprocess
import sys
from collections import defaultdict
from pathlib import Path

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from scenarios import CATALOG_DIR
from scenarios.common.errors import SpecError
from scenarios.spec.sweep_plan import expand, plan_sha256
from scenarios.spec.sweep_spec import SweepSpec, load_sweep
from scenarios.spec.toml_io import load_spec
from scenarios.spec.world_seating import (
    WorldSeat,
    group_worlds,
    on_world_road,
    traffic_seed,
    world_fields,
)

DATA = Path(__file__).parent / "data"
QUICK_TOWN = DATA / "grid-town-quick.toml"
TOWN_NET = CATALOG_DIR / "networks" / "grid-10x10.net.xml"
SDC = [sys.executable, "-m", "sdc"]


def sweep_plain(**table) -> dict:
    params = table.pop("params", {"ego.speed_mps": {"uniform": [3.0, 6.0]}})
    return {"sweep": {"name": "worlds", "base": str(QUICK_TOWN), "samples": 10,
                      "sampler": "random", "seed": 3, "controllers": ["seed", "lane-keep"],
                      **table, "params": params}}


def make(**table) -> SweepSpec:
    return SweepSpec.from_plain(sweep_plain(**table), DATA)


def worlds_of(plan) -> dict[str, list]:
    """The runs of each world, in plan order."""
    worlds: dict[str, list] = defaultdict(list)
    for run in plan:
        worlds[run.world.world_id].append(run)
    return dict(worlds)


# ------------------------------------------------------ the plan


def test_a_sweep_seats_each_controllers_runs_in_worlds_of_up_to_r():
    plain_plan = expand(make())
    plan = expand(make(egos_per_world=2, runs_per_world=4))
    assert len(plan) == len(plain_plan) == 20
    assert [r.run_id for r in plan] == [r.run_id for r in plain_plan]
    assert all(run.world is not None and run.spec is not None for run in plan)
    worlds = worlds_of(plan)
    for world_id, runs in worlds.items():
        assert 1 <= len(runs) <= 4
        assert len({r.controller for r in runs}) == 1  # one controller a world
        first = runs[0]
        assert world_id == f"w{first.sample:05d}-{first.controller}"
        assert [r.world.slot for r in runs] == list(range(len(runs)))  # in plan order
        assert [r.index for r in runs] == sorted(r.index for r in runs)
        # one traffic: the first run's seed (its scenario's: the base sets no warm seed)
        assert {r.spec.traffic.warm_seed for r in runs} == {first.seed}
        assert {traffic_seed(r.spec) for r in runs} == {first.seed}
        assert all(world_fields(r.spec) == world_fields(first.spec) for r in runs)
        # the rest of each run stays its own: its seed (route), start, speed, controller
        assert len({r.seed for r in runs}) == len(runs)
    # 10 runs a controller: 4 + 4 + 2, each sample's runs seated alike for both
    sizes = {c: [len(w) for w in worlds.values() if w[0].controller == c]
             for c in ("seed", "lane-keep")}
    assert sizes == {"seed": [4, 4, 2], "lane-keep": [4, 4, 2]}
    assert sorted(worlds) == ["w00000-lane-keep", "w00000-seed", "w00004-lane-keep",
                              "w00004-seed", "w00008-lane-keep", "w00008-seed"]
    # each run's spec is the one it has alone, but for the world's traffic seed
    for run, alone in zip(plan, plain_plan, strict=True):
        assert alone.world is None and alone.spec.traffic.warm_seed is None
        assert dataclasses.replace(run.spec, traffic=alone.spec.traffic) == alone.spec
        assert run.params == alone.params and run.seed == alone.seed


def test_runs_whose_road_differs_only_by_their_route_share_a_world():
    """The route through the network, its length and its turns are each ego's own: runs
    swept over them share worlds (each keeping its own), as runs of one route do."""
    plan = expand(make(egos_per_world=2, runs_per_world=4, params={
        "road.length_m": {"uniform": [150.0, 400.0]},
        "road.route_turns": {"choice": ["straight", "any"]}}))
    worlds = worlds_of(plan)
    assert len(worlds) == 6  # 10 runs a controller in worlds of 4: 4 + 4 + 2
    mixed = [runs for runs in worlds.values()
             if len({(r.spec.road.length_m, r.spec.road.route_turns) for r in runs}) > 1]
    assert len(mixed) == 6
    for runs in worlds.values():
        assert len({json.dumps(world_fields(r.spec), sort_keys=True) for r in runs}) == 1
    lengths = {r.run_id: r.spec.road.length_m for r in plan}
    assert len(set(lengths.values())) == 10  # each sample its own length, kept


def test_a_worlds_run_takes_the_worlds_network_files_and_keeps_its_route():
    """On a worker a world's runs read the network where the worker holds it (the
    world's spec, its files localised): each keeps its own route."""
    spec = load_spec(QUICK_TOWN)
    own = dataclasses.replace(spec, road=dataclasses.replace(
        spec.road, length_m=222.0, route_turns="any", see_edges=False))
    local = dataclasses.replace(spec, road=dataclasses.replace(
        spec.road, net_file="/worker/files/grid.net.xml"))
    moved = on_world_road(own, local)
    assert moved.road.net_file == "/worker/files/grid.net.xml"
    assert (moved.road.length_m, moved.road.route_turns, moved.road.see_edges) == (
        222.0, "any", False)
    assert dataclasses.replace(moved, road=own.road) == own


def test_runs_of_different_traffic_never_share_a_world():
    plan = expand(make(egos_per_world=4, runs_per_world=4, params={
        "ego.speed_mps": {"uniform": [3.0, 6.0]},
        "traffic.vehicles": {"choice": [200, 300]}}))
    values = {r.spec.traffic.vehicles for r in plan}
    assert values == {200, 300}
    worlds = worlds_of(plan)
    for runs in worlds.values():
        assert len(runs) <= 4
        assert len({r.spec.traffic.vehicles for r in runs}) == 1
        assert len({r.controller for r in runs}) == 1
        assert [r.world.slot for r in runs] == list(range(len(runs)))
        assert {r.spec.traffic.warm_seed for r in runs} == {runs[0].seed}
    # each (controller, traffic) class fills its worlds in plan order, up to 4
    for controller in ("seed", "lane-keep"):
        for vehicles in (200, 300):
            runs = [r for r in plan if r.controller == controller
                    and r.spec.traffic.vehicles == vehicles]
            chunks = [runs[k:k + 4] for k in range(0, len(runs), 4)]
            assert [[r.run_id for r in worlds[c[0].world.world_id]] for c in chunks] == \
                [[r.run_id for r in c] for c in chunks]


def test_one_ego_a_world_leaves_the_plan_as_it_was():
    without = make()
    one = make(egos_per_world=1)
    assert one.egos_per_world == 1 and "egos_per_world" not in one.to_plain()["sweep"]
    plan = expand(one)
    assert all(run.world is None for run in plan)
    assert plan_sha256(plan) == plan_sha256(expand(without))
    assert [r.spec for r in plan] == [r.spec for r in expand(without)]
    four = make(egos_per_world=4)
    assert four.to_plain()["sweep"]["egos_per_world"] == 4
    assert plan_sha256(expand(four)) != plan_sha256(plan)  # the seats are in the digest


def test_group_worlds_on_its_own():
    spec = load_spec(QUICK_TOWN)
    specs = [dataclasses.replace(spec, scenario=dataclasses.replace(spec.scenario, seed=s))
             for s in (5, 6, 7)]
    runs = [(k, f"{k:03d}", "seed", s) for k, s in enumerate(specs)]
    grouped = group_worlds(runs, 2, 1)
    assert {k: seat for k, (seat, _) in grouped.items()} == {
        0: WorldSeat("w000-seed", 0, 1), 1: WorldSeat("w000-seed", 1, 1),
        2: WorldSeat("w002-seed", 0, 1)}
    assert [grouped[k][1].traffic.warm_seed for k in range(3)] == [5, 5, 7]
    assert [grouped[k][1].scenario.seed for k in range(3)] == [5, 6, 7]


@pytest.mark.parametrize("k", [2, 3, 8])
def test_a_world_serves_two_runs_a_seat_unless_told(k):
    """By default a world of K seats serves 2K runs (the seat a run frees is taken by
    the next); runs_per_world says otherwise, never fewer than the seats, and only where
    runs share worlds. Each run's seat carries its world's K."""
    sweep = make(egos_per_world=k)
    assert sweep.runs_per_world == 2 * k
    assert sweep.to_plain()["sweep"]["runs_per_world"] == 2 * k
    plan = expand(sweep)
    assert {len(runs) for runs in worlds_of(plan).values()} <= set(range(1, 2 * k + 1))
    assert max(len(runs) for runs in worlds_of(plan).values()) == min(2 * k, 10)
    assert {run.world.seats for run in plan} == {k}
    assert make(egos_per_world=k, runs_per_world=k).runs_per_world == k
    with pytest.raises(SpecError) as e:
        make(egos_per_world=k, runs_per_world=k - 1)
    assert e.value.field == "sweep.runs_per_world" and "egos_per_world" in e.value.message
    with pytest.raises(SpecError) as e:
        make(runs_per_world=4)  # one ego a world: no world has turns to take
    assert e.value.field == "sweep.runs_per_world"
    assert make(runs_per_world=1).runs_per_world == 1


def test_at_most_the_measured_egos_share_a_world():
    """16 egos a world is the most the interference table measured to agree with one:
    more is refused, naming the field."""
    assert make(egos_per_world=16).egos_per_world == 16
    for k in (0, 17, 64):
        with pytest.raises(SpecError) as e:
            make(egos_per_world=k)
        assert e.value.field == "sweep.egos_per_world"


def test_a_highway_base_cannot_share_worlds(tmp_path):
    base = tmp_path / "highway.toml"
    text = (CATALOG_DIR / "highway-obstacle.toml").read_text()
    base.write_text(text.replace("seed = 7", 'seed = 7\nbackend = "highway"', 1))
    assert load_spec(base).scenario.backend == "highway"
    plain = sweep_plain(egos_per_world=2)
    plain["sweep"]["base"] = str(base)
    with pytest.raises(SpecError) as e:
        SweepSpec.from_plain(plain, tmp_path)
    assert str(e.value).startswith("sweep.egos_per_world")
    assert e.value.field == "sweep.egos_per_world" and "highway" in e.value.message
    # one ego a world is any backend's
    plain["sweep"]["egos_per_world"] = 1
    assert SweepSpec.from_plain(plain, tmp_path).egos_per_world == 1
    # from a file, the message names the file and the field
    sweep_file = tmp_path / "sweep.toml"
    sweep_file.write_text(f'[sweep]\nname = "h"\nbase = "{base}"\nsamples = 2\n'
                          'egos_per_world = 2\n\n[sweep.params]\n'
                          '"ego.speed_mps" = { uniform = [10.0, 20.0] }\n')
    with pytest.raises(SpecError) as e:
        load_sweep(sweep_file)
    assert e.value.field == "sweep.egos_per_world"
    assert str(e.value).startswith(f"{sweep_file}: sweep.egos_per_world")


@pytest.mark.parametrize("base", ["highway-obstacle.toml", "seed-lesson.toml",
                                  "avoid-roads-curve.toml"])
def test_a_built_road_base_cannot_share_worlds(base):
    """Every ego of a built road starts at ego.start_m of the same lane: none could be
    placed apart, so the sweep is refused, naming the field."""
    plain = sweep_plain(egos_per_world=2)
    plain["sweep"]["base"] = str(CATALOG_DIR / base)
    kind = load_spec(CATALOG_DIR / base).road.kind
    assert kind in ("straight", "curve")
    with pytest.raises(SpecError) as e:
        SweepSpec.from_plain(plain, CATALOG_DIR)
    assert e.value.field == "sweep.egos_per_world"
    assert "built road" in e.value.message and "network" in e.value.message
    plain["sweep"]["egos_per_world"] = 1
    assert SweepSpec.from_plain(plain, CATALOG_DIR).egos_per_world == 1


def test_runs_swept_onto_the_highway_backend_are_refused_or_run():
    """A sumo base whose sweep draws scenario.backend = "highway" for some samples: with
    egos_per_world = 2 the sweep is either refused (naming sweep.egos_per_world) or its
    highway runs run (alone: the highway backend holds one ego)."""
    from sdc.batch.sweeps.sweep_runner import plan_tasks
    from sdc.batch.tasks.task import execute, rows_of

    plain = {"sweep": {"name": "hw", "base": str(CATALOG_DIR / "seed-lesson.toml"),
                       "samples": 4, "sampler": "random", "seed": 3,
                       "controllers": ["lane-keep"], "egos_per_world": 2, "params": {
                           "scenario.backend": {"choice": ["highway"]},
                           "scenario.duration_s": {"choice": [2.0]}}}}
    try:
        sweep = SweepSpec.from_plain(plain, CATALOG_DIR)
    except SpecError as e:
        assert e.field == "sweep.egos_per_world"
        return
    plan = expand(sweep)
    assert all(run.spec.scenario.backend == "highway" for run in plan)
    rows = [row for task in plan_tasks(plan, set(), None, "none")
            for row in rows_of(execute(task))]
    assert sorted(row["run_id"] for row in rows) == [run.run_id for run in plan]
    assert [row["error"] for row in rows if row["status"] != "ok"] == []


# ------------------------------------------------------ a sweep for real (SUMO)

TOWN_BASE = f"""[scenario]
name = "town-small"
duration_s = 5.0
step_s = 0.064
seed = 1

[road]
kind = "sumo_net"
net_file = "{TOWN_NET}"
length_m = 300.0

[traffic]
vehicles = 300
speed_dev = 0.1
warm_up_s = 10.0

[[obstacles]]
kind = "car"
lane = 0
position_m = 80.0

[ego]
lane = 0
start_m = 10.0
speed_mps = 4.0

[controller]
name = "seed"
"""
SAMPLES, CONTROLLERS, EGOS = 8, ["seed", "lane-keep"], 4


def town_sweep(tmp_path: Path) -> Path:
    base = tmp_path / "town-small.toml"
    base.write_text(TOWN_BASE)
    path = tmp_path / "worlds.toml"
    path.write_text(f"""[sweep]
name = "worlds"
base = "{base}"
samples = {SAMPLES}
sampler = "random"
seed = 5
controllers = {json.dumps(CONTROLLERS)}
egos_per_world = {EGOS}

[sweep.params]
"ego.speed_mps" = {{ uniform = [3.0, 8.0] }}
""")
    return path


def sweep_cli(*args) -> subprocess.CompletedProcess:
    return subprocess.run([*SDC, "sweep", *map(str, args), "--quiet"], capture_output=True,
                          text=True, timeout=600)


def comparable(out_dir: Path) -> pd.DataFrame:
    """The results without what differs between sessions: wall time."""
    return pd.read_parquet(out_dir / "results.parquet").drop(columns=["wall_time_s"])


@pytest.fixture(scope="module")
def swept(tmp_path_factory, temporary_cache) -> tuple[Path, Path]:
    """The town sweep, run once for the module by the command line: its file and its
    directory (read only: tests copy it)."""
    tmp_path = tmp_path_factory.mktemp("worlds")
    path, out = town_sweep(tmp_path), tmp_path / "reference"
    result = sweep_cli(path, "--out", out, "--workers", "2")
    assert result.returncode == 0, result.stderr
    return path, out


@pytest.mark.slow
def test_a_sweep_of_shared_worlds_fills_the_world_columns(swept):
    path, out = swept
    results = pd.read_parquet(out / "results.parquet")
    plan = expand(load_sweep(path))
    assert list(results.run_id) == [r.run_id for r in plan]
    assert (results.status == "ok").all(), results.error.dropna().tolist()
    assert results.world_id.notna().all() and results.world_slot.notna().all()
    assert results.world_egos.notna().all()
    seats = {r.run_id: (r.world.world_id, r.world.slot) for r in plan}
    assert {row.run_id: (row.world_id, row.world_slot) for row in results.itertuples()} == seats
    # by default a world serves two runs a seat
    assert results.world_id.nunique() == len(CONTROLLERS) * SAMPLES // (2 * EGOS)
    for world_id, runs in results.groupby("world_id"):
        assert len(runs) == 2 * EGOS and runs.controller.nunique() == 1, world_id
        assert sorted(runs.world_slot) == list(range(len(runs)))
        assert (runs.world_egos == len(runs)).all()
        # never more than its seats in it at once; runs entered as seats freed
        first, last = runs.world_entry_step, runs.world_entry_step + runs.steps - 1
        for step in range(int(last.max()) + 1):
            assert ((first <= step) & (step <= last)).sum() <= EGOS, (world_id, step)
        assert (first == 0).any() and (first > 0).sum() >= EGOS, world_id
        assert runs.warm_state.nunique() == 1  # one traffic, one warm state
    by_controller = results.groupby("controller").trace_sha256
    assert (by_controller.nunique() == SAMPLES).all()
    # the obstacle 80 m ahead is out of reach in 5 s, so the seed controller only keeps its
    # lane: a sample's two runs, in their controllers' worlds seated alike, are one run
    traces = results.pivot(index="sample", columns="controller", values="trace_sha256")
    assert (traces["seed"] == traces["lane-keep"]).all()
    plan_table = pd.read_parquet(out / "plan.parquet")
    assert list(plan_table.world_id) == list(results.world_id)


@pytest.mark.slow
def test_the_report_says_what_the_shared_worlds_cost_and_how_wide_they_made_the_intervals(
        swept, tmp_path):
    """The report of the town sweep: SUMO's steps and the wall time of its simulations
    against the runs alone, each said measured or estimated, and each controller's
    design effect; in summary.json the same numbers, measured from the rows: the runs of
    one simulation each timed the whole of it."""
    from analysis.report.sweep_report import write_report

    _, reference = swept
    out = tmp_path / "report"
    shutil.copytree(reference, out)
    report = write_report(out)
    results = pd.read_parquet(out / "results.parquet")
    sharing = json.loads((out / "summary.json").read_text())["shared_worlds"]
    assert sharing["steps_alone"] == results.steps.sum()
    assert sharing["sumo_steps"] < sharing["steps_alone"]  # fewer steps shared
    ends = results.world_entry_step + results.steps
    assert sharing["sumo_steps"] == ends.groupby(results.world_id).max().sum()
    assert sharing["egos_per_step"] == pytest.approx(
        sharing["steps_alone"] / sharing["sumo_steps"], abs=1e-3)
    for _, runs in results.groupby("world_id"):  # one simulation: its runs timed it
        assert runs.wall_time_s.max() < 1.1 * runs.wall_time_s.min(), runs.wall_time_s
    text = "\n".join(report.terminal)
    assert f"SUMO stepped {sharing['sumo_steps']:,} steps for the 16 runs (measured" in text
    assert "had each run a world of its own (estimated: the sum of the runs' steps)" in text
    assert "s of wall time (measured: a run's wall_time_s is its world's)" in text
    assert f"their SUMO steps carried {sharing['egos_per_step']:.2f} egos on average" in text
    assert "seed's completed rate: design effect" in text
    assert "lane-keep's completed rate: design effect" in text
    page = (out / "report.html").read_text()
    assert "Cost of sharing" in page and "Clustering: runs that share their traffic" in page


@pytest.mark.slow
def test_a_resumed_sweep_of_shared_worlds_is_the_uninterrupted_one(swept, tmp_path):
    path, reference = swept
    out = tmp_path / "resumed"
    shutil.copytree(reference, out)
    # what Ctrl-C leaves: results.parquet with the runs finished so far, no parts
    table = pq.read_table(out / "results.parquet")
    ids = table.column("run_id").to_pylist()
    worlds = table.column("world_id").to_pylist()
    lost = {ids[0], ids[len(ids) - 1], ids[len(ids) - 3]}  # in two worlds, one run of
    kept = table.filter(pa.array([i not in lost for i in ids]))
    pq.write_table(kept, out / "results.parquet")
    for run_id in lost:
        (out / "traces" / f"{run_id}.parquet").unlink(missing_ok=True)
    assert len({worlds[ids.index(i)] for i in lost}) >= 2

    resumed = sweep_cli(path, "--out", out, "--workers", "2", "--resume")
    assert resumed.returncode == 0, resumed.stderr
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["status"] == "complete"
    assert manifest["sessions"][-1]["runs_to_do"] == len(lost)
    pd.testing.assert_frame_equal(comparable(out), comparable(reference))
    assert sorted(p.name for p in (out / "traces").iterdir()) == \
        sorted(p.name for p in (reference / "traces").iterdir())


@pytest.mark.slow
def test_ray_runs_the_shared_worlds_as_local_processes_do(swept, tmp_path, ray_session):
    from sdc.batch.executors.ray_executor import RayExecutor
    from sdc.batch.sweeps.progress import QuietReporter
    from sdc.batch.sweeps.sweep_runner import run_sweep

    path, reference = swept
    outcome = run_sweep(load_sweep(path), tmp_path / "ray", RayExecutor(2), QuietReporter())
    assert outcome.counts == {"ok": SAMPLES * len(CONTROLLERS), "error": 0, "timeout": 0,
                              "missing": 0}
    pd.testing.assert_frame_equal(comparable(tmp_path / "ray"), comparable(reference))


@pytest.mark.slow
def test_a_run_that_entered_a_world_under_way_replays_to_its_trace(swept):
    """sdc replay --verify re-simulates the run's world, its runs entering where they
    entered: the replayed trace of a run that entered as a seat freed is its trace."""
    _, reference = swept
    results = pd.read_parquet(reference / "results.parquet")
    traced = [p.stem for p in (reference / "traces").iterdir()]
    late = results[(results.world_entry_step > 0) & results.run_id.isin(traced)]
    assert len(late), results[["run_id", "world_entry_step", "outcome"]]
    run_id = late.sort_values("world_entry_step").run_id.iloc[-1]  # the last to enter
    replay = subprocess.run([*SDC, "replay", str(reference), "--run", run_id, "--verify"],
                            capture_output=True, text=True, timeout=600)
    assert replay.returncode == 0, replay.stdout + replay.stderr
    assert "re-simulating the world" in replay.stdout and "identical" in replay.stdout
