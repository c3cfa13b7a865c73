"""A SUMO configuration as the road and its traffic (``road.kind = "sumo_config"``):
its files resolved as SUMO resolves them, its own demand warmed up until
``traffic.enter_s``, clean entries, its vehicles as SUMO runs them, bad input named.
The real configurations are those SUMO's package ships (``tools/game``)."""

from __future__ import annotations

import gzip
import json
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ElementTree
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import sumo
from click.testing import CliRunner

from scenarios.common.errors import SpecError
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.spec.toml_io import dumps_plain, load_spec
from scenarios.sumo_net.sumo_config import (
    STEP_FROM_CONFIG,
    STEP_FROM_SPEC,
    check_config,
    config_manifest,
    config_step_s,
    last_departure_s,
    load_bundle,
    read_config,
    seconds,
)
from scenarios.world_backends import make_road
from sdc.car.geometry import boxes_overlap
from sdc.cli import main
from sdc.run.episode import run_episode

GAME_DIR = Path(sumo.SUMO_HOME) / "tools" / "game"
#: motorway, city (plain and gzipped network), ring, grid, corridor, ramp, crossing
REAL_CONFIGS = ["A10KW", "bs3d", "fkk_in", "square", "grid6", "corridor", "ramp", "cross"]


def config_plain(name: str, *, seed: int = 1, enter_s: float = 60.0, duration_s: float = 5.0,
                 controller: str = "lane-keep", speed_mps: float = 10.0) -> dict:
    return {"scenario": {"name": name, "duration_s": duration_s, "step_s": 0.1, "seed": seed},
            "road": {"kind": "sumo_config", "config_file": str(GAME_DIR / f"{name}.sumocfg"),
                     "length_m": 200.0},
            "traffic": {"enter_s": enter_s}, "obstacles": [],
            "ego": {"lane": 0, "start_m": 10.0, "speed_mps": speed_mps},
            "controller": {"name": controller}}


def write_config(folder: Path, inputs: str, time: str = "") -> Path:
    path = folder / "x.sumocfg"
    path.write_text(f"<configuration><input>{inputs}</input><time>{time}</time>"
                    "<output><tripinfo-output value='trips.xml'/></output></configuration>")
    return path


def test_files_resolve_as_sumo_resolves_them(tmp_path):
    """Comma and space separated lists, paths relative to the configuration, gzip."""
    (tmp_path / "net").mkdir()
    shutil.copy(GAME_DIR / "square" / "square.net.xml", tmp_path / "net" / "n.net.xml")
    routes = (GAME_DIR / "square" / "square.rou.xml").read_bytes()
    (tmp_path / "a.rou.xml.gz").write_bytes(gzip.compress(routes))
    (tmp_path / "b.rou.xml").write_bytes(routes.replace(b'id="', b'id="b'))
    config = write_config(tmp_path, "<net-file value='net/n.net.xml'/>"
                          "<route-files value='a.rou.xml.gz, b.rou.xml'/>",
                          "<begin value='0:1:0'/><end value='99'/><step-length value='1'/>")
    read = read_config(config)
    assert read.net_file == tmp_path / "net" / "n.net.xml"
    assert read.route_files == (tmp_path / "a.rou.xml.gz", tmp_path / "b.rou.xml")
    assert read.begin_s == 60.0
    manifest = read.manifest()
    assert manifest["overridden"] == {"end": "99", "step-length": "1"}
    assert manifest["not_applied"] == ["tripinfo-output"]
    bundle = load_bundle(config)
    assert last_departure_s(bundle) == last_departure_s(load_bundle(config))
    assert bundle.sha256 == load_bundle(config).sha256


@pytest.mark.parametrize("name, asked_s", [("A10KW", 0.5), ("cross", 0.2), ("square", 0.1),
                                           ("fokr_bs_demo", 0.05)])
def test_a_configuration_steps_as_it_asks_unless_the_spec_sets_step_s(tmp_path, name, asked_s):
    """A spec that leaves ``step_s`` out steps as its configuration asks; one that sets
    it keeps its own; the manifest says which, and a run steps so."""
    plain = config_plain(name)
    del plain["scenario"]["step_s"]
    (tmp_path / "own.toml").write_text(dumps_plain(plain))
    own = load_spec(tmp_path / "own.toml")
    assert own.scenario.step_s == asked_s == config_step_s(plain["road"]["config_file"])
    entry = config_manifest(own.road.config_file, own.scenario.step_s)
    assert (entry["step_s"], entry["step_from"]) == (asked_s, STEP_FROM_CONFIG)
    assert "step-length" not in entry["overridden"]
    assert seconds(entry["applied"]["step-length"]) == asked_s
    plain["scenario"]["step_s"] = 0.25
    (tmp_path / "set.toml").write_text(dumps_plain(plain))
    spec = load_spec(tmp_path / "set.toml")
    assert spec.scenario.step_s == 0.25
    entry = config_manifest(spec.road.config_file, spec.scenario.step_s)
    assert entry["step_from"] == STEP_FROM_SPEC
    assert seconds(entry["overridden"]["step-length"]) == asked_s


def test_a_run_steps_as_its_configuration_asks_and_odd_steps_are_refused(tmp_path):
    """square asks 0.1 s (the default is 0.064 s): the trace's clock steps 0.1 s. A
    configuration that asks none leaves the default; one that asks what no run can
    take is bad input naming scenario.step_s."""
    plain = config_plain("square", enter_s=0.0, duration_s=1.0)
    del plain["scenario"]["step_s"]
    (tmp_path / "own.toml").write_text(dumps_plain(plain))
    episode = run_episode(load_spec(tmp_path / "own.toml"))
    assert np.diff(episode.trace.floats["t_s"]) == pytest.approx(0.1)
    shutil.copy(GAME_DIR / "square" / "square.net.xml", tmp_path / "n.net.xml")
    inputs = "<net-file value='n.net.xml'/>"
    for time, expected in (("", 0.064), ("<step-length value='2'/>", None)):
        plain["road"]["config_file"] = str(write_config(tmp_path, inputs, time))
        (tmp_path / "odd.toml").write_text(dumps_plain(plain))
        if expected is not None:
            assert load_spec(tmp_path / "odd.toml").scenario.step_s == expected
            continue
        with pytest.raises(SpecError, match=r"scenario\.step_s: the configuration asks a "
                                            r"step-length of 2 s"):
            load_spec(tmp_path / "odd.toml")


def test_a_run_entering_past_its_demand_is_refused_before_sumo_simulates():
    """The A10's demand ends at 1800 s: a run (a sweep's sample, which no one checked
    before) entering at 58000 s fails at once, naming the field, instead of warming the
    motorway up for 16 hours of SUMO first."""
    with pytest.raises(SpecError, match=r"traffic\.enter_s: 58000\.0 is past the end of "
                                        r"the configuration's demand .* 1800 s"):
        run_episode(ScenarioSpec.from_plain(config_plain("A10KW", enter_s=58000.0)))


def test_sumo_times_read_as_seconds():
    assert seconds("12.5") == 12.5 and seconds("1:00:00") == 3600.0
    assert seconds("1:0:0:1") == 86_401.0 and seconds("triggered") is None


@pytest.mark.parametrize("problem", ["no config", "no network", "missing route file",
                                     "not xml", "enter after demand", "enter before begin"])
def test_bad_configurations_are_bad_input_naming_the_file_or_field(tmp_path, problem):
    shutil.copy(GAME_DIR / "square" / "square.net.xml", tmp_path / "n.net.xml")
    shutil.copy(GAME_DIR / "square" / "square.rou.xml", tmp_path / "r.rou.xml")
    config, enter_s = tmp_path / "x.sumocfg", 10.0
    if problem == "no network":
        write_config(tmp_path, "<route-files value='r.rou.xml'/>")
    elif problem == "missing route file":
        write_config(tmp_path, "<net-file value='n.net.xml'/><route-files value='gone.rou.xml'/>")
    elif problem == "not xml":
        config.write_text("<configuration><input>")
    elif problem != "no config":
        write_config(tmp_path, "<net-file value='n.net.xml'/><route-files value='r.rou.xml'/>",
                     "<begin value='5'/>")
        enter_s = 1e6 if problem == "enter after demand" else 2.0
    expected = {"no config": "no such file", "no network": "names no network",
                "missing route file": "route file 'gone.rou.xml' is not a file",
                "not xml": "not well-formed XML", "enter after demand": "past the end of",
                "enter before begin": "before the configuration's begin"}[problem]
    field = "traffic.enter_s" if problem.startswith("enter") else "road.config_file"
    with pytest.raises(SpecError, match=expected) as raised:
        check_config(config, enter_s)
    assert raised.value.field == field
    spec = tmp_path / "s.toml"
    spec.write_text(f"""[scenario]\nname = "x"\nduration_s = 2.0\n
[road]\nkind = "sumo_config"\nconfig_file = "x.sumocfg"\nlength_m = 50.0\n
[traffic]\nenter_s = {enter_s}\n\n[ego]\nlane = 0\nstart_m = 10.0\nspeed_mps = 5.0\n
[controller]\nname = "lane-keep"\n""")
    result = CliRunner().invoke(main, ["run", str(spec), "--trace", str(tmp_path / "t.parquet")])
    assert result.exit_code == 2, result.output
    assert field in result.output and "Traceback" not in result.output
    assert not (tmp_path / "t.parquet").exists()


STANDING = """<routes>
    <vType id="truck" vClass="truck" length="7.1"/>
    <route id="across" edges="left0A0 A0B0 B0right0"/>
    <route id="up" edges="bottom0A0 A0A1 A1top0"/>
    <vehicle id="parked" type="truck" route="across" depart="0">{stop}</vehicle>
    <vehicle id="car" route="up" depart="10"/>
</routes>
"""


@pytest.mark.parametrize("stop, stands_s", [
    ('<stop lane="A0B0_0" endPos="60" until="500"/>', 500.0),
    ('<stop lane="A0B0_0" endPos="60" duration="400"/>', 400.0),  # from its depart at 0
    ('<stop lane="A0B0_0" endPos="60" duration="1" triggered="true"/>', float("inf")),
])
def test_enter_after_the_last_departure_is_allowed_where_a_vehicle_surely_stands(
        tmp_path, stop, stands_s):
    """Past the demand's last departure a run may enter while a stop surely holds a
    vehicle (to its until, or its duration after the depart: the vehicle reaches
    it later; for good where it waits for a person); SUMO itself has it there."""
    import libsumo

    shutil.copy(GAME_DIR / "square" / "square.net.xml", tmp_path / "n.net.xml")
    (tmp_path / "r.rou.xml").write_text(STANDING.format(stop=stop))
    config = write_config(tmp_path, "<net-file value='n.net.xml'/><route-files value='r.rou.xml'/>",
                          "<begin value='0'/>")
    assert last_departure_s(load_bundle(config)) == max(10.0, stands_s)
    check_config(config, 350.0)
    if stands_s < float("inf"):
        with pytest.raises(SpecError, match="past the end of the configuration's demand"):
            check_config(config, stands_s + 1.0)
    libsumo.start(["sumo", "-c", str(config), "--no-step-log", "true", "--no-warnings", "true"])
    try:
        libsumo.simulationStep(350.0)
        assert "parked" in libsumo.vehicle.getIDList() and "car" not in libsumo.vehicle.getIDList()
        assert libsumo.vehicle.getSpeed("parked") == 0.0
    finally:
        libsumo.close()


def test_a_configuration_takes_no_flows_random_trips_or_warm_up():
    for traffic, field in (({"flow_vph_per_lane": 100.0}, "traffic.flow_vph_per_lane"),
                           ({"vehicles": 10}, "traffic.vehicles"),
                           ({"warm_up_s": 10.0}, "traffic.warm_up_s")):
        plain = config_plain("square")
        plain["traffic"].update(traffic)
        with pytest.raises(SpecError) as raised:
            ScenarioSpec.from_plain(plain)
        assert raised.value.field == field
    plain = config_plain("square")
    plain["road"] = {"kind": "straight", "length_m": 100.0, "lanes": 1}
    with pytest.raises(SpecError, match='only applies to road kind "sumo_config"'):
        ScenarioSpec.from_plain(plain)
    plain["traffic"] = {}
    plain["road"]["route_edges"] = ["a", "b"]
    with pytest.raises(SpecError, match='only applies to road kind "sumo_net" or "sumo_config"'):
        ScenarioSpec.from_plain(plain)


def start_overlaps(episode) -> bool:
    vehicle = episode.metadata["vehicle"]
    ego = episode.trace.body_boxes(vehicle["center_ahead_of_rear_axle_m"], vehicle["length_m"],
                                   vehicle["width_m"])[0]
    first = np.asarray(episode.trace.traffic[0]).reshape(-1, 5)
    return any(boxes_overlap(ego, box) for box in first)


@pytest.mark.slow
@pytest.mark.parametrize("name", REAL_CONFIGS)
def test_two_hundred_entries_into_real_demand_are_clean(name):
    """The ego enters SUMO's real scenarios in their own traffic at 10 m/s, lane
    keeping: over 200 runs (8 configurations, 5 seeds, 5 entry times; one
    configuration a test) no start overlaps a vehicle and no collision comes in the
    first second."""
    assert len(REAL_CONFIGS) == 8
    runs = 0
    for seed in range(1, 6):
        for enter_s in (0.0, 30.0, 60.0, 120.0, 240.0):
            plain = config_plain(name, seed=seed, enter_s=enter_s, duration_s=1.5)
            plain["traffic"]["warm_seed"] = 1  # the seeds share a warm state
            episode = run_episode(ScenarioSpec.from_plain(plain))
            row = episode.row
            assert row["status"] == "ok"
            assert not start_overlaps(episode), (name, seed, enter_s)
            assert not (row["collision"] and row["collision_time_s"] <= 1.0), (
                name, seed, enter_s, row["collision_with"], row["collision_time_s"])
            runs += 1
    assert runs == 25


def sumo_vehicles_at(name: str, t_s: float, folder: Path, seed: int) -> int:
    """Vehicles in SUMO's own run of the configuration (``sumo -c``, its options, its
    step; SUMO's random seed ``seed``) at ``t_s``; in a process of its own, on a copy
    in ``folder`` (its outputs land there)."""
    config = ElementTree.parse(GAME_DIR / f"{name}.sumocfg")
    for gui in config.getroot().findall("gui_only"):  # plain sumo refuses some (osg-view)
        config.getroot().remove(gui)
    config.write(folder / f"{name}.sumocfg")
    shutil.copy(GAME_DIR / "input_additional.add.xml", folder)
    shutil.copytree(GAME_DIR / name, folder / name)
    code = ("import sys, libsumo; libsumo.start(['sumo', '-c', sys.argv[1], '--no-step-log', "
            "'true', '--no-warnings', 'true', '--seed', sys.argv[3]]); t = float(sys.argv[2])\n"
            "while libsumo.simulation.getTime() < t - 1e-9: libsumo.simulationStep()\n"
            "print('vehicles', libsumo.vehicle.getIDCount()); libsumo.close()")
    done = subprocess.run([sys.executable, "-c", code, str(folder / f"{name}.sumocfg"),
                           str(t_s), str(seed)], capture_output=True, text=True, check=True,
                          cwd=folder)
    (count,) = [line.split()[1] for line in done.stdout.splitlines()
                if line.startswith("vehicles ")]
    return int(count)


@pytest.mark.slow
@pytest.mark.parametrize("name, enter_s", [("A10KW", 120.0), ("A10KW", 300.0),
                                           ("bs3d", 300.0), ("grid6", 120.0), ("grid6", 300.0),
                                           ("fkk_in", 300.0)])
def test_the_network_holds_what_sumos_own_run_holds_when_the_ego_enters(name, enter_s,
                                                                          tmp_path):
    """Within 10% of ``sumo -c`` run to the same time with the same random seed (its
    own step length and options; ours: our step, lane changes over 2 s, no
    teleporting, and the vehicles on the ego's entry taken off)."""
    plain = config_plain(name, enter_s=enter_s, duration_s=0.5, seed=3)
    episode = run_episode(ScenarioSpec.from_plain(plain))
    ours, theirs = episode.row["network_vehicles"], sumo_vehicles_at(name, enter_s, tmp_path, 3)
    assert theirs > 20
    assert abs(ours - theirs) <= 0.1 * theirs, (ours, theirs)


@pytest.mark.slow
def test_a_configurations_trucks_are_seen_as_trucks():
    """The A10 motorway's demand holds trucks (vClass truck, SUMO's default truck size,
    7.1 m): the trace's boxes carry each vehicle type's size, the class beside it."""
    episode = run_episode(ScenarioSpec.from_plain(config_plain("A10KW", enter_s=300.0,
                                                               duration_s=10.0)))
    classes = {c for step in episode.trace.traffic_class for c in step}
    assert "truck" in classes and "passenger" in classes
    lengths = {c: set() for c in classes}
    for boxes, step in zip(episode.trace.traffic, episode.trace.traffic_class, strict=True):
        for box, vclass in zip(np.asarray(boxes).reshape(-1, 5), step, strict=True):
            lengths[vclass].add(round(float(box[3]), 2))
    assert min(lengths["truck"]) > max(lengths["passenger"])
    assert lengths["truck"] == {7.1}  # SUMO's default for its class, no length given


@pytest.mark.slow
def test_a_sweep_over_a_configuration_ships_it_and_runs_as_a_single_run(tmp_path):
    """Workers get the configuration as one bundle; a run's trace there is the one a
    direct run gives, and the manifest says which options were overridden."""
    base = tmp_path / "a10.toml"
    plain = config_plain("A10KW", enter_s=90.0, duration_s=4.0, controller="avoid")
    base.write_text(f"""[scenario]\nname = "a10"\nduration_s = 4.0\nstep_s = 0.1\nseed = 2\n
[road]\nkind = "sumo_config"\nconfig_file = "{plain['road']['config_file']}"\nlength_m = 200.0\n
[traffic]\nenter_s = 90.0\n\n[ego]\nlane = 0\nstart_m = 10.0\nspeed_mps = 15.0\n
[controller]\nname = "avoid"\n""")
    sweep = tmp_path / "sweep.toml"
    sweep.write_text("""[sweep]\nname = "a10"\nbase = "a10.toml"\nsamples = 2\nsampler = "lhs"
seed = 1\ncontrollers = ["avoid"]\n[sweep.params]\n"ego.speed_mps" = { uniform = [12.0, 18.0] }
""")
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["sweep", str(sweep), "--out", str(out), "--workers", "2",
                                       "--quiet", "--traces", "all"])
    assert result.exit_code in (0, 1), result.output
    manifest = json.loads((out / "manifest.json").read_text())
    (config,) = manifest["sumo_config"]
    assert config["overridden"] == {
        "end": "1800", "step-length": "0.5", "time-to-teleport": "0", "no-step-log": "true"}
    assert (config["step_s"], config["step_from"]) == (0.1, STEP_FROM_SPEC)
    assert config["applied"] == {"ignore-route-errors": "true",
                                 "device.rerouting.adaptation-steps": "180"}
    fields = {entry["field"] for entry in manifest["files"].values()}
    assert "road.config_file" in fields and "warm state" in fields
    rows = pd.read_parquet(out / "results.parquet")
    assert (rows.status == "ok").all()
    for row in rows.itertuples():
        replay = CliRunner().invoke(main, ["replay", str(out), "--run", row.run_id, "--verify"])
        assert replay.exit_code == 0, replay.output


@pytest.mark.slow
def test_the_real_scenarios_family_runs_on_each_of_its_configurations(tmp_path):
    """The catalog's family over SUMO's own scenarios (sumo: paths into its
    installation): every run ends ok, on each of the three configurations, and no
    collision comes in the first second."""
    from scenarios import CATALOG_DIR

    out = tmp_path / "out"
    result = CliRunner().invoke(main, [
        "sweep", str(CATALOG_DIR / "sweeps" / "real-scenarios.toml"), "--out", str(out),
        "--samples", "3", "--workers", "2", "--quiet"])
    assert result.exit_code in (0, 1), result.output
    rows = pd.read_parquet(out / "results.parquet")
    assert (rows.status == "ok").all() and len(rows) == 9
    assert rows["p.road.config_file"].nunique() == 3
    manifest = json.loads((out / "manifest.json").read_text())
    assert {c["file"] for c in manifest["sumo_config"]} == set(rows["p.road.config_file"])
    report = CliRunner().invoke(main, ["report", str(out)])
    assert report.exit_code in (0, 1), report.output
    text = (out / "report.md").read_text()
    for name in set(rows["p.road.config_file"]):
        assert f"SUMO configuration {name}: its own demand from" in text
    early = rows.collision.astype(bool) & (rows.collision_time_s <= 1.0)
    assert not early.any()


def test_a_configuration_without_lanes_for_cars_is_bad_input():
    """SUMO's rail demo: its network has tracks only."""
    plain = config_plain("rail", enter_s=10.0)
    with pytest.raises(SpecError, match="no lane open to passenger cars") as raised:
        make_road(ScenarioSpec.from_plain(plain))
    assert raised.value.field == "road.config_file"
