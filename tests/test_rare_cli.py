"""sdc search and sdc estimate for real: runs on the executors (on the scripted backend, a
world without a simulator: no traffic here, so SUMO's runs), rows, resume, replay, report,
wrong use."""

from __future__ import annotations

import dataclasses
import json
import math
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from analysis.measures.commands import replay_command
from analysis.measures.run_score import run_score
from analysis.rare.failure_estimate import estimate_from_rows
from analysis.report.rare_report import estimate_lines
from scenarios import CATALOG_DIR
from scenarios.spec.sweep_spec import load_sweep
from sdc.batch.executors.local_executor import LocalExecutor
from sdc.batch.executors.ray_executor import RayExecutor
from sdc.batch.sweeps.adaptive_runner import AdaptiveSettings, run_adaptive
from sdc.batch.sweeps.progress import QuietReporter
from sdc.cli import main

SDC = [sys.executable, "-m", "sdc"]
#: the lesson on the scripted backend (no traffic: the runs SUMO gives, without SUMO)
BASE = Path(__file__).resolve().parent / "data" / "seed-lesson-scripted.toml"
# the lesson around its design point (speeds a bounded range: a search reaches the tails,
# and a normal speed there goes negative); the seed maneuver fails often here,
# so a few hundred runs show everything; short runs
TOY = f"""[sweep]
name = "toy"
base = "{BASE}"
samples = 10
seed = 3
controllers = ["seed"]

[sweep.params]
"ego.speed_mps" = {{ uniform = [1.5, 6.0] }}
"obstacles[0].lateral_offset_m" = {{ normal = [0.0, 0.3] }}
"scenario.duration_s" = {{ choice = [15.0] }}
"""


def write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return path


def sdc(*args) -> subprocess.CompletedProcess:
    """``sdc ARGS`` in this process: its exit code, output and errors as a process's
    (the kill test starts one of its own)."""
    result = CliRunner().invoke(main, [str(a) for a in args])
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        raise result.exception
    return subprocess.CompletedProcess(args, result.exit_code, result.stdout, result.stderr)


# ---------------------------------------------------------------- units, no simulator

def _row(**values) -> dict:
    row = {"status": "ok", "collision": False, "min_gap_obstacle_m": 2.0,
           "min_road_edge_gap_m": 0.5, "min_ttc_s": None}
    return {**row, **values}


def test_a_score_is_zero_exactly_for_a_collision_or_no_outcome():
    assert run_score(_row()) == 0.5  # the road edge came closer than the obstacle
    assert run_score(_row(min_road_edge_gap_m=None)) == 2.0
    assert run_score(_row(collision=True)) == 0.0
    assert run_score(_row(status="error", collision=None)) == 0.0
    assert run_score(_row(status="timeout", collision=None)) == 0.0
    assert 0 < run_score(_row(min_gap_obstacle_m=0.0)) < 1e-6  # touching is not a collision
    assert run_score(_row(min_ttc_s=None), "ttc") == math.inf
    assert run_score(_row(min_ttc_s=1.5), "ttc") == 1.5


def test_the_estimate_says_its_bound_or_its_interval_and_never_rounds_a_loss_to_1x():
    e = {"p_collision": 0.418, "ci_low": 0.367, "ci_high": 0.469, "rhw": 0.12, "runs": 400,
         "estimation_runs": 350, "failures": 120, "ess": 279.4, "mc_equivalent_runs": 361.0,
         "acceleration": 361 / 400, "max_term_share": 0.012}
    interval, cost = estimate_lines(e, "budget", 0.15)
    assert interval == ("P(collision) = 0.418, 95% interval [0.367, 0.469], RHW 0.12 "
                        "(target 0.15; budget spent before the target RHW)")
    assert "0.9x the 400 runs spent (350 weighted, ESS 279)" in cost
    assert "25x the" in estimate_lines({**e, "acceleration": 25.3}, "target_rhw", 0.3)[1]
    [bound] = estimate_lines({**e, "failures": 0}, None, 0.3)
    assert bound == "P(collision) <= 0.469 (95%): no collision in 350 weighted runs (not finished)"
    assert estimate_lines(None, None, 0.3)[0].startswith("no estimate")
    # below its target RHW, but stopped by the budget before the RHW could be judged
    rule = {"estimation_runs": 1500, "failures": 30, "max_term_share": 0.1}
    [unjudged, _] = estimate_lines({**e, "failures": 12, "max_term_share": 0.14}, "budget",
                                   0.15, rule)
    assert unjudged.endswith("(target 0.15; budget spent before the RHW could be judged: 350 "
                             "of the 1500 weighted runs it needs, 12 of the 30 collisions it "
                             "needs, one run carries 14% of P (at most 10%))")
    judged = {**e, "estimation_runs": 1500, "rhw": 0.2}
    assert estimate_lines(judged, "budget", 0.15, rule)[0].endswith(
        "(target 0.15; budget spent before the target RHW)")


# ---------------------------------------------------------------- runs on the executors

@pytest.mark.slow
def test_search_finds_collisions_and_every_run_is_a_replayable_row(tmp_path):
    sweep = write(tmp_path, "toy", TOY)
    out = tmp_path / "search"
    done = sdc("search", sweep, "--out", out, "--budget", 60, "--batch-size", 20,
               "--workers", 2, "--quiet")
    assert done.returncode == 0, done.stderr
    summary = json.loads((out / "search.json").read_text())
    results = pd.read_parquet(out / "results.parquet")
    assert len(results) == summary["runs"] == 60 and results.run_id.is_unique
    assert list(results.batch.unique()) == [0, 1, 2]
    assert set(results.phase) <= {"adapt", "search"}
    collided = results.collision.astype(bool)
    assert (collided == (results.score <= 0)).all()  # every run ok here: score <= 0 iff hit
    assert summary["failures"] == collided.sum() > 0
    first = results[collided].run_index.min() + 1
    assert summary["first_failure_run"] == first
    first_id = results.set_index("run_index").run_id[first - 1]
    assert summary["first_failure_run_id"] == first_id  # ids count from 0
    runs = "run" if first == 1 else "runs"
    assert f"the first: run {first_id}, after {first} {runs}" in done.stdout
    modes = summary["failure_modes"]
    assert sum(m["runs"] for m in modes) == summary["failures"]
    assert {m["outcome"] for m in modes} <= {"obstacle", "road_edge"}
    # each mode names an example run of its own and the command that replays it
    for mode in modes:
        assert mode["example_run"] in mode["run_ids"]
        assert mode["replay"] == replay_command(out, mode["example_run"])
    # a failed run replays to the same trace
    run_id = results[collided].run_id.iloc[0]
    replay = sdc("replay", out, "--run", run_id, "--verify")
    assert replay.returncode == 0 and "identical" in replay.stdout, replay.stdout + replay.stderr
    report = sdc("report", out)
    assert report.returncode == 0, report.stderr
    assert "no probability" in report.stdout and "search of toy" in report.stdout
    assert "Runs drawn over" in (out / "report.html").read_text()


# stands still when it starts above 4 m/s, else holds its speed into the barrel
STOP_WHEN_FAST = """
from sdc.car.controller_api import Command


class StopWhenFast:
    def __init__(self, params):
        self.stop = None

    def step(self, obs):
        if self.stop is None:
            self.stop = obs.speed_mps > 4.0
        return Command(0.0, -8.0 if self.stop else 0.0)
"""


@pytest.mark.slow
def test_a_search_reports_its_stuck_runs_beside_its_collisions(tmp_path):
    (tmp_path / "stop.py").write_text(STOP_WHEN_FAST)
    plugin = f"{tmp_path / 'stop.py'}:StopWhenFast"
    sweep = write(tmp_path, "toy", TOY.replace('["seed"]', f'["{plugin}"]'))
    out = tmp_path / "search"
    done = sdc("search", sweep, "--out", out, "--budget", 40, "--batch-size", 20, "--quiet")
    assert done.returncode == 0, done.stderr
    rows = pd.read_parquet(out / "results.parquet")
    stuck = rows[rows.outcome == "stuck"]
    assert 0 < len(stuck) < len(rows) and (stuck["p.ego.speed_mps"] > 4.0).all()
    summary = json.loads((out / "search.json").read_text())
    grouped = sorted(r for m in summary["stuck_modes"] for r in m["run_ids"])
    assert grouped == sorted(stuck.run_id)
    assert {m["outcome"] for m in summary["stuck_modes"]} <= {"stuck", "other"}
    assert f"stuck (no collision, standing still at the end): {len(stuck)} of 40 runs" in (
        done.stdout)
    report = sdc("report", out)
    assert report.returncode == 0, report.stderr
    assert f"{len(stuck)} stuck" in report.stdout and "stuck runs:" in report.stdout
    page = (out / "report.html").read_text()
    assert "<h2>Stuck runs</h2>" in page and stuck.run_id.iloc[0] in page


@pytest.mark.slow
def test_estimate_is_recomputable_from_the_rows_and_resumes_after_kill(tmp_path):
    sweep = write(tmp_path, "toy", TOY)
    args = ["--target-rhw", 0.15, "--max-runs", 200, "--batch-size", 40, "--workers", 2,
            "--quiet"]
    whole = tmp_path / "whole"
    done = sdc("estimate", sweep, "--out", whole, *args)
    assert done.returncode == 0, done.stderr
    saved = json.loads((whole / "estimate.json").read_text())
    for key in ("p_collision", "ci_low", "ci_high", "rhw", "runs", "ess",
                "mc_equivalent_runs", "stopped"):
        assert saved[key] is not None, key
    assert saved["stopped"] in ("target_rhw", "budget") and saved["state"] == "finished"
    assert saved["ci_low"] < saved["p_collision"] < saved["ci_high"]
    results = pd.read_parquet(whole / "results.parquet")
    estimation = results[results.phase == "estimate"]
    again = estimate_from_rows(estimation.weight.to_numpy(), (estimation.score <= 0).to_numpy(),
                               runs=len(results), max_weight=saved["max_weight"])
    assert again.p_collision == saved["p_collision"] and again.rhw == saved["rhw"]
    assert again.ess == saved["ess"] and saved["runs"] == len(results)
    # the adaptation's runs carry weights too, but only the estimation rows count
    assert (results.phase == "adapt").sum() == saved["adaptation_runs"] > 0

    killed = tmp_path / "killed"
    proc = subprocess.Popen([*SDC, "estimate", str(sweep), "--out", str(killed),
                             *map(str, args)], start_new_session=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and len(list((killed / "parts").glob("*"))) < 2:
            time.sleep(0.1)
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert not (killed / "results.parquet").exists()
    resumed = sdc("estimate", sweep, "--out", killed, *args, "--resume")
    assert resumed.returncode == 0, resumed.stderr
    columns = ["run_id", "batch", "phase", "weight", "score", "trace_sha256"]
    assert pd.read_parquet(killed / "results.parquet")[columns].equals(results[columns])
    assert json.loads((killed / "estimate.json").read_text())["p_collision"] == \
        saved["p_collision"]
    # other options are another estimate: refused, not mixed
    other = sdc("estimate", sweep, "--out", killed, *args[:-1], "--batch-size", 80, "--resume")
    assert other.returncode == 2 and "different sweep" in other.stderr

    report = sdc("report", whole)
    assert report.returncode == 0, report.stderr
    # the estimate's own printout and its report say P(collision) in the same words
    said = [line for line in done.stdout.splitlines() if line.startswith("P(collision) = ")]
    assert len(said) == 1 and f"P(collision) = {saved['p_collision']:.3g}, 95%" in said[0]
    assert said[0] in report.stdout.splitlines()
    # the modes are listed once, in their own table, and the terms are defined
    assert report.stdout.count("failure modes:") == 1
    first = saved["failure_modes"][0]
    assert report.stdout.count(f"e.g. {first['example_run']}") == 1
    # the runs to look at: the estimation's failures first, the most of P first, at most 50
    markdown = (whole / "report.md").read_text().split("## Runs to look at")[1]
    listed = re.findall(r"^- `([^`]+)`", markdown, flags=re.MULTILINE)
    bad = results[(results.status != "ok") | results.collision.fillna(False).astype(bool)
                  | (results.outcome == "stuck")]
    assert len(listed) == min(len(bad), 50) > 0
    assert (f"... {len(bad) - 50} more in results.parquet" in markdown) == (len(bad) > 50)
    order = results.set_index("run_id").loc[listed]
    counted = ((order.phase == "estimate") & (order.score <= 0)
               & (order.status == "ok")).to_numpy()
    first = int(counted.argmax())
    assert counted.any() and counted[first:first + counted.sum()].all()
    assert (order.status != "ok").to_numpy()[:first].all()
    assert order.weight[counted].is_monotonic_decreasing
    page = (whole / "report.html").read_text()
    assert "Convergence" in page and "RHW: the 95% interval&#x27;s half-width" in page
    assert "P (95% interval): its part of P(collision)" in page
    summary = json.loads((whole / "summary.json").read_text())
    assert summary["estimate"]["p_collision"] == saved["p_collision"]


@pytest.mark.slow
@pytest.mark.parametrize("settings", [
    AdaptiveSettings("search", "seed", 40, 20),
    AdaptiveSettings("estimate", "seed", 100, 25, target_rhw=0.05),
], ids=["search", "estimate"])
def test_search_and_estimate_on_ray_draw_the_same_runs_as_on_local_processes(tmp_path,
                                                                             settings,
                                                                             ray_session):
    sweep = load_sweep(write(tmp_path, "toy", TOY))
    tables, summaries = [], []
    for name, executor in (("local", LocalExecutor(2)), ("ray", RayExecutor(2))):
        outcome = run_adaptive(sweep, tmp_path / name, executor, QuietReporter(), settings)
        tables.append(pd.read_parquet(tmp_path / name / "results.parquet"))
        summaries.append(outcome.summary)
    columns = ["run_id", "seed", "batch", "phase", "weight", "score", "trace_sha256",
               "p.ego.speed_mps"]
    assert tables[0][columns].equals(tables[1][columns])
    assert set(tables[0].phase) > {"adapt"}  # past the adaptation: the estimate's own runs
    if settings.mode == "estimate":
        assert summaries[0]["p_collision"] == summaries[1]["p_collision"] > 0


# ---------------------------------------------------------------- wrong use

@pytest.mark.parametrize("edit, args, message", [
    (lambda t: t.replace('samples = 10\n', 'sampler = "grid"\n').replace(
        '{ uniform = [1.5, 6.0] }', '{ uniform = [3.0, 5.0] }').replace(
        '{ normal = [0.0, 0.3] }', '{ choice = [0.0] }'),
     ["--budget", 100], "sweep.sampler: search draws its own samples"),
    (lambda t: t.replace('{ uniform = [1.5, 6.0] }', '{ choice = [3.0, 4.0] }').replace(
        '{ normal = [0.0, 0.3] }', '{ choice = [0.0] }'),
     ["--budget", 100], "sweep.params: search adapts the sampling of continuous"),
    (lambda t: t, ["--budget", 30], "--budget: 30 runs are too few to adapt"),
    (lambda t: t.replace('["seed"]', '["seed", "avoid"]'), ["--budget", 100],
     "--controller: the sweep lists 2 controllers"),
    (lambda t: t, ["--budget", 100, "--controller", "avoid"],
     "--controller: 'avoid' is not one of the sweep's controllers"),
])
def test_wrong_use_of_search_is_a_clear_error(tmp_path, edit, args, message):
    sweep = write(tmp_path, "bad", edit(TOY))
    done = sdc("search", sweep, "--out", tmp_path / "out", *args)
    assert done.returncode == 2 and message in done.stderr, done.stderr
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("args, message", [
    (["--target-rhw", 0], "--target-rhw: must be > 0"),
    (["--target-rhw", -0.3], "--target-rhw: must be > 0"),
    (["--max-runs", 300], "--max-runs: 300 runs are too few to adapt"),
])
def test_wrong_use_of_estimate_is_a_clear_error(tmp_path, args, message):
    sweep = write(tmp_path, "toy", TOY)
    done = sdc("estimate", sweep, "--out", tmp_path / "out", *args)
    assert done.returncode == 2 and message in done.stderr, done.stderr



# ---------------------------------------------------------------- the catalog's seed-rare

RARE = CATALOG_DIR / "sweeps" / "seed-rare.toml"


def _truth() -> dict:
    return json.loads((CATALOG_DIR / "sweeps" / "seed-rare.truth.json").read_text())


def test_the_seed_rare_emulator_is_the_truth_files_family():
    """The statistics of seed-rare (its estimate covers the truth with 20x fewer runs than
    plain Monte Carlo: tests/test_rare_bank.py; its search below) run on
    analysis.rare.rare_bank's emulator: its P lies within the truth file's bounds, and its
    gap is the one the runs beside the boundary measured (tests/test_seed_rare.py holds
    real runs to those)."""
    from analysis.rare.rare_bank import SEED_RARE_EMULATED

    truth = _truth()
    assert truth["p_low"] <= SEED_RARE_EMULATED.truth <= truth["p_high"]
    (v_mean, v_sd), (w_mean, w_sd) = (truth["nominal"][name]["normal"]
                                      for name in ("ego.speed_mps", "road.lane_width_m"))
    for example in truth["boundary_examples"]:
        z = np.array([[(example["speed_mps"] - v_mean) / v_sd,
                       (example["lane_width_m"] - w_mean) / w_sd]])
        gap = SEED_RARE_EMULATED.score(z)[0]
        assert gap == pytest.approx(example["predicted_gap_m"], abs=1e-6)  # as real runs
        assert bool(gap <= 0) == example["collision"]


def test_search_finds_a_collision_on_the_seed_rare_emulator_10x_sooner_than_uniform():
    """Median over 20 seeds of the runs to a first collision, against 1 / p (about 2060);
    measured: 48."""
    from analysis.rare.rare_bank import SEED_RARE_EMULATED, sampled_runs

    firsts = []
    for seed in range(20):
        runs = sampled_runs(SEED_RARE_EMULATED, "search", seed, 600)
        failed = np.flatnonzero(runs.score.to_numpy() <= 0)
        assert failed.size, seed
        firsts.append(int(failed[0]) + 1)
    assert np.median(firsts) * 10 <= 1 / SEED_RARE_EMULATED.truth, firsts


@pytest.mark.slow
def test_a_real_search_on_seed_rare_stops_at_its_first_road_edge_collision(tmp_path):
    """The wiring on real runs, one seed (the statistics: the emulator, above). The family
    has no traffic: on the scripted backend (a world without a simulator) its runs are
    SUMO's, bit for bit, without building a network for each lane width."""
    sweep = dataclasses.replace(load_sweep(RARE, ['scenario.backend="scripted"']), seed=1)
    settings = AdaptiveSettings("search", "seed", 600, 20, stop_after=1)
    summary = run_adaptive(sweep, tmp_path, LocalExecutor(2), QuietReporter(),
                           settings).summary
    assert summary["stopped"] == "failures found"
    assert summary["first_failure_run"] * 10 <= 1 / _truth()["p_true"]
    assert {m["outcome"] for m in summary["failure_modes"]} == {"road_edge"}
