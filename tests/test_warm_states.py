"""Warm states: a run gives the same trace whether its traffic's warm state was
computed in the run, found in the cache, shipped with a sweep's job or rebuilt
by ``sdc replay``; sweeps draw their samples from as many states as they say."""

from __future__ import annotations

import dataclasses
import json
import re
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from analysis.report.settling_report import TITLE as SETTLING_TITLE
from analysis.report.sweep_report import write_report
from scenarios import CATALOG_DIR
from scenarios.common.errors import SdcError, SpecError
from scenarios.common.file_read import file_sha256
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.spec.sweep_plan import expand
from scenarios.spec.sweep_spec import load_sweep, warm_seeds
from scenarios.spec.toml_io import load_spec
from scenarios.sumo.sumo_world import SumoWorld
from scenarios.sumo.warm_state import WARM_FORMAT, WarmState, cached_path, warm_key
from scenarios.sumo_net.road_source import road_source
from scenarios.world_backends import make_road
from sdc.batch.executors.local_executor import LocalExecutor
from sdc.batch.sweeps.progress import QuietReporter
from sdc.batch.sweeps.sweep_runner import run_sweep
from sdc.cli import main
from sdc.run.episode import run_episode

REPO = Path(__file__).resolve().parent.parent
TOWN_NET = CATALOG_DIR / "networks" / "grid-10x10.net.xml"


def town(seed: int = 1, warm_up_s: float = 20.0, vehicles: int = 300, **traffic) -> ScenarioSpec:
    """Grid-town, smaller: 300 cars warmed up 20 s, a 6 s run."""
    spec = load_spec(CATALOG_DIR / "grid-town.toml")
    return dataclasses.replace(
        spec, scenario=dataclasses.replace(spec.scenario, seed=seed, duration_s=6.0),
        traffic=dataclasses.replace(spec.traffic, vehicles=vehicles, warm_up_s=warm_up_s,
                                    **traffic))


def highway(seed: int = 1) -> ScenarioSpec:
    """Two lanes of flows at 1200 vph, warmed up 15 s."""
    spec = load_spec(CATALOG_DIR / "highway-obstacle.toml")
    return dataclasses.replace(
        spec, scenario=dataclasses.replace(spec.scenario, seed=seed, duration_s=6.0),
        traffic=dataclasses.replace(spec.traffic, flow_vph_per_lane=1200.0, warm_up_s=15.0))


def fresh_cache(path: Path, monkeypatch) -> Path:
    monkeypatch.setenv("SDC_CACHE_DIR", str(path))
    return path


def sha_in_fresh_process(spec: ScenarioSpec, tmp_path: Path) -> str:
    spec_file = tmp_path / "spec.json"
    spec_file.write_text(json.dumps(spec.to_plain()))
    code = ("import json, sys; from scenarios.spec.scenario_spec import ScenarioSpec; "
            "from sdc.run.episode import run_episode; "
            "spec = ScenarioSpec.from_plain(json.load(open(sys.argv[1]))); "
            "print(run_episode(spec).row['trace_sha256'])")
    out = subprocess.run([sys.executable, "-c", code, str(spec_file)], cwd=REPO,
                         capture_output=True, text=True, check=True)
    return out.stdout.strip()


@pytest.mark.slow
@pytest.mark.parametrize("make", [town, highway], ids=["town", "highway"])
def test_computed_cached_and_fresh_process_warm_states_give_one_trace(make, tmp_path,
                                                                      monkeypatch):
    fresh_cache(tmp_path / "cache", monkeypatch)
    spec = make()
    computed = run_episode(spec)  # computes the state, then starts afresh on it
    key = computed.row["warm_state"]
    assert key is not None and len(list((tmp_path / "cache" / "warm-states").iterdir())) == 1
    cached = run_episode(spec)
    assert cached.row["trace_sha256"] == computed.row["trace_sha256"]
    assert sha_in_fresh_process(spec, tmp_path) == computed.row["trace_sha256"]
    # the traffic is there: warmed up, and (on the highway) still flowing in
    assert computed.row["network_vehicles"] > 10


@pytest.mark.slow
def test_a_warm_state_is_the_traffic_alone(tmp_path, monkeypatch):
    """Runs that differ in the ego, its route or the obstacles share one state; the
    warm-up's seed, the traffic or its length make another."""
    fresh_cache(tmp_path / "cache", monkeypatch)
    net_sha = file_sha256(TOWN_NET)
    base = town(seed=1, warm_seed=7)
    moved = dataclasses.replace(base, obstacles=(dataclasses.replace(
        base.obstacles[0], position_m=60.0),), scenario=dataclasses.replace(
        base.scenario, seed=2))
    assert warm_key(moved, net_sha) == warm_key(base, net_sha)
    for other in (town(seed=1, warm_seed=8), town(seed=1, warm_seed=7, vehicles=301),
                  town(seed=1, warm_seed=7, warm_up_s=21.0), town(seed=8)):
        assert warm_key(other, net_sha) != warm_key(base, net_sha)
    assert warm_key(town(seed=7), net_sha) == warm_key(town(seed=3, warm_seed=7), net_sha)

    a, b = run_episode(base), run_episode(moved)
    assert a.row["warm_state"] == b.row["warm_state"]
    assert len(list((tmp_path / "cache" / "warm-states").iterdir())) == 1
    # the state holds how the network's traffic settled, sampled every second
    state = WarmState.read(cached_path(warm_key(base, net_sha)))
    assert state.settling["t_s"][-1] == pytest.approx(20.0, abs=0.07)
    assert len(state.settling["t_s"]) == 20 and max(state.settling["vehicles"]) == 300
    assert state.demand["trips_made"] >= 300


@pytest.mark.slow
def test_a_warm_state_made_for_other_traffic_is_refused(tmp_path, monkeypatch):
    fresh_cache(tmp_path / "cache", monkeypatch)
    made = town(warm_seed=1)  # its warm state computed and cached (no run on it needed)
    SumoWorld(made, make_road(made), source=road_source(made.road)).warm_state()
    other = cached_path(warm_key(town(warm_seed=1), file_sha256(TOWN_NET)))
    spec = town(warm_seed=2)
    world = SumoWorld(spec, make_road(spec), warm_state=other, source=road_source(spec.road))
    with pytest.raises(SdcError, match="made for other traffic"):
        world.warm_state()
    broken = tmp_path / "broken.zip"
    broken.write_bytes(b"not a zip")
    with pytest.raises(SdcError, match="broken.zip: cannot be read"):
        SumoWorld(spec, make_road(spec), warm_state=broken,
                  source=road_source(spec.road)).warm_state()


SWEEP = """[sweep]
name = "warm"
base = "town.toml"
samples = 6
seed = 3
warm_states = 2
controllers = ["seed", "lane-keep"]

[sweep.params]
"obstacles[0].position_m" = {{ uniform = [60.0, 90.0] }}
"""


def town_sweep(root: Path, warm_states: str = "warm_states = 2") -> Path:
    root.mkdir(parents=True, exist_ok=True)
    text = (CATALOG_DIR / "grid-town.toml").read_text()
    text = (text.replace("vehicles = 2000", "vehicles = 300")
            .replace("duration_s = 30.0", "duration_s = 6.0")
            .replace('net_file = "networks/', f'net_file = "{CATALOG_DIR}/networks/'))
    text = text.replace("warm_up_s = ", "warm_up_s = 20.0 # ")
    (root / "town.toml").write_text(text)
    (root / "sweep.toml").write_text(SWEEP.format().replace("warm_states = 2", warm_states))
    return root / "sweep.toml"


@pytest.mark.slow
def test_a_sweep_draws_its_samples_from_its_warm_states_and_replays_them(tmp_path, monkeypatch,
                                                                        chromium_page):
    cache = fresh_cache(tmp_path / "cache", monkeypatch)
    sweep = load_sweep(town_sweep(tmp_path / "scenarios"))
    seeds = warm_seeds(sweep)
    plan = expand(sweep)
    assert {r.spec.traffic.warm_seed for r in plan} == set(seeds) and len(seeds) == 2
    assert all(r.spec.traffic.warm_seed == seeds[r.seed % 2] for r in plan)

    out = run_sweep(sweep, tmp_path / "out", LocalExecutor(2), QuietReporter(), traces="all")
    assert out.counts == {"ok": 12, "error": 0, "timeout": 0, "missing": 0}
    rows = pd.read_parquet(tmp_path / "out" / "results.parquet")
    assert rows.warm_state.nunique() == 2
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert manifest["warm_states"] == 2
    assert manifest["sessions"][-1]["warm_states"] == {"distinct": 2, "computed": 2,
                                                       "failed": {}}
    shipped = [path for path, entry in manifest["files"].items()
               if entry["field"] == "warm state"]
    assert len(shipped) == 2 and all(Path(p).parent == cache / "warm-states" for p in shipped)

    # replayed with the cache the sweep filled, and with none (the state rebuilt); by
    # the CLI in this process (the sweep's runs were in worker processes, the rebuilt
    # state is computed in a fresh one all the same: scenarios/sumo/warm_up_process.py)
    for cache_dir, run_id in ((cache, "00001-seed"), (tmp_path / "empty-cache", "00004-lane-keep")):
        replay = CliRunner().invoke(main, ["replay", str(tmp_path / "out"), "--run", run_id,
                                           "--verify"], env={"SDC_CACHE_DIR": str(cache_dir)})
        assert replay.exit_code == 0 and "identical" in replay.stdout, \
            (replay.output, replay.exception)
        assert ("warming the traffic up" in replay.stderr) == (cache_dir != cache)
    assert len(list((tmp_path / "empty-cache" / "warm-states").iterdir())) == 1

    # the report: how the traffic settled in the warm-ups, the warm states counted and
    # the intervals widened, as a user sees the page
    report = write_report(tmp_path / "out")
    lines = "\n".join(report.terminal)
    assert ("Traffic warm-up: 20 s (traffic.warm_up_s; the mean of 2 warm-ups kept in "
            "warm-states.json)") in lines
    assert "2 distinct warm states" in lines and "WARNING: the traffic's variety" in lines
    page, problems = chromium_page
    page.goto(report.html_path.as_uri())
    widths = page.eval_on_selector_all(f'img[alt="{SETTLING_TITLE}"]',
                                       "els => els.map(e => e.naturalWidth)")
    assert len(widths) == 1 and widths[0] > 300 and problems == []

    # a sweep without warm_states: one state per sample, as before
    default = load_sweep(town_sweep(tmp_path / "one-each", warm_states=""))
    assert default.warm_states is None
    assert all(r.spec.traffic.warm_seed is None for r in expand(default))


def test_warm_states_need_a_warm_up(tmp_path):
    path = town_sweep(tmp_path / "s")
    text = (tmp_path / "s" / "town.toml").read_text()
    (tmp_path / "s" / "town.toml").write_text(text.replace("warm_up_s = 20.0", "warm_up_s = 0.0"))
    with pytest.raises(SpecError, match="sweep.warm_states: the base scenario has no traffic"):
        load_sweep(path)


@pytest.mark.slow
def test_a_configuration_sweep_shares_its_warm_states(tmp_path, monkeypatch):
    """On a sumo_config base the demand up to traffic.enter_s is the warm-up: N warm
    states are N shared entries of it, each from its own seed; the plan says so."""
    fresh_cache(tmp_path / "cache", monkeypatch)
    base = (CATALOG_DIR / "real-traffic.toml").read_text()
    base = (base.replace("A10KW.sumocfg", "square.sumocfg").replace("enter_s = 120.0",
                                                                    "enter_s = 30.0")
            .replace("duration_s = 40.0", "duration_s = 2.0"))
    (tmp_path / "base.toml").write_text(base)
    (tmp_path / "sweep.toml").write_text(
        '[sweep]\nname = "shared"\nbase = "base.toml"\nsamples = 4\nseed = 5\n'
        'warm_states = 2\ncontrollers = ["lane-keep"]\n\n[sweep.params]\n'
        '"ego.speed_mps" = { uniform = [5.0, 9.0] }\n')
    sweep = load_sweep(tmp_path / "sweep.toml")
    plan = expand(sweep)
    assert {r.spec.traffic.warm_seed for r in plan} == set(warm_seeds(sweep))
    dry = CliRunner().invoke(main, ["sweep", str(tmp_path / "sweep.toml"), "--dry-run"])
    assert "the samples draw their traffic from 2 warm states" in dry.output, dry.output
    out = run_sweep(sweep, tmp_path / "out", LocalExecutor(2), QuietReporter())
    assert out.counts == {"ok": 4, "error": 0, "timeout": 0, "missing": 0}
    rows = pd.read_parquet(tmp_path / "out" / "results.parquet")
    assert rows.warm_state.nunique() == 2
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert manifest["sessions"][-1]["warm_states"]["distinct"] == 2


def test_warm_states_on_the_highway_backend_alone_are_refused(tmp_path):
    """highway-env has no saved traffic to share: asking for warm states there was
    silently ignored ("0 warm states")."""
    path = town_sweep(tmp_path / "s")
    text = path.read_text()
    path.write_text(text.replace("[sweep.params]",
                                 '[sweep.params]\n"scenario.backend" = { choice = ["highway"] }'))
    with pytest.raises(SpecError, match="sweep.warm_states: .* the highway backend only"):
        load_sweep(path)


@pytest.mark.parametrize("args, message", [
    (["--for", "nan"], "'--for': not a number"),
    (["--out", "{tmp}/missing/x.png"], "--out: directory {tmp}/missing does not exist"),
    (["--out", "{tmp}/x.gif"], "--out: {tmp}/x.gif must end in .png"),
])
def test_sdc_settle_refuses_bad_options_before_simulating(tmp_path, args, message):
    spec_file = CATALOG_DIR / "highway-obstacle.toml"
    args = [a.format(tmp=tmp_path) for a in args]
    result = CliRunner().invoke(main, ["settle", str(spec_file), *args])
    assert result.exit_code == 2 and message.format(tmp=tmp_path) in result.output
    assert "warming up" not in result.output and list(tmp_path.iterdir()) == []


def test_sdc_settle_on_a_scenario_without_traffic_says_so(lesson_plain, tmp_path):
    result = CliRunner().invoke(main, ["settle", str(CATALOG_DIR / "seed-lesson.toml")])
    assert result.exit_code == 2
    assert "traffic: the scenario has no background traffic to watch" in result.output


@pytest.mark.slow
def test_sdc_settle_watches_the_traffic_and_suggests_a_warm_up(tmp_path):
    spec_file = tmp_path / "highway.toml"
    text = (CATALOG_DIR / "highway-obstacle.toml").read_text()
    spec_file.write_text(text.replace("flow_vph_per_lane = 600.0", "flow_vph_per_lane = 1500.0"))
    out = tmp_path / "settle.png"
    done = subprocess.run([sys.executable, "-m", "sdc", "settle", str(spec_file), "--for", "30",
                           "--out", str(out), "--json"], cwd=REPO, capture_output=True,
                          text=True, check=False)
    assert done.returncode == 0, done.stderr
    suggestion = json.loads(done.stdout.strip().splitlines()[-1])
    assert suggestion["rule"].startswith("MSER")
    assert suggestion["observed_s"] == pytest.approx(30.0, abs=0.07)
    # the 1 km road fills from empty for 40 s: no settled value, only a lower bound
    assert set(suggestion["measures"]) == {"vehicles", "mean_speed_mps", "halting"}
    assert not suggestion["measures"]["vehicles"]["settled"] and not suggestion["settled"]
    assert "not settled within 30 s" in done.stdout
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    series = pd.read_csv(out.with_suffix(".csv"))
    assert list(series.columns) == ["t_s", "vehicles", "mean_speed_mps", "halting"]
    assert len(series) == 30 and series.vehicles.iloc[-1] > series.vehicles.iloc[5] > 0

    bad = subprocess.run([sys.executable, "-m", "sdc", "settle", str(spec_file), "--for", "5"],
                         cwd=REPO, capture_output=True, text=True, check=False)
    assert bad.returncode == 2 and "--for" in bad.stderr


def test_a_run_without_an_outcome_still_names_its_warm_state():
    """An error or timeout row names the warm state its run was to start from, so the
    report's gate counts it with the runs sharing its traffic, not as one apart."""
    from sdc.batch.sweeps.warm_states import with_warm_state
    from sdc.run.result_row import error_row

    key = "ab" * 32
    row = error_row(run_id="00003-seed", seed=1, controller="seed", backend="sumo",
                    error="boom", traceback=None)
    assert row["warm_state"] is None
    assert with_warm_state(row, {"00003-seed": key})["warm_state"] == key[:16]
    assert with_warm_state(row, {})["warm_state"] is None
    ran = {**row, "warm_state": "cd" * 8}  # a run's own word stands
    assert with_warm_state(ran, {"00003-seed": key})["warm_state"] == "cd" * 8


def test_a_warm_state_file_missing_a_part_is_refused_by_name(tmp_path):
    import zipfile

    path = tmp_path / "half.zip"
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("warm-state.json", json.dumps({"format": WARM_FORMAT, "t_s": 1.0}))
        z.writestr("sumo-state.xml.gz", b"")
    with pytest.raises(SdcError, match=r"half.zip: cannot be read \(KeyError"):
        WarmState.read(path)
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("warm-state.json", json.dumps({"format": 99}))
        z.writestr("sumo-state.xml.gz", b"")
    with pytest.raises(SdcError, match=f"format 99, this sdc reads {WARM_FORMAT}"):
        WarmState.read(path)


def _state_text(state: WarmState) -> list[str]:
    """SUMO's saved state, but when it was written and the files it was run on (each
    test's cache folder holds its own copy of the network)."""
    import gzip
    text = gzip.decompress(state.sumo_state).decode()
    return [line for line in text.splitlines()
            if "generated on" not in line and not re.search(r"<[\w.-]*-files? value=", line)]


@pytest.mark.slow
def test_a_warm_state_is_the_same_whatever_ran_before_it_in_the_process(tmp_path,
                                                                          monkeypatch):
    """libsumo counts its route parser's random draws across simulations in one
    process and a saved state records that count: a warm state computed after another
    run held 670 draws where a fresh process holds 354, and runs from it drew other
    numbers. Computed apart (scenarios/sumo/warm_up_process.py), it is the same."""
    fresh_cache(tmp_path / "first", monkeypatch)
    spec = highway(seed=2)
    alone = SumoWorld(spec, make_road(spec), source=road_source(spec.road)).warm_state()
    fresh_cache(tmp_path / "after", monkeypatch)
    run_episode(highway(seed=1))  # its flows draw from the same generator
    after = SumoWorld(spec, make_road(spec), source=road_source(spec.road)).warm_state()
    assert 'routeHandler="' in "".join(_state_text(alone))
    assert _state_text(after) == _state_text(alone)
