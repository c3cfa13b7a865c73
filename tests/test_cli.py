from __future__ import annotations

import json

import pandas as pd
import pytest
from click.testing import CliRunner

from analysis.report.sweep_words import COLLISION_TITLE, VERDICT_TITLE
from scenarios import CATALOG_DIR
from scenarios.spec.toml_io import dumps_plain
from sdc.cli import main
from sdc.run.result_row import JSON_COLUMNS

LESSON = str(CATALOG_DIR / "seed-lesson.toml")


def invoke(*args: str):
    return CliRunner().invoke(main, list(args))


def test_help_lists_the_commands_and_exit_codes():
    result = invoke("--help")
    assert result.exit_code == 0
    assert "run" in result.output and "demo" in result.output and "130" in result.output
    assert "--trace" in invoke("run", "--help").output


@pytest.mark.slow
def test_run_json_prints_the_row_on_the_last_line(tmp_path):
    trace = tmp_path / "t.parquet"
    result = invoke("run", LESSON, "--json", "--trace", str(trace), "--seed", "5")
    assert result.exit_code == 0, result.output
    row = json.loads(result.output.strip().splitlines()[-1])
    assert row["seed"] == 5 and row["controller"] == "seed" and row["status"] == "ok"
    assert list(row) == list(JSON_COLUMNS) and row["run_id"] == "seed-lesson-seed-5"
    assert trace.exists()


@pytest.mark.slow
def test_run_summary_is_readable():
    result = invoke("run", LESSON, "--controller", "lane-keep")
    assert result.exit_code == 0  # a collision is an outcome, not an error
    assert "outcome:   collided: COLLISION with obstacle" in result.output
    assert "  progress:  " in result.output and " m along the route, time lost " in result.output


def _spec_file(tmp_path, lesson_plain, edit) -> str:
    edit(lesson_plain)
    path = tmp_path / "spec.toml"
    path.write_text(dumps_plain(lesson_plain))
    return str(path)


# (how to break the input, the field the message must name)
BAD = [
    (lambda p: p["obstacles"][0].update(lane=4),
     "obstacles[0].lane: 4, but the road has lanes 0 to 2 (road.lanes = 3; 0 is the rightmost)"),
    (lambda p: p["ego"].update(start_m=40.0), "ego.start_m"),
    (lambda p: p["obstacles"][0].update(position_m=1000.0), "obstacles[0].position_m"),
    (lambda p: p["road"].update(kind="spiral"), "road.kind"),
    (lambda p: p["road"].update(lanes="three"), "road.lanes"),
    (lambda p: p["road"].update(length_m=-1.0), "road.length_m"),
    (lambda p: p["ego"].update(wings=True), "ego.wings: unknown key"),
    (lambda p: p["lidar"].update(beams=0), "lidar.beams"),
    (lambda p: p["controller"].update(name="magic"), "controller.name"),
    (lambda p: p["scenario"].update(step_s=-0.1), "scenario.step_s"),
    (lambda p: p["road"].update(kind="curve"), "road.curve_radius_m"),
    (lambda p: p.pop("road"), "road: table is required"),
]


@pytest.mark.parametrize(("edit", "field"), BAD, ids=[f for _, f in BAD])
def test_bad_spec_exits_2_naming_the_field_and_writes_nothing(tmp_path, lesson_plain, edit,
                                                              field):
    trace = tmp_path / "out.parquet"
    result = invoke("run", _spec_file(tmp_path, lesson_plain, edit), "--trace", str(trace))
    assert result.exit_code == 2
    assert field in result.output
    assert "Traceback" not in result.output
    assert not trace.exists()
    assert list(tmp_path.iterdir()) == [tmp_path / "spec.toml"]


@pytest.mark.parametrize(("args", "message"), [
    (["run", "missing.toml"], "missing.toml: cannot read the scenario file: no such file"),
    (["run", LESSON, "--trace", "out.csv"], "--trace"),
    (["run", LESSON, "--trace", "no/such/dir/t.parquet"], "--trace"),
    (["run", LESSON, "--controller", "magic"], "--controller"),
    (["run", LESSON, "--seed", "-3"], "--seed"),
    (["run", LESSON, "--backend", "carla"], "--backend"),
])
def test_bad_arguments_exit_2_naming_the_option(args, message):
    result = invoke(*args)
    assert result.exit_code == 2
    assert message in result.output


SWEEP = str(CATALOG_DIR / "sweeps" / "seed-envelope.toml")


@pytest.mark.parametrize("args", [["run", SWEEP], ["settle", SWEEP]])
def test_a_sweep_file_where_a_scenario_belongs_names_sdc_sweep(args):
    result = invoke(*args)
    assert result.exit_code == 2
    assert result.stderr == (f"error: {SWEEP}: this is a sweep file ([sweep]), not a scenario: "
                             "use `sdc sweep FILE --out DIR`, or run its base scenario "
                             '(sweep.base = "../seed-lesson.toml")\n')


@pytest.mark.parametrize("args", [["sweep", LESSON, "--dry-run"],
                                  ["search", LESSON, "--out", "o", "--budget", "4"],
                                  ["estimate", LESSON, "--out", "o"]])
def test_a_scenario_file_where_a_sweep_belongs_names_sdc_run(args, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    result = invoke(*args)
    assert result.exit_code == 2
    assert result.stderr == (f"error: {LESSON}: this is a scenario file, not a sweep: use `sdc "
                             "run FILE`; to sweep it, write a sweep file whose [sweep] base "
                             "names it (docs/how-to/sweeps.md)\n")
    assert list(tmp_path.iterdir()) == []


def test_set_changes_one_run_and_its_row_records_the_values():
    result = invoke("run", LESSON, "--json", "--set", "ego.speed_mps=9",
                    "--set", "scenario.duration_s=2", "--set", 'scenario.name="short"')
    assert result.exit_code == 0, result.output
    row = json.loads(result.output.strip().splitlines()[-1])
    assert list(row) == [*JSON_COLUMNS, "p.ego.speed_mps", "p.scenario.duration_s",
                         "p.scenario.name"]
    # the values as the spec holds them: 9 is a float speed
    assert (row["p.ego.speed_mps"], row["p.scenario.duration_s"]) == (9.0, 2.0)
    assert row["p.scenario.name"] == "short" and row["run_id"] == "short-seed-1"
    assert row["sim_time_s"] <= 2.0 + 0.064 and row["progress_m"] > 2 * 3.74 + 5  # at 9 m/s
    text = invoke("run", LESSON, "--set", "scenario.duration_s=2", "--set", "road.kind=curve",
                  "--set", "road.curve_radius_m=-80")
    assert text.exit_code == 0, text.output
    assert text.output.splitlines()[1] == (
        "  set:       scenario.duration_s=2, road.kind=curve, road.curve_radius_m=-80")


BAD_SETS = [
    ("ego.sped_mps=9", "--set ego.sped_mps=9: unknown key (known: lane, speed_mps, start_m)"),
    ("ego.speed_mps=-1", "--set ego.speed_mps=-1: must be >= 0, got -1.0"),
    ("ego.speed_mps=fast", "--set ego.speed_mps=fast: must be a number, got 'fast'"),
    ("ego.speed_mps.max=9", "--set ego.speed_mps.max=9: ego.speed_mps is not a table"),
    ("obstacles[3].lane=1",
     "--set obstacles[3].lane=1: obstacles[3] does not exist: the file has 1 [[obstacles]]"),
    ("weather.rain=1", "--set weather.rain=1: weather: unknown table (known: controller, ego, "
                       "lidar, obstacles, road, scenario, traffic, vehicle)"),
    ("ego.speed_mps", "--set ego.speed_mps: expected PATH=VALUE, e.g. ego.speed_mps=9"),
    ("ego..lane=1", "--set ego..lane=1: bad path segment '' (expected name or name[index])"),
    # a rule the changed file breaks elsewhere: the file's error, read with the option
    ("road.kind=curve", f'{LESSON}: road.curve_radius_m: is required for kind "curve" '
                        "(with --set road.kind=curve)"),
]


@pytest.mark.parametrize(("value", "message"), BAD_SETS, ids=[v for v, _ in BAD_SETS])
@pytest.mark.parametrize("command", ["run", "settle"])
def test_a_bad_set_exits_2_naming_it(command, value, message, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    result = invoke(command, LESSON, "--set", value)
    assert result.exit_code == 2
    assert result.stderr == f"error: {message}\n"
    assert list(tmp_path.iterdir()) == []


def test_invalid_toml_exits_2(tmp_path):
    path = tmp_path / "broken.toml"
    path.write_text("[road\nlanes = 3\n")
    result = invoke("run", str(path))
    assert result.exit_code == 2 and "invalid TOML" in result.output


def test_a_run_that_raises_is_an_error_row_and_exit_1(monkeypatch):
    def broken(spec, **_):
        raise RuntimeError("SUMO went away")

    monkeypatch.setattr("sdc.run.episode.run_episode", broken)
    result = invoke("run", LESSON, "--json")
    assert result.exit_code == 1
    row = json.loads([line for line in result.output.splitlines() if line.startswith("{")][-1])
    assert row["status"] == "error" and "SUMO went away" in row["error"]
    assert list(row) == list(JSON_COLUMNS) and row["trace_sha256"] is None
    # one line naming the error and where it was raised, no traceback
    assert result.stderr.startswith("error: RuntimeError: SUMO went away (raised at ")
    assert "in broken)" in result.stderr and "Traceback" not in result.stderr


@pytest.mark.slow
def test_demo_sweeps_reports_and_shows_a_finished_demo_again(tmp_path):
    out = tmp_path / "demo"
    args = ["demo", "--out", str(out), "--samples", "3", "--workers", "2"]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    at = lines.index(VERDICT_TITLE) + 2  # the verdict table's rows, ranked
    verdicts = {line.split()[0]: line.split() for line in lines[at:at + 3]}
    assert verdicts["lane-keep"][1:4] == ["3", "0", "(0.0%)"]  # never completes
    rows = {}  # the collision table's (the first after its title); stop-possible rows follow
    for line in lines[lines.index(COLLISION_TITLE) + 1:]:
        if len(line.split()) > 1 and line.split()[1].isdigit():
            rows.setdefault(line.split()[0], line.split())
    assert rows["seed"][1] == "3" and rows["lane-keep"][1:4] == ["3", "3", "100.0%"]
    assert rows["avoid"][1] == "3"  # the three controllers of the catalog's seed-envelope
    assert "where braking alone could stop in time" in result.output
    assert (out / "report.html").exists() and (out / "summary.json").exists()
    rerun = CliRunner().invoke(main, args)  # a finished demo is reported again, not rerun
    assert rerun.exit_code == 0 and rerun.stdout == result.stdout
    other = CliRunner().invoke(main, [*args[:4], "2", *args[5:]])  # another plan: anew
    assert other.exit_code == 0, other.output
    assert "starting anew" in other.stderr
    assert len(pd.read_parquet(out / "results.parquet")) == 2 * 3


@pytest.mark.parametrize("args", [["sweep"], ["sweep", "x.toml", "--executor", "foo"],
                                  ["search", "x.toml"], ["nope"]])
def test_click_usage_errors_carry_the_same_error_prefix_and_exit_2(args):
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 2
    assert "\nerror: " in result.output and "Error:" not in result.output
    assert "for help." in result.output
