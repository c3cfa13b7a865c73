"""Replay: exact re-simulation, divergence located to its step, GIF and HTML drawings."""

from __future__ import annotations

import concurrent.futures
import dataclasses
import json
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

from analysis.measures.sweep_manifest import SweepManifest
from analysis.measures.trace_file import Trace, read_trace
from analysis.report.render import frame_steps, scene_from_trace, script_json, write_html
from scenarios import CATALOG_DIR
from scenarios.spec.sweep_spec import load_sweep
from sdc.batch.executors.local_executor import LocalExecutor
from sdc.batch.sweeps.manifest import package_versions
from sdc.batch.sweeps.progress import QuietReporter
from sdc.batch.sweeps.replay_check import first_divergence, version_warnings
from sdc.batch.sweeps.sweep_runner import run_sweep
from sdc.cli import main

#: the lesson on the scripted backend (a world without a simulator): the base of the sweeps
#: here, but the one the GUI (SUMO's) replays
SCRIPTED_LESSON = Path(__file__).resolve().parent / "data" / "seed-lesson-scripted.toml"
SWEEP = f"""[sweep]
name = "replays"
base = "{SCRIPTED_LESSON}"
sampler = "grid"
controllers = ["seed", "lane-keep"]

[sweep.params]
"ego.speed_mps" = {{ choice = [3.74, 9.0] }}
"traffic.flow_vph_per_lane" = {{ choice = [0, 1200] }}
"road.speed_limit_mps" = {{ choice = [27.78] }}
"scenario.duration_s" = {{ choice = [12.0] }}
"""
RUN = "00000-seed"  # 3.74 m/s, no traffic: the lesson's maneuver, about 190 steps


def fake_trace(n: int = 6) -> Trace:
    floats = {name: np.arange(n, dtype=float) for name in
              ("t_s", "x_m", "y_m", "yaw_rad", "speed_mps", "steer_rad", "steer_cmd_rad",
               "lane_offset_m", "heading_error_rad", "s_m", "obstacle_gap_m", "ttc_s",
               "drac_mps2", "headway_s")}
    floats["lane_offset_m"][:] = np.nan
    return Trace(floats, ["lane_keep"] * n, [np.full(4, np.inf, np.float32)] * n,
                 [np.zeros(5, np.float32)] * n, [["passenger"]] * n)


def altered(trace: Trace, **floats) -> Trace:
    return dataclasses.replace(trace, floats={**trace.floats, **floats})


def test_first_divergence_names_the_earliest_step_and_field():
    a = fake_trace()
    assert first_divergence(a, fake_trace()) is None  # NaN equals NaN here
    speed = a.floats["speed_mps"].copy()
    speed[4] = 99.0
    yaw = a.floats["yaw_rad"].copy()
    yaw[4] = -1.0
    d = first_divergence(a, altered(a, speed_mps=speed, yaw_rad=yaw))
    assert (d.step, d.field, d.recorded, d.replayed) == (4, "yaw_rad", 4.0, -1.0)
    lidar = list(a.lidar)
    lidar[2] = np.array([np.inf, 3.0, np.inf, np.inf], np.float32)
    d = first_divergence(a, dataclasses.replace(a, lidar=lidar))
    assert (d.step, d.field, d.replayed) == (2, "lidar[1]", 3.0)
    d = first_divergence(a, dataclasses.replace(a, phase=["lane_keep"] * 3 + ["avoid_left"] * 3))
    assert (d.step, d.field) == (3, "phase")
    shorter = Trace({k: v[:5] for k, v in a.floats.items()}, a.phase[:5], a.lidar[:5],
                    a.traffic[:5], a.traffic_class[:5])
    d = first_divergence(a, shorter)
    assert (d.step, d.field, d.recorded, d.replayed) == (5, "steps", 6, 5)


@pytest.fixture(scope="module")
def sweep_dir(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("replay")
    (tmp / "sweep.toml").write_text(SWEEP)
    out = tmp / "sweep"
    outcome = run_sweep(load_sweep(tmp / "sweep.toml"), out, LocalExecutor(2), QuietReporter(),
                        traces="all")
    assert outcome.counts["ok"] == 8
    return out



@pytest.mark.slow
def test_every_run_of_a_two_worker_sweep_replays_identically(sweep_dir):
    for run_id in sorted(p.stem for p in (sweep_dir / "traces").glob("*.parquet")):
        result = CliRunner().invoke(main, ["replay", str(sweep_dir), "--run", run_id,
                                           "--verify"])
        assert result.exit_code == 0, result.output
        assert "identical: trace sha256" in result.output


@pytest.mark.slow
def test_a_trace_altered_at_step_k_diverges_at_step_k(sweep_dir, tmp_path):
    copy = tmp_path / "sweep"
    shutil.copytree(sweep_dir, copy)
    path = copy / "traces" / f"{RUN}.parquet"
    trace, metadata = read_trace(path)
    speed = trace.floats["speed_mps"].copy()
    speed[37] += 0.5
    altered(trace, speed_mps=speed).write(path, metadata)
    result = CliRunner().invoke(main, ["replay", str(copy), "--run", RUN])
    assert result.exit_code == 0  # without --verify a divergence is reported, not failed
    assert "DIVERGED: diverged at step 37, field speed_mps: recorded 4.24" in result.output
    assert "replayed 3.74" in result.output
    verify = CliRunner().invoke(main, ["replay", str(copy), "--run", RUN, "--verify"])
    assert verify.exit_code == 1


@pytest.mark.slow
def test_gif_has_one_frame_per_kept_step(sweep_dir, tmp_path):
    out = tmp_path / "run.gif"
    result = CliRunner().invoke(main, ["replay", str(sweep_dir), "--run", RUN, "--out",
                                       str(out), "--every", "20"])
    assert result.exit_code == 0, result.output
    steps = len(read_trace(sweep_dir / "traces" / f"{RUN}.parquet")[0])
    expected = len(frame_steps(steps, 20))
    assert expected == -(-steps // 20) + (steps % 20 != 1)
    assert Image.open(out).n_frames == expected
    assert f"{expected} frames written to {out}" in result.output


@pytest.mark.slow
def test_html_page_steps_on_click_in_headless_chromium(sweep_dir, tmp_path):
    from playwright.sync_api import sync_playwright

    trace_file = tmp_path / "run.parquet"
    shutil.copy(sweep_dir / "traces" / f"{RUN}.parquet", trace_file)
    result = CliRunner().invoke(main, ["replay", str(trace_file), "--every", "3"])
    assert result.exit_code == 0, result.output
    page_file = tmp_path / "run.html"  # the default: beside the trace
    assert page_file.exists() and "http" not in page_file.read_text().split("<script>")[0]
    chromium = shutil.which("chromium")
    assert chromium, "Debian's chromium is needed (make test installs it)"
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, args=[
            "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
            "--disable-background-networking", "--disable-component-update", "--disable-sync"])
        page = browser.new_page()
        problems = []
        page.on("console", lambda m: problems.append(m.text) if m.type == "error" else None)
        page.on("pageerror", lambda e: problems.append(str(e)))
        page.goto(page_file.as_uri())
        assert page.get_attribute("body", "data-step") == "0"
        # a scale bar, labelled strip charts, a time axis in round steps
        assert page.get_attribute("#scene", "data-scale-bar-m") == "10"
        assert page.get_attribute("#strip", "data-panels") == \
            "speed [m/s]|lane offset [m]|central range [m] (\u2264 20)"
        assert page.get_attribute("#strip", "data-tick-s") in ("1", "2")  # a 12 s run
        page.screenshot(path=str(tmp_path / "page.png"))
        shot = np.asarray(Image.open(tmp_path / "page.png").convert("L"), float)
        assert shot.std() > 10
        page.click("#next")
        page.click("#next")
        assert page.get_attribute("body", "data-step") == "6"
        assert "step 6" in page.text_content("#status")
        page.click("#beams")  # beams off, still drawing
        page.click("#prev")
        assert page.get_attribute("body", "data-step") == "3"
        browser.close()
    assert problems == []


HOSTILE = "</script><img src=x onerror=document.title=666><!-- & \u2028"


def test_data_in_a_script_block_stays_text():
    data = {"title": HOSTILE, "frames": [{"phase": "</SCRIPT >"}]}
    text = script_json(data)
    assert not set("<>&") & set(text)
    assert json.loads(text) == data


@pytest.mark.slow
def test_a_hostile_scenario_name_runs_no_script_in_the_replay_page(sweep_dir, tmp_path,
                                                                  chromium_page):
    """The issue's case: a name that closes the script block and adds a handler."""
    scene = scene_from_trace(*read_trace(sweep_dir / "traces" / f"{RUN}.parquet"))
    page_file = tmp_path / "run.html"
    write_html(dataclasses.replace(scene, title=HOSTILE), page_file, every=20)
    page, problems = chromium_page
    page.goto(page_file.as_uri())
    page.wait_for_timeout(200)  # time for an injected image's error handler
    assert page.text_content("#title") == HOSTILE  # shown as text
    assert page.title() != "666" and page.query_selector("img") is None
    assert problems == []


@pytest.mark.slow
def test_gui_replay_on_a_virtual_display_is_identical(tmp_path):
    xvfb_run = shutil.which("xvfb-run")
    assert xvfb_run, "Debian's xvfb is needed (make test installs it)"
    # the sweep's 00002-seed (9 m/s, no traffic) on SUMO, whose GUI it is
    (tmp_path / "sumo.toml").write_text(SWEEP.replace(str(SCRIPTED_LESSON), str(
        CATALOG_DIR / "seed-lesson.toml")).replace("[3.74, 9.0]", "[9.0]").replace(
        "[0, 1200]", "[0]").replace('["seed", "lane-keep"]', '["seed"]'))
    sumo_dir = tmp_path / "sweep"
    run_sweep(load_sweep(tmp_path / "sumo.toml"), sumo_dir, LocalExecutor(1), QuietReporter(),
              traces="all")
    done = subprocess.run([xvfb_run, "-a", sys.executable, "-m", "sdc", "replay",
                           str(sumo_dir), "--run", "00000-seed", "--gui", "--verify"],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "identical: trace sha256" in done.stdout


@pytest.mark.slow
def test_replay_bad_inputs_exit_2(sweep_dir, tmp_path):
    def run(*args, env=None):
        return CliRunner(env=env).invoke(main, ["replay", *map(str, args)])

    assert "--run: no run 'nope'" in run(sweep_dir, "--run", "nope").output
    assert run(sweep_dir, "--run", "nope").exit_code == 2
    assert run(sweep_dir).exit_code == 2
    assert "must end in .gif" in run(sweep_dir, "--run", RUN, "--out", tmp_path / "x.txt").output
    no_display = run(sweep_dir, "--run", RUN, "--gui", env={"DISPLAY": None,
                                                             "WAYLAND_DISPLAY": None})
    assert no_display.exit_code == 2 and "--gui: no display" in no_display.output
    assert "not a sweep directory" in run(tmp_path, "--run", RUN).output
    png = tmp_path / "x.png"
    for at in ("-1", "nan", "inf"):
        refused = run(sweep_dir, "--run", RUN, "--out", png, "--at", at)
        assert refused.exit_code == 2 and "'--at'" in refused.output, at
    # past the run's end: refused before anything is simulated or written
    past = run(sweep_dir, "--run", RUN, "--out", png, "--at", "1000")
    assert past.exit_code == 2 and "--at: 1000 s is past the run's end at " in past.output
    assert "identical" not in past.output and not png.exists()


def test_versions_other_than_the_sweeps_are_warned_about():
    now = package_versions()
    assert version_warnings(SweepManifest.from_dict({"versions": now})) == []
    lines = version_warnings(SweepManifest.from_dict({"versions": {**now, "numpy": "0.0.1"}}))
    assert lines == [f"warning: the sweep ran with numpy 0.0.1, this is {now['numpy']}"]


@pytest.mark.slow
def test_mp4_is_written_with_ffmpeg_and_refused_clearly_without(sweep_dir, tmp_path):
    from matplotlib import animation

    out = tmp_path / "run.mp4"
    result = CliRunner().invoke(main, ["replay", str(sweep_dir), "--run", RUN, "--out",
                                       str(out), "--every", "50"])
    if animation.writers.is_available("ffmpeg"):
        assert result.exit_code == 0 and out.stat().st_size > 0
    else:
        assert result.exit_code == 2 and "needs ffmpeg" in result.output and not out.exists()


@pytest.mark.slow
def test_one_frame_as_png_at_the_decisive_moment_or_at_a_time(sweep_dir, tmp_path):
    crash = "00000-lane-keep"  # 3.74 m/s into the barrel: the collision is its last step
    trace, metadata = read_trace(sweep_dir / "traces" / f"{crash}.parquet")
    assert metadata["run"]["outcome"] == "collided"
    out = tmp_path / "frame.png"
    result = CliRunner().invoke(main, ["replay", str(sweep_dir), "--run", crash, "--out",
                                       str(out)])
    assert result.exit_code == 0, result.output
    last = len(trace) - 1
    assert f"step {last} (t = {trace.floats['t_s'][last]:.3f} s) written to {out}" \
        in result.output
    image = Image.open(out)
    assert image.format == "PNG" and image.size[0] >= 600
    assert np.asarray(image.convert("L")).std() > 10  # a drawing, not a blank
    at = tmp_path / "at.png"
    result = CliRunner().invoke(main, ["replay", str(sweep_dir / "traces" / f"{crash}.parquet"),
                                       "--out", str(at), "--at", "2.0"])
    k = int(np.searchsorted(trace.floats["t_s"], 2.0 + 1e-9, side="right") - 1)
    assert result.exit_code == 0 and f"step {k} (t = " in result.output
    assert trace.floats["t_s"][k] <= 2.0 < trace.floats["t_s"][k + 1]
    bad = CliRunner().invoke(main, ["replay", str(sweep_dir), "--run", crash, "--at", "2"])
    assert bad.exit_code == 2 and "--at: draws one frame" in bad.output


HOSTILE_PLUGIN = """
import time
from sdc.car.controller_api import Command


class RaisesFirst:
    def __init__(self, params):
        pass

    def step(self, obs):
        raise ZeroDivisionError("first step")


class RaisesAtStep3:
    def __init__(self, params):
        self.k = 0

    def step(self, obs):
        self.k += 1
        if self.k == 3:
            raise ValueError("step three")
        return Command(0.0)


class Sleepy:
    def __init__(self, params):
        pass

    def step(self, obs):
        time.sleep(0.4)
        return Command(0.0)
"""


@pytest.mark.slow
def test_every_replay_the_report_of_a_hostile_sweep_prints_exits_cleanly(tmp_path):
    """Plug-ins that raise in their first step and in their third, one that runs
    past the run timeout, and a collision: each replay command the report lists
    runs with and without a drawing, in lines (the error, where it was raised, the
    run's parameters) and exit 0 or 1, never a traceback."""
    (tmp_path / "hostile.py").write_text(HOSTILE_PLUGIN)
    plugin = tmp_path / "hostile.py"
    sweep = tmp_path / "hostile.toml"
    sweep.write_text(SWEEP.replace('name = "replays"', 'name = "hostile"').replace(
        'controllers = ["seed", "lane-keep"]',
        f'controllers = ["{plugin}:RaisesFirst", "{plugin}:RaisesAtStep3", "{plugin}:Sleepy", '
        '"lane-keep"]').replace('choice = [3.74, 9.0]', 'choice = [9.0]').replace(
        'choice = [0, 1200]', 'choice = [0]'))
    out = tmp_path / "out"

    def sdc_here(*args):  # the same command in this process
        result = CliRunner().invoke(main, [str(a) for a in args])
        assert result.exception is None or isinstance(result.exception, SystemExit)
        return result

    done = sdc_here("sweep", sweep, "--out", out, "--workers", "2", "--run-timeout", "2",
                    "--quiet")
    assert done.exit_code in (0, 1), done.stderr
    assert sdc_here("report", out).exit_code in (0, 1)
    # each command as printed: the interpreter that ran the report, -m sdc, replay ...
    commands = sorted(set(re.findall(r"`([^`]*-m sdc replay \S+ --run [\w-]+)`",
                                     (out / "report.md").read_text())))
    assert {c.rsplit(" ", 1)[1] for c in commands} == {
        "00000-RaisesFirst", "00000-RaisesAtStep3", "00000-Sleepy", "00000-lane-keep"}
    # the eight replays are independent processes: run side by side, the Sleepy ones'
    # waits for the run timeout (2 s each) overlap the others' work
    jobs = {}  # (command, with a drawing) -> the words run
    for command in commands:
        run_id = command.rsplit(" ", 1)[1]
        for extra in ((), ("--out", tmp_path / f"{run_id}.png")):
            jobs[command, bool(extra)] = [*shlex.split(command), *map(str, extra)]
    with concurrent.futures.ThreadPoolExecutor(len(jobs)) as pool:
        replays = dict(zip(jobs, pool.map(lambda words: subprocess.run(
            words, capture_output=True, text=True, timeout=300), jobs.values()), strict=True))
    for (command, _), replay in replays.items():
        run_id = command.rsplit(" ", 1)[1]
        assert "Traceback" not in replay.stdout + replay.stderr, command
        assert replay.returncode in (0, 1), replay.stderr
        if run_id == "00000-lane-keep":
            continue
        first = replay.stdout.splitlines()[0]
        assert first.startswith(f"{run_id}: ") and "ego.speed_mps=9" in first
    raises = sdc_here("replay", out, "--run", "00000-RaisesAtStep3", "--out", tmp_path / "r.png")
    assert "ValueError: step three" in raises.stdout and f"{plugin}:" in raises.stdout
    assert raises.exit_code == 0 and (tmp_path / "r.png").stat().st_size > 0  # 2 steps
    first = sdc_here("replay", out, "--run", "00000-RaisesFirst", "--out", tmp_path / "f.png")
    assert first.exit_code == 1 and "before its first step" in first.stdout
    # `python -m sdc replay OUT --run 00000-Sleepy`: the command as printed, run above
    sleepy = replays[next(c for c in commands if c.endswith(" --run 00000-Sleepy")), False]
    assert sleepy.returncode == 1 and "ran past the run timeout of 2" in sleepy.stdout
