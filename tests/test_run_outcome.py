"""How a run ended (completed | collided | stuck | unfinished), its progress and time lost:
the rules on plain arrays, then each outcome from a real run."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from analysis.measures import run_outcome
from analysis.measures.run_outcome import (
    COLLIDED,
    COMPLETED,
    STUCK,
    UNFINISHED,
    passed_every_obstacle,
    progress_m,
    still_at_end_s,
    time_lost_s,
)
from scenarios import CATALOG_DIR, ScenarioSpec, load_spec
from scenarios.spec.sweep_params import set_path
from sdc.run.episode import run_episode

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "cautious.py"
T = np.arange(0, 10.0, 0.5)


def test_standing_still_is_timed_from_the_first_step_of_the_final_stop():
    speed = np.where(T < 6.0, 5.0, 0.05)  # under 0.1 m/s from t = 6 s
    assert still_at_end_s(T, speed) == pytest.approx(T[-1] - 6.0)
    assert still_at_end_s(T, np.full(len(T), 5.0)) == 0.0
    assert still_at_end_s(T, np.zeros(len(T))) == pytest.approx(T[-1])
    speed[-1] = 0.1  # moving again at its last step (0.1 is not under 0.1)
    assert still_at_end_s(T, speed) == 0.0


@pytest.mark.parametrize("collided, passed, stop_at_s, expected", [
    (True, True, None, COLLIDED),  # a collision wins over everything
    (True, False, 2.0, COLLIDED),
    (False, True, 2.0, COMPLETED),  # passed, then parked: completed
    (False, False, 6.0, STUCK),  # still for the last 3.5 s
    (False, False, 6.5, STUCK),  # still for exactly STUCK_HOLD_S
    (False, False, 7.0, UNFINISHED),  # still for 2.5 s only
    (False, False, None, UNFINISHED),  # moving when it ended
])
def test_one_outcome_per_run(collided, passed, stop_at_s, expected):
    speed = np.full(len(T), 4.0) if stop_at_s is None else np.where(stop_at_s > T, 4.0, 0.0)
    assert run_outcome.run_outcome(collided, passed, T, speed) == expected


def test_passing_means_the_rear_beyond_the_front_of_every_obstacle_ahead_of_the_start():
    s = np.array([10.0, 20.0, 30.0, 40.0, np.nan])  # NaN: off the road's end
    # an obstacle centred at 30 m, 1 m long: its front at 30.5, the ego 5 m long
    assert passed_every_obstacle(s, 5.0, np.array([30.0]), np.array([1.0]))  # 40 >= 33
    assert not passed_every_obstacle(s, 5.0, np.array([38.0]), np.array([1.0]))  # 40 < 41
    # an obstacle behind the start does not count; none at all: passed
    assert passed_every_obstacle(s, 5.0, np.array([5.0, 30.0]), np.array([1.0, 1.0]))
    assert passed_every_obstacle(s, 5.0, np.zeros(0), np.zeros(0))
    assert not passed_every_obstacle(s, 5.0, np.array([30.0, 60.0]), np.array([1.0, 1.0]))


def test_progress_and_time_lost():
    s = np.array([5.0, 8.0, np.nan, 15.0, np.nan])
    assert progress_m(s) == 10.0 and progress_m(s, 0.98) == pytest.approx(9.8)
    assert time_lost_s(4.0, 10.0, 5.0) == 2.0  # 10 m at 5 m/s take 2 s of the 4
    assert time_lost_s(4.0, 10.0, 0.0) is None


@pytest.fixture(scope="module")
def lesson() -> ScenarioSpec:
    return load_spec(CATALOG_DIR / "seed-lesson.toml")


def _with(spec: ScenarioSpec, **values) -> ScenarioSpec:
    plain = spec.to_plain()
    for path, value in values.items():
        set_path(plain, path.replace("__", "."), value)
    return ScenarioSpec.from_plain(plain)


@pytest.mark.slow
def test_real_runs_end_in_each_outcome(lesson):
    seed = run_episode(lesson).row
    assert seed["outcome"] == COMPLETED and seed["termination"] == "route_end"
    assert seed["time_lost_s"] > 0  # the swerve makes the way along the road slower
    lane_keep = run_episode(lesson.with_controller("lane-keep")).row
    assert lane_keep["outcome"] == COLLIDED
    # lane keeping drives at its start speed: no time lost
    assert lane_keep["time_lost_s"] == pytest.approx(0.0, abs=1e-6)
    assert lane_keep["progress_m"] == pytest.approx(
        lesson.ego.speed_mps * lane_keep["sim_time_s"], rel=1e-6)
    braking = run_episode(lesson.with_controller(f"{EXAMPLE}:Cautious")).row
    assert braking["outcome"] == STUCK and braking["collision"] is False
    assert braking["time_lost_s"] > 20  # parked behind the barrel for most of the run
    short = run_episode(_with(lesson, scenario__duration_s=3.0)).row
    assert short["outcome"] == UNFINISHED and short["termination"] == "duration"


@pytest.mark.slow
def test_on_a_curve_progress_is_measured_along_the_egos_lane(lesson):
    plain_curve = _with(lesson.with_controller("lane-keep"), road__kind="curve",
                        road__curve_radius_m=60.0, scenario__duration_s=6.0)
    row = run_episode(plain_curve).row
    # at its start speed along its lane: the distance is speed x time, whatever the curve
    assert row["progress_m"] == pytest.approx(lesson.ego.speed_mps * row["sim_time_s"],
                                              rel=0.01)
    assert abs(row["time_lost_s"]) < 0.06
