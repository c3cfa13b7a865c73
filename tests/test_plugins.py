"""Controller plug-ins for real: the four ways to name one, in a run, a sweep on
local workers and on Ray, and every way a plug-in can be bad.

The plug-ins live in a temporary folder put on ``sys.path`` and ``PYTHONPATH`` (so
this process and the processes a test starts, Ray's workers included, import them)
with a ``.dist-info`` that registers entry points, as an installed package would. The
commands run in this process (:func:`sdc_here`) but for the Ray sweep, whose workers
must start with the plug-ins on their path; the runs are the lesson's on the scripted
backend (a world without a simulator: no traffic, the runs SUMO gives).
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from scenarios.spec.toml_io import dumps_plain, read_toml
from sdc.cli import main

REPO = Path(__file__).resolve().parent.parent
EXAMPLE = REPO / "examples" / "cautious.py"
LESSON = Path(__file__).resolve().parent / "data" / "seed-lesson-scripted.toml"
SDC = [sys.executable, "-m", "sdc"]

ENTRY_POINTS = """[sdc.controllers]
cautious-ep = plugpkg.cautious:Cautious
lane-keep-ep = sdc.car.controllers:LaneKeepController
lost-ep = plugpkg.nowhere:Lost
"""
# plug-ins that break each rule of the protocol, in plugpkg/bad.py
BAD_PLUGINS = """
from sdc import Command

NOT_A_CLASS = 3


class Refuses:
    def __init__(self, params):
        raise RuntimeError("needs a lidar with 360 beams")


class NoStep:
    def __init__(self, params):
        pass


class RaisesAtStep5:
    def __init__(self, params):
        self.k = 0

    def step(self, obs):
        self.k += 1
        if self.k == 5:
            raise ZeroDivisionError("step five")
        return Command(0.0)


class ReturnsTuple:
    def __init__(self, params):
        pass

    def step(self, obs):
        return (0.0, 0.0)


class ReturnsNan:
    def __init__(self, params):
        pass

    def step(self, obs):
        return Command(float("nan"))


class WritesRanges:
    def __init__(self, params):
        pass

    def step(self, obs):
        obs.ranges_m[0] = 1.0
        return Command(0.0)
"""


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """A folder with package ``plugpkg`` (the example, under two class names, and
    the bad plug-ins) and its dist-info registering entry points."""
    root = tmp_path_factory.mktemp("site")
    package = root / "plugpkg"
    package.mkdir()
    shutil.copy(EXAMPLE, package / "cautious.py")
    (package / "__init__.py").write_text("from plugpkg.cautious import Cautious as Careful\n")
    (package / "bad.py").write_text(BAD_PLUGINS)
    (package / "syntax.py").write_text("class Broken(:\n")
    (package / "raises.py").write_text("raise ImportError('needs torch')\n")
    info = root / "plugpkg-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: plugpkg\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text(ENTRY_POINTS)
    return root


@pytest.fixture
def on_path(site, monkeypatch):
    """``site`` importable here and in every process a test starts."""
    monkeypatch.syspath_prepend(str(site))
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(
        [str(site), str(REPO), *filter(None, [os.environ.get("PYTHONPATH")])]))
    return site


def sdc(*args, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([*SDC, *map(str, args)], capture_output=True, text=True,
                          timeout=600, cwd=cwd)


def sdc_here(*args, cwd: Path | None = None) -> subprocess.CompletedProcess:
    """:func:`sdc` in this process (``cwd``: its working directory meanwhile): the same
    command, exit code, output and errors, without starting a Python."""
    with contextlib.chdir(cwd or Path.cwd()):
        result = CliRunner().invoke(main, [str(a) for a in args])
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        raise result.exception
    return subprocess.CompletedProcess(args, result.exit_code, result.stdout, result.stderr)


def run_json(*args, cwd: Path | None = None) -> dict:
    done = sdc_here("run", *args, "--json", cwd=cwd)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.splitlines()[-1])


def scenario_with(tmp_path: Path, controller: dict, name: str = "spec.toml") -> Path:
    plain = read_toml(LESSON)
    plain["controller"] = controller
    path = tmp_path / name
    path.write_text(dumps_plain(plain))
    return path


@pytest.mark.slow
def test_the_four_ways_to_name_a_controller_run_the_same_code(on_path, tmp_path):
    # the example three ways, and from a scenario file naming it relative to itself
    rows = {
        "file": run_json(LESSON, "--controller", "plugpkg/cautious.py:Cautious", cwd=on_path),
        "module": run_json(LESSON, "--controller", "plugpkg:Careful"),
        "entry point": run_json(LESSON, "--controller", "cautious-ep"),
    }
    (tmp_path / "mine").mkdir()
    shutil.copy(EXAMPLE, tmp_path / "mine" / "cautious.py")
    spec = scenario_with(tmp_path, {"name": "mine/cautious.py:Cautious", "margin_m": 3.0})
    rows["scenario file"] = run_json(spec, cwd=REPO)
    assert {k: r["controller"] for k, r in rows.items()} == {
        "file": "Cautious", "module": "Careful", "entry point": "cautious-ep",
        "scenario file": "Cautious"}
    shas = {r["trace_sha256"] for r in rows.values()}
    assert len(shas) == 1
    assert all(r["status"] == "ok" and not r["collision"] for r in rows.values())
    # a built-in goes through the same protocol: the same class by any name, one trace
    builtin = [run_json(LESSON, "--controller", name) for name in (
        "lane-keep", "sdc.car.controllers:LaneKeepController",
        f"{REPO}/sdc/car/controllers.py:LaneKeepController", "lane-keep-ep")]
    assert len({r["trace_sha256"] for r in builtin}) == 1
    assert builtin[0]["trace_sha256"] not in shas


def test_the_example_brakes_to_a_stop_before_the_barrel(tmp_path):
    trace = tmp_path / "cautious.parquet"
    row = run_json(LESSON, "--controller", EXAMPLE.relative_to(REPO).as_posix() + ":Cautious",
                   "--trace", trace, cwd=REPO)
    assert row["collision"] is False and row["termination"] == "duration"
    assert 0 < row["min_gap_obstacle_m"] < 5.0
    assert row["maneuver_started"] is False  # it never swerves
    table = pd.read_parquet(trace)
    assert set(table.phase) == {"lane_keep", "brake"}
    assert table.speed_mps.iloc[-1] == 0.0


SWEEP = """[sweep]
name = "plugins"
base = "{base}"
samples = 3
seed = 3
controllers = ["plugpkg/cautious.py:Cautious", "plugpkg:Careful", "cautious-ep", "lane-keep"]

[sweep.params]
"ego.speed_mps" = {{ uniform = [3.0, 12.0] }}
"scenario.duration_s" = {{ choice = [12.0] }}
"""


def comparable(out_dir: Path) -> pd.DataFrame:
    return pd.read_parquet(out_dir / "results.parquet").drop(columns=["wall_time_s"])


@pytest.mark.slow
def test_plugins_in_local_and_ray_sweeps_give_identical_results(on_path):
    sweep = on_path / "plugins.toml"
    sweep.write_text(SWEEP.format(base=LESSON))
    for executor, command in (("local", sdc_here), ("ray", sdc)):
        done = command("sweep", sweep, "--out", on_path / executor, "--workers", 2,
                       "--executor", executor, "--quiet", "--traces", "all")
        assert done.returncode == 0, done.stderr
    local = comparable(on_path / "local")
    pd.testing.assert_frame_equal(comparable(on_path / "ray"), local)
    assert (local.status == "ok").all() and len(local) == 12
    assert set(local.controller) == {"Cautious", "Careful", "cautious-ep", "lane-keep"}
    per_sample = local[local.controller != "lane-keep"].groupby("sample").trace_sha256.nunique()
    assert (per_sample == 1).all()  # the same code by three names
    manifest = json.loads((on_path / "local" / "manifest.json").read_text())
    sources = manifest["controllers"]
    assert sources["Cautious"]["file"] == str(on_path / "plugpkg" / "cautious.py")
    assert sources["Cautious"]["sha256"] == sources["Careful"]["sha256"]
    assert sources["cautious-ep"]["distribution"] == "plugpkg 1.0"
    assert sources["lane-keep"] == {"name": "lane-keep", "kind": "builtin"}

    run_id = local.run_id[local.controller == "Cautious"].iloc[0]
    replay = sdc_here("replay", on_path / "ray", "--run", run_id, "--verify")
    assert replay.returncode == 0 and "identical" in replay.stdout
    assert "warning" not in replay.stderr
    plugin = on_path / "plugpkg" / "cautious.py"
    original = plugin.read_text()
    try:
        plugin.write_text(original.replace("margin_m\": 3.0", "margin_m\": 6.0"))
        replay = sdc_here("replay", on_path / "ray", "--run", run_id, "--verify")
        assert "warning: the controller Cautious changed since the sweep ran" in replay.stderr
        assert replay.returncode == 1 and "DIVERGED" in replay.stdout
        resumed = sdc_here("sweep", sweep, "--out", on_path / "local", "--resume", "--quiet")
        assert resumed.returncode == 2
        assert "the controller Cautious changed" in resumed.stderr
    finally:
        plugin.write_text(original)


@pytest.mark.parametrize(("name", "reason"), [
    ("plugpkg/missing.py:Cautious", "no controller file"),
    ("plugpkg/syntax.py:Broken", "importing {site}/plugpkg/syntax.py failed: SyntaxError"),
    ("plugpkg/raises.py:Any", "failed: ImportError: needs torch"),
    ("plugpkg/cautious.py:Reckless", "has no class 'Reckless'"),
    ("plugpkg/bad.py:NOT_A_CLASS", "is a int, not a class"),
    ("plugpkg/bad.py:Refuses", "Refuses could not be built: RuntimeError: needs a lidar"),
    ("plugpkg/bad.py:NoStep", "NoStep has no step(obs) method"),
    ("plugpkg.nowhere:Lost", "importing plugpkg.nowhere failed: ModuleNotFoundError"),
    ("plugpkg:Reckless", "plugpkg has no class 'Reckless'"),
    ("no-such-plugin", "unknown controller 'no-such-plugin'"),
    ("lost-ep", "importing plugpkg.nowhere failed"),
])
def test_a_plugin_that_cannot_be_built_is_exit_2_naming_the_field(on_path, tmp_path, name,
                                                                  reason):
    reason = reason.format(site=on_path)
    on_command_line = sdc_here("run", LESSON, "--controller", name, cwd=on_path)
    assert on_command_line.returncode == 2
    assert on_command_line.stderr.startswith("error: --controller: ")
    assert reason in on_command_line.stderr and "Traceback" not in on_command_line.stderr
    spec = scenario_with(on_path, {"name": name}, f"spec-{abs(hash(name))}.toml")
    in_file = sdc_here("run", spec)
    assert in_file.returncode == 2
    assert in_file.stderr.startswith(f"error: {spec}: controller.name: ")
    assert reason in in_file.stderr
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(f'[sweep]\nname = "bad"\nbase = "{LESSON}"\nsamples = 2\n'
                     f'controllers = ["seed", "{on_path}/{name}"]\n' if "/" in name else
                     f'[sweep]\nname = "bad"\nbase = "{LESSON}"\nsamples = 2\n'
                     f'controllers = ["seed", "{name}"]\n')
    in_sweep = sdc_here("sweep", sweep, "--out", tmp_path / "out")
    assert in_sweep.returncode == 2
    assert in_sweep.stderr.startswith(f"error: {sweep}: sweep.controllers[1]: ")
    assert reason in in_sweep.stderr
    assert not (tmp_path / "out").exists()


def test_a_plugin_rejecting_its_parameters_names_them(on_path):
    spec = scenario_with(on_path, {"name": "plugpkg:Careful", "margin": 2.0}, "typo.toml")
    done = sdc_here("run", spec)
    assert done.returncode == 2
    assert "controller.name: Careful could not be built: ValueError: unknown parameters " \
           "['margin']" in done.stderr


@pytest.mark.slow
def test_a_plugin_failing_during_a_run_is_an_error_row_and_the_sweep_goes_on(on_path,
                                                                             tmp_path):
    sweep = tmp_path / "failing.toml"
    names = ["RaisesAtStep5", "ReturnsTuple", "ReturnsNan", "WritesRanges"]
    refs = ", ".join(f'"plugpkg.bad:{n}"' for n in names)
    sweep.write_text(f'[sweep]\nname = "failing"\nbase = "{LESSON}"\nsamples = 2\n'
                     f'controllers = [{refs}, "lane-keep"]\n[sweep.params]\n'
                     '"scenario.duration_s" = { choice = [5.0] }\n')
    done = sdc_here("sweep", sweep, "--out", tmp_path / "out", "--workers", 2, "--quiet")
    assert done.returncode == 1, done.stderr  # runs errored; the sweep finished
    rows = pd.read_parquet(tmp_path / "out" / "results.parquet").set_index("run_id")
    assert (rows.loc[rows.controller == "lane-keep", "status"] == "ok").all()
    errors = rows[rows.controller != "lane-keep"]
    assert (errors.status == "error").all() and len(errors) == 8
    message = errors.groupby("controller").error.first()
    assert message["RaisesAtStep5"] == "ZeroDivisionError: step five"
    assert message["ReturnsTuple"].startswith(
        "ControllerError: ReturnsTuple.step returned (0.0, 0.0) at step 0, not a Command")
    assert message["ReturnsNan"].startswith(
        "ControllerError: ReturnsNan.step returned Command(steer_rad=nan")
    assert message["WritesRanges"].startswith("ValueError: assignment destination is read-only")


@pytest.mark.slow
def test_the_example_plugins_sweep_file_runs_as_its_docstring_says(tmp_path):
    """...and its brake-only plug-in, which never collides, is never called safe: all
    its runs end stuck behind the barrel, and the report's verdicts rank it below avoid."""
    sweep = REPO / "examples" / "cautious-sweep.toml"
    assert "sdc sweep examples/cautious-sweep.toml" in EXAMPLE.read_text()
    done = subprocess.run([*SDC, "sweep", "examples/cautious-sweep.toml", "--out",
                           str(tmp_path / "out"), "--samples", "10", "--workers", "2",
                           "--quiet"], capture_output=True, text=True, timeout=600, cwd=REPO)
    assert sweep.exists() and done.returncode == 0, done.stderr
    rows = pd.read_parquet(tmp_path / "out" / "results.parquet")
    assert sorted(rows.controller.unique()) == ["Cautious", "avoid", "seed"]
    assert (rows.status == "ok").all()
    braking = rows[rows.controller == "Cautious"]
    assert len(braking) == 10 and (braking.outcome == "stuck").all()
    assert (braking.stood_for == "obstacle").all()  # the barrel, not a light
    assert not braking.collision.any()

    report = subprocess.run([*SDC, "report", str(tmp_path / "out")], capture_output=True,
                            text=True, timeout=600, cwd=REPO)
    assert report.returncode == 0, report.stderr
    ranked = list(json.loads((tmp_path / "out" / "summary.json").read_text())
                  ["verdicts"]["by_controller"])
    assert ranked.index("avoid") < ranked.index("Cautious")
    lines = report.stdout.splitlines()
    table = lines[1:5]  # the verdict table's header and its three rows, ranked
    assert table[0].startswith("controller") and table[-1].startswith("Cautious")
    assert "Cautious: completed 0.0% [0.0%, 27.8%], stuck 100.0% (stood for: obstacle 10): " \
           "not safe to ship, it completes fewer than 50% of its runs" in lines
