"""Whole runs in a real libsumo simulation."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from analysis.measures.trace_file import read_trace
from scenarios import CATALOG_DIR, ScenarioSpec, load_spec
from sdc.run.episode import run_episode

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def lesson() -> ScenarioSpec:
    return load_spec(CATALOG_DIR / "seed-lesson.toml")


def test_seed_lesson_seed_avoids_and_returns(lesson):
    row = run_episode(lesson).row
    assert row["maneuver_started"] is True
    assert row["collision"] is False and row["collision_with"] == "none"
    assert row["returned_to_lane"] is True
    assert 3.0 < row["max_abs_lane_offset_m"] < 5.5  # the open-loop swing of ~4.5 m
    assert 4.0 < row["detection_range_m"] < 5.0
    assert row["termination"] == "route_end"


def test_seed_lesson_lane_keep_hits_the_barrel(lesson):
    row = run_episode(lesson.with_controller("lane-keep")).row
    assert row["maneuver_started"] is False
    assert row["collision"] is True and row["collision_with"] == "obstacle"
    assert row["termination"] == "collision"
    # the barrel's near face is at 39.7 m, the ego's front starts at 12.425 m
    assert row["collision_time_s"] == pytest.approx((39.7 - 12.425) / 3.74, abs=0.07)
    # braking alone would have stopped it: 3.74^2 / (2 * 8) = 0.87 m of 27.275 m
    assert row["stop_gap_m"] == pytest.approx(40 - 0.3 - (10 + 2.425), abs=1e-9)
    assert row["stop_possible"] is True


def test_seed_at_25_mps_detects_too_late_and_hits_the_stopped_car(lesson_plain):
    lesson_plain["road"].update(length_m=500.0, speed_limit_mps=33.33)
    lesson_plain["ego"]["speed_mps"] = 25.0
    lesson_plain["obstacles"][0].update(kind="car", position_m=250.0)
    row = run_episode(ScenarioSpec.from_plain(lesson_plain)).row
    assert row["maneuver_started"] is True
    assert row["collision_with"] == "obstacle"
    assert row["stop_gap_m"] == pytest.approx(250 - 2.25 - (10 + 2.425))
    assert row["stop_possible"] is True  # 25^2 / 16 = 39 m of braking


def test_trace_file_holds_every_step_and_what_is_needed_to_draw_it(lesson, tmp_path):
    episode = run_episode(lesson)
    path = tmp_path / "run.parquet"
    episode.write_trace(path)
    trace, metadata = read_trace(path)
    assert len(trace) == episode.row["steps"]
    assert trace.sha256() == episode.row["trace_sha256"]
    assert ScenarioSpec.from_plain(metadata["spec"]) == lesson
    assert metadata["road"]["lanes"] == 3 and len(metadata["road"]["center_xy"]) >= 2
    assert {"lane_keep", "avoid_left", "avoid_straight", "avoid_right"} <= set(trace.phase)
    assert all(len(r) == 180 for r in trace.lidar)
    np.testing.assert_allclose(np.diff(trace.floats["t_s"]), 0.064)
    # the left phase steers left (ISO: positive), the right phase right
    phases = np.array(trace.phase)
    assert np.all(trace.floats["steer_cmd_rad"][phases == "avoid_left"] == 0.7)
    assert np.all(trace.floats["steer_cmd_rad"][phases == "avoid_right"] == -0.7)


def test_same_spec_and_seed_give_the_same_trace_in_two_processes():
    spec_file = str(CATALOG_DIR / "highway-obstacle.toml")
    cmd = [sys.executable, "-m", "sdc", "run", spec_file, "--json", "--controller", "lane-keep"]
    rows = [json.loads(subprocess.run(cmd, capture_output=True, text=True, check=True)
                       .stdout.strip().splitlines()[-1]) for _ in range(2)]
    assert rows[0]["trace_sha256"] == rows[1]["trace_sha256"]
    in_process = run_episode(load_spec(spec_file).with_controller("lane-keep")).row
    assert in_process["trace_sha256"] == rows[0]["trace_sha256"]
    other_seed = run_episode(load_spec(spec_file).with_controller("lane-keep").with_seed(99)).row
    assert other_seed["trace_sha256"] != rows[0]["trace_sha256"]


def test_traffic_reacts_to_the_ego(lesson_plain):
    """On a one-lane road, faster traffic from behind must brake for the slow ego."""
    lesson_plain["road"].update(lanes=1, length_m=600.0, speed_limit_mps=30.0)
    lesson_plain["traffic"] = {"flow_vph_per_lane": 900.0, "speed_mean_mps": 25.0}
    lesson_plain["ego"].update(start_m=60.0, speed_mps=8.0)
    lesson_plain["obstacles"] = []
    lesson_plain["scenario"]["duration_s"] = 40.0
    episode = run_episode(ScenarioSpec.from_plain(lesson_plain).with_controller("lane-keep"))
    assert episode.row["collision"] is False
    trace = episode.trace
    ego_x = trace.floats["x_m"]
    followers = 0
    for k in range(len(trace)):
        boxes = trace.traffic[k].reshape(-1, 5)
        behind = boxes[boxes[:, 0] < ego_x[k]]
        followers = max(followers, len(behind))
        assert np.all(boxes[:, 0] < ego_x[k])  # nobody passes the ego
    assert followers >= 2  # traffic did catch up


def test_lane_keeping_holds_a_curve():
    plain = {
        "scenario": {"name": "curve", "duration_s": 20.0},
        "road": {"kind": "curve", "length_m": 300.0, "lanes": 2, "curve_radius_m": -150.0},
        "ego": {"lane": 1, "start_m": 10.0, "speed_mps": 10.0},
        "controller": {"name": "lane-keep"},
    }
    row = run_episode(ScenarioSpec.from_plain(plain)).row
    assert row["collision"] is False
    assert row["max_abs_lane_offset_m"] < 0.5
