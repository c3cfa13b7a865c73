"""Sweep files: validation naming the field, samplers, and a deterministic plan."""

from __future__ import annotations

import math

import pytest
from click.testing import CliRunner

from scenarios import CATALOG_DIR
from scenarios.common.errors import SpecError
from scenarios.spec.sweep_plan import expand, plan_sha256, sample_values
from scenarios.spec.sweep_spec import SweepSpec, load_sweep
from scenarios.spec.toml_io import dumps_plain
from sdc.cli import main

BASE = str(CATALOG_DIR / "seed-lesson.toml")


def sweep_plain(**table) -> dict:
    params = table.pop("params", {"ego.speed_mps": {"uniform": [2.0, 6.0]}})
    return {"sweep": {"name": "t", "base": BASE, "samples": 8, "sampler": "random",
                      "seed": 3, **table, "params": params}}


def make(**table) -> SweepSpec:
    return SweepSpec.from_plain(sweep_plain(**table), CATALOG_DIR)


@pytest.mark.parametrize("name", ["seed-envelope", "highway-traffic", "seed-rare", "seed-modes"])
def test_catalog_sweeps_expand_to_valid_deterministic_plans(name):
    path = CATALOG_DIR / "sweeps" / f"{name}.toml"
    plan = expand(load_sweep(path))
    assert len(plan) == len(load_sweep(path).controllers) * load_sweep(path).samples
    assert all(run.spec is not None for run in plan), [r.error for r in plan if r.error][:3]
    assert plan_sha256(plan) == plan_sha256(expand(load_sweep(path)))
    assert len({run.run_id for run in plan}) == len(plan)


def test_seed_envelope_covers_the_issue_ranges():
    sweep = load_sweep(CATALOG_DIR / "sweeps" / "seed-envelope.toml")
    speeds = [values["ego.speed_mps"] for values in sample_values(sweep)]
    assert 2.0 <= min(speeds) < 2.5 and 25 < max(speeds) <= 30.0
    kinds = {values["obstacles[0].kind"] for values in sample_values(sweep)}
    assert kinds == {"barrel", "car", "truck"}


@pytest.mark.parametrize("sampler", ["random", "sobol", "lhs"])
def test_samplers_stay_inside_each_distribution(sampler):
    sweep = make(sampler=sampler, samples=64, params={
        "ego.speed_mps": {"uniform": [2.0, 6.0]},
        "traffic.flow_vph_per_lane": {"loguniform": [10.0, 1000.0]},
        "ego.lane": {"int_range": [0, 2]},
        "obstacles[0].kind": {"choice": ["barrel", "car"]},
        "obstacles[0].lateral_offset_m": {"normal": [0.0, 0.1]},
    })
    values = sample_values(sweep)
    assert len(values) == 64
    assert all(2.0 <= v["ego.speed_mps"] <= 6.0 for v in values)
    assert all(10.0 <= v["traffic.flow_vph_per_lane"] <= 1000.0 for v in values)
    assert {v["ego.lane"] for v in values} == {0, 1, 2}
    assert {v["obstacles[0].kind"] for v in values} == {"barrel", "car"}
    offsets = [v["obstacles[0].lateral_offset_m"] for v in values]
    assert abs(sum(offsets) / len(offsets)) < 0.05 and max(map(abs, offsets)) < 0.6
    assert sample_values(sweep) == values  # same spec, same samples


def test_quasi_random_samplers_cover_the_range_more_evenly_than_random():
    def worst_gap(sampler):
        speeds = sorted(v["ego.speed_mps"] for v in sample_values(make(sampler=sampler,
                                                                       samples=32)))
        return max(b - a for a, b in zip([2.0] + speeds, speeds + [6.0], strict=True))

    assert worst_gap("lhs") <= 4.0 / 32 * 2
    assert worst_gap("sobol") < worst_gap("random")


def test_grid_takes_every_combination():
    sweep = SweepSpec.from_plain({"sweep": {
        "name": "g", "base": BASE, "sampler": "grid", "levels": 3,
        "controllers": ["seed", "lane-keep"],
        "params": {"ego.speed_mps": {"uniform": [2.0, 4.0]},
                   "obstacles[0].kind": {"choice": ["barrel", "car"]}}}}, CATALOG_DIR)
    plan = expand(sweep)
    assert len(plan) == 3 * 2 * 2
    assert sorted({r.params["ego.speed_mps"] for r in plan}) == [2.0, 3.0, 4.0]
    assert plan[0].run_id == "00000-seed" and plan[1].run_id == "00000-lane-keep"


def test_controllers_of_a_sample_share_its_spec_and_seed():
    plan = expand(make(controllers=["seed", "lane-keep"]))
    for a, b in zip(plan[::2], plan[1::2], strict=True):
        assert a.sample == b.sample and a.seed == b.seed and a.params == b.params
        assert (a.controller, b.controller) == ("seed", "lane-keep")
        assert a.spec.controller.name == "seed" and b.spec.controller.name == "lane-keep"
        assert a.spec.ego == b.spec.ego and a.spec.scenario == b.spec.scenario
    assert len({run.seed for run in plan}) == 8
    assert plan_sha256(plan) != plan_sha256(expand(make(controllers=["seed", "lane-keep"],
                                                        seed=4)))


def test_a_swept_seed_overrides_the_drawn_one():
    plan = expand(make(params={"scenario.seed": {"int_range": [5, 5]}}))
    assert {run.seed for run in plan} == {5}
    assert {run.spec.scenario.seed for run in plan} == {5}


def test_an_invalid_sample_is_reported_with_its_values():
    # half the samples put the barrel's centre off the 10.5 m road
    plan = expand(make(samples=20, params={
        "obstacles[0].lateral_offset_m": {"uniform": [-3.0, 0.0]}}))
    invalid = [run for run in plan if run.spec is None]
    assert 0 < len(invalid) < len(plan)
    for run in invalid:
        value = run.params["obstacles[0].lateral_offset_m"]
        assert value < -1.75
        assert f"sample {run.sample}" in run.error
        assert f"obstacles[0].lateral_offset_m={value!r}" in run.error
        assert "obstacles[0].lateral_offset_m:" in run.error  # the spec's own message


@pytest.mark.parametrize(("change", "field", "words"), [
    ({"params": {"ego.speeed_mps": {"uniform": [1.0, 2.0]}}}, 'sweep.params."ego.speeed_mps"',
     "unknown parameter path"),
    ({"params": {"obstacles[3].kind": {"choice": ["car"]}}}, 'sweep.params."obstacles[3].kind"',
     "does not exist"),
    ({"params": {"road": {"choice": [1]}}}, 'sweep.params."road"', "table"),
    ({"params": {"obstacles[0].kind": {"choice": []}}},
     'sweep.params."obstacles[0].kind".choice', "empty"),
    ({"params": {"ego.speed_mps": {"uniform": [6.0, 2.0]}}},
     'sweep.params."ego.speed_mps".uniform', "inverted range"),
    ({"params": {"ego.lane": {"int_range": [2, 0]}}}, 'sweep.params."ego.lane".int_range',
     "inverted range"),
    ({"params": {"ego.lane": {"uniform": [0, 2]}}}, 'sweep.params."ego.lane"',
     "whole number"),
    ({"params": {"obstacles[0].lane": {"normal": [1.0, 0.5]}}},
     'sweep.params."obstacles[0].lane"', "use int_range or choice"),
    ({"params": {"ego.speed_mps": {"loguniform": [0.0, 2.0]}}},
     'sweep.params."ego.speed_mps".loguniform', "> 0"),
    ({"params": {"ego.speed_mps": {"normal": [3.0, -1.0]}}},
     'sweep.params."ego.speed_mps".normal', "deviation"),
    ({"params": {"ego.speed_mps": {"gauss": [3.0, 1.0]}}},
     'sweep.params."ego.speed_mps".gauss', "unknown distribution"),
    ({"params": {"ego.speed_mps": [3.0, 1.0]}}, 'sweep.params."ego.speed_mps"', "table"),
    ({"samples": 0}, "sweep.samples", "> 0"),
    ({"samples": -5}, "sweep.samples", "> 0"),
    ({"sampler": "halton"}, "sweep.sampler", "must be one of"),
    ({"controllers": ["seed", "p i d"]}, "sweep.controllers[1]", "unknown controller"),
    ({"controllers": ["seed", "a.py:Seed", "b.py:Seed"]}, "sweep.controllers[2]",
     "go by 'Seed' in run IDs"),
    ({"controllers": []}, "sweep.controllers", "non-empty"),
    ({"base": "nowhere.toml"}, "sweep.base", "cannot read"),
    ({"levels": 4}, "sweep.levels", "grid"),
    ({"sampler": "grid"}, "sweep.samples", "grid sampler"),
    ({"speed": 3}, "sweep.speed", "unknown key"),
])
def test_bad_sweep_specs_name_the_field(change, field, words):
    with pytest.raises(SpecError) as info:
        make(**change)
    assert info.value.field == field
    assert words in info.value.message


def test_grid_rejects_a_normal_distribution():
    plain = sweep_plain(params={"ego.speed_mps": {"normal": [3.0, 1.0]}})
    del plain["sweep"]["samples"]
    plain["sweep"]["sampler"] = "grid"
    with pytest.raises(SpecError, match="has no grid") as info:
        SweepSpec.from_plain(plain, CATALOG_DIR)
    assert info.value.field == 'sweep.params."ego.speed_mps".normal'


def write_sweep(tmp_path, text: str):
    path = tmp_path / "sweep.toml"
    path.write_text(f'[sweep]\nname = "t"\nbase = "{BASE}"\n{text}')
    return path


@pytest.mark.parametrize(("text", "field"), [
    ('samples = 4\n[sweep.params]\n"ego.nope" = { uniform = [1.0, 2.0] }\n',
     'sweep.params."ego.nope"'),
    ('samples = 4\n[sweep.params]\n"ego.lane" = { choice = [] }\n',
     'sweep.params."ego.lane".choice'),
    ('samples = 4\n[sweep.params]\n"ego.speed_mps" = { uniform = [3.0, 1.0] }\n',
     'sweep.params."ego.speed_mps".uniform'),
    ('samples = 4\n[sweep.params]\n"ego.lane" = { uniform = [0, 2] }\n',
     'sweep.params."ego.lane"'),
    ("samples = 0\n", "sweep.samples"),
    ('samples = 4\nsampler = "magic"\n', "sweep.sampler"),
    ('samples = 4\ncontrollers = ["seed", "pid"]\n', "sweep.controllers[1]"),
])
def test_cli_rejects_bad_sweep_files_with_exit_2(tmp_path, text, field):
    path = write_sweep(tmp_path, text)
    result = CliRunner().invoke(main, ["sweep", str(path), "--out", str(tmp_path / "out")])
    assert result.exit_code == 2, result.output
    assert f"error: {path}: {field}:" in result.output
    assert "Traceback" not in result.output
    assert not (tmp_path / "out").exists()
    dry = CliRunner().invoke(main, ["sweep", str(path), "--dry-run"])  # before any run
    assert dry.exit_code == 2 and f"error: {path}: {field}:" in dry.output


def test_cli_dry_run_prints_the_plan(tmp_path):
    path = write_sweep(tmp_path, 'samples = 3\ncontrollers = ["seed", "lane-keep"]\n'
                                 '[sweep.params]\n"ego.speed_mps" = { uniform = [2.0, 4.0] }\n')
    result = CliRunner().invoke(main, ["sweep", str(path), "--dry-run"])
    assert result.exit_code == 0, result.output
    lines = result.output.strip().splitlines()
    assert "3 samples x 2 controllers = 6 runs" in lines[0]
    assert lines[1].split() == ["run_id", "seed", "ego.speed_mps"]
    assert [line.split()[0] for line in lines[2:]] == [run.run_id for run in
                                                       expand(load_sweep(path))]
    speeds = [float(line.split()[2]) for line in lines[2:]]
    assert all(2.0 <= s <= 4.0 for s in speeds) and not any(math.isnan(s) for s in speeds)


def test_set_changes_the_sweep_table_its_parameters_or_its_base(tmp_path):
    path = write_sweep(tmp_path, 'samples = 3\n[sweep.params]\n'
                                 '"ego.speed_mps" = { uniform = [2.0, 4.0] }\n')
    sets = ["sweep.samples=2", "sweep.params.obstacles[0].kind={ choice = ['car'] }",
            "scenario.duration_s=5", "traffic.speed_dev=0"]
    sweep = load_sweep(path, sets)
    assert sweep.overrides == tuple(sets) and sweep.samples == 2
    assert [p.path for p in sweep.params] == ["ego.speed_mps", "obstacles[0].kind"]
    assert (sweep.base.scenario.duration_s, sweep.base.traffic.speed_dev) == (5.0, 0.0)
    plan = expand(sweep)
    assert len(plan) == 2 and {run.spec.obstacles[0].kind for run in plan} == {"car"}
    assert {run.spec.scenario.duration_s for run in plan} == {5.0}
    result = CliRunner().invoke(main, ["sweep", str(path), "--dry-run",
                                       *[w for s in sets for w in ("--set", s)]])
    assert result.exit_code == 0, result.output
    lines = result.output.strip().splitlines()
    assert "2 samples x 1 controllers = 2 runs" in lines[0]
    assert lines[1].split() == ["run_id", "seed", "ego.speed_mps", "obstacles[0].kind"]
    assert [line.split()[3] for line in lines[2:]] == ["car", "car"]


@pytest.mark.parametrize(("value", "message"), [
    ("sweep.sampels=2", "--set sweep.sampels=2: unknown key (known: base, controllers, "
                        "egos_per_world, levels, name, params, runs_per_world, sampler, "
                        "samples, seed, warm_states)"),
    ("sweep.samples=0", "--set sweep.samples=0: must be > 0, got 0"),
    ("sweep.params.ego.speed_mps={ uniform = [5.0, 1.0] }",
     '--set sweep.params.ego.speed_mps={ uniform = [5.0, 1.0] }: sweep.params."ego.speed_mps"'
     ".uniform: inverted range: 5.0 >= 1.0"),
    ("ego.sped_mps=9", "--set ego.sped_mps=9: unknown key (known: lane, speed_mps, start_m)"),
    ("ego.speed_mps=9", "--set ego.speed_mps=9: the sweep's plan sets ego.speed_mps: it is "
                        "swept; set its distribution instead, e.g. --set "
                        "'sweep.params.ego.speed_mps={ choice = [9] }'"),
    ("scenario.seed=3", "--set scenario.seed=3: the sweep's plan sets scenario.seed: each "
                        "sample's seed is drawn from sweep.seed"),
    ("controller.name=avoid", "--set controller.name=avoid: the sweep's plan sets "
                              "controller.name: the runs' controllers are sweep.controllers"),
])
@pytest.mark.parametrize("command", ["sweep", "search", "estimate"])
def test_a_bad_set_of_a_sweep_exits_2_naming_it(tmp_path, monkeypatch, command, value, message):
    monkeypatch.chdir(tmp_path)
    path = write_sweep(tmp_path, 'samples = 3\n[sweep.params]\n'
                                 '"ego.speed_mps" = { uniform = [2.0, 4.0] }\n')
    result = CliRunner().invoke(main, [command, str(path), "--out", "out", "--budget", "4",
                                       "--set", value] if command == "search" else
                                [command, str(path), "--out", "out", "--set", value])
    assert result.exit_code == 2
    assert result.stderr == f"error: {message}\n"
    assert not (tmp_path / "out").exists()


def test_a_base_error_a_set_brings_names_the_sweep_its_base_and_the_set(tmp_path):
    path = write_sweep(tmp_path, "samples = 3\n")
    result = CliRunner().invoke(main, ["sweep", str(path), "--dry-run",
                                       "--set", "ego.start_m=100", "--set", "sweep.samples=2"])
    assert result.exit_code == 2
    assert result.stderr == (
        f"error: {path}: sweep.base: {BASE}: obstacles[0].position_m: 40.0 puts the barrel "
        "behind the ego, which starts at ego.start_m = 100.0: the run would never meet it "
        "(with --set ego.start_m=100)\n")


def test_cli_sweep_needs_an_out_dir_and_checks_samples(tmp_path):
    path = write_sweep(tmp_path, "samples = 3\n")
    result = CliRunner().invoke(main, ["sweep", str(path)])
    assert result.exit_code == 2 and "--out" in result.output
    result = CliRunner().invoke(main, ["sweep", str(path), "--samples", "0", "--dry-run"])
    assert result.exit_code == 2 and "--samples" in result.output


def test_a_plugin_controller_takes_its_own_swept_parameters(tmp_path, lesson_plain):
    """A file controller is named relative to the file that names it, goes by its
    class name in run IDs, and its [controller] parameters sweep like a built-in's;
    the built-in beside it keeps only the parameters it knows."""
    (tmp_path / "ctl").mkdir()
    lesson_plain["controller"] = {"name": "ctl/mine.py:Mine", "gain": 1.0, "look_ahead_m": 8.0}
    (tmp_path / "base.toml").write_text(dumps_plain(lesson_plain))
    (tmp_path / "sweep.toml").write_text(
        '[sweep]\nname = "p"\nbase = "base.toml"\nsamples = 3\n'
        'controllers = ["ctl/mine.py:Mine", "lane-keep"]\n'
        '[sweep.params]\n"controller.gain" = { uniform = [2.0, 3.0] }\n')
    sweep = load_sweep(tmp_path / "sweep.toml")
    assert sweep.controllers == (f"{tmp_path / 'ctl' / 'mine.py'}:Mine", "lane-keep")
    plan = expand(sweep)
    assert [r.run_id for r in plan[:2]] == ["00000-Mine", "00000-lane-keep"]
    mine, lane_keep = plan[0].spec.controller, plan[1].spec.controller
    assert 2.0 <= mine.params["gain"] <= 3.0 and mine.params["look_ahead_m"] == 8.0
    assert mine.label == "Mine" and mine.look_ahead_m == 8.0
    assert lane_keep.params.look_ahead_m == 8.0 and not hasattr(lane_keep.params, "gain")


def test_each_controller_takes_the_swept_parameters_it_has(tmp_path):
    """On the seed's base scenario, avoid's and the seed's own parameters sweep side
    by side: each controller gets those its parameters have."""
    path = write_sweep(tmp_path, 'samples = 4\ncontrollers = ["seed", "lane-keep", "avoid"]\n'
                       '[sweep.params]\n"controller.detect_ttc_s" = { uniform = [2.0, 6.0] }\n'
                       '"controller.detect_range_m" = { uniform = [4.0, 8.0] }\n'
                       '"controller.look_ahead_m" = { uniform = [3.0, 9.0] }\n')
    plan = expand(load_sweep(path))
    assert all(run.spec is not None for run in plan)
    seed, lane_keep, avoid = (run.spec.controller.params for run in plan[:3])
    values = plan[0].params
    assert avoid.detect_ttc_s == values["controller.detect_ttc_s"]
    assert seed.detect_range_m == values["controller.detect_range_m"]
    assert seed.look_ahead_m == lane_keep.look_ahead_m == avoid.look_ahead_m \
        == values["controller.look_ahead_m"]
    assert not hasattr(seed, "detect_ttc_s") and not hasattr(avoid, "detect_range_m")


def test_a_swept_controller_parameter_no_controller_takes_is_refused(tmp_path):
    path = write_sweep(tmp_path, 'samples = 4\ncontrollers = ["seed", "lane-keep"]\n'
                       '[sweep.params]\n"controller.detect_ttc_s" = { uniform = [2.0, 6.0] }\n')
    with pytest.raises(SpecError) as caught:
        load_sweep(path)
    assert caught.value.field == 'sweep.params."controller.detect_ttc_s"'


def test_a_sample_invalid_for_one_controller_leaves_the_others_running(tmp_path):
    path = write_sweep(tmp_path, 'samples = 4\ncontrollers = ["seed", "avoid"]\n'
                       '[sweep.params]\n"controller.detect_ttc_s" = { uniform = [-2.0, -1.0] }\n')
    plan = expand(load_sweep(path))
    assert all(run.spec is not None for run in plan if run.controller == "seed")
    invalid = [run for run in plan if run.controller == "avoid"]
    assert all(run.spec is None and "controller.detect_ttc_s" in run.error for run in invalid)


def test_a_sweep_too_big_to_plan_is_refused_before_anything_is_planned(tmp_path, monkeypatch):
    """10,000,000 samples x 2 controllers: exit 2 as the file is read, naming the field,
    the limit and what to do instead; nothing is planned (a plan of that size held
    the terminal silent for minutes, then ran out of memory)."""
    import scenarios.spec.sweep_plan as sweep_plan
    import scenarios.spec.sweep_spec as sweep_spec

    def no_plan(*args, **kwargs):
        raise AssertionError("planned a sweep it should have refused")

    monkeypatch.setattr(sweep_plan, "expand", no_plan)
    path = write_sweep(tmp_path, 'samples = 10_000_000\ncontrollers = ["seed", "avoid"]\n')
    result = CliRunner().invoke(main, ["sweep", str(path), "--dry-run"])
    assert result.exit_code == 2, result.output
    assert ("sweep.samples: 10000000 samples x 2 controllers = 20,000,000 runs, more than "
            f"the {sweep_spec.MAX_RUNS:,} a sweep plans") in result.output
    assert "sdc estimate" in result.output and "Traceback" not in result.output
    small = write_sweep(tmp_path, 'samples = 3\ncontrollers = ["seed", "avoid"]\n')
    result = CliRunner().invoke(main, ["sweep", str(small), "--samples", "50001", "--dry-run"])
    assert result.exit_code == 2 and "--samples: 50001 samples x 2 controllers" in result.output
    with pytest.raises(SpecError, match="the grid has 300000 points x 1 controller = 300,000"):
        make(sampler="grid", samples=None, levels=None,
             params={"scenario.seed": {"int_range": [1, 300_000]}})
    assert make(samples=sweep_spec.MAX_RUNS).samples == sweep_spec.MAX_RUNS  # at the limit


def test_planning_says_how_far_it_got():
    sweep = make(samples=2500, controllers=["seed", "lane-keep"])
    seen = []
    plan = expand(sweep, lambda done, total: seen.append((done, total)))
    assert seen[0] == (0, 5000) and seen[-1] == (5000, 5000) == (len(plan), 5000)
    assert [d for d, _ in seen] == sorted(d for d, _ in seen) and len(seen) >= 6


def test_the_planning_bar_shows_on_a_terminal_for_big_plans():
    import io

    from rich.console import Console

    from sdc.batch.sweeps.progress import PLANNING_SHOWN_RUNS, RichReporter

    out = io.StringIO()
    reporter = RichReporter(Console(file=out, force_terminal=True, width=100))
    reporter.planning(0, PLANNING_SHOWN_RUNS)  # small: no bar
    assert out.getvalue() == ""
    for done in (0, 3000, 2 * PLANNING_SHOWN_RUNS):
        reporter.planning(done, 2 * PLANNING_SHOWN_RUNS)
    assert "planning the runs" in out.getvalue()
