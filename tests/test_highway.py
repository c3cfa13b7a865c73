"""The highway-env backend: the same scenarios, our car, a second simulator."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from scenarios import CATALOG_DIR, load_spec
from scenarios.spec.scenario_spec import ScenarioSpec
from sdc.run.episode import run_episode

pytestmark = pytest.mark.slow

LESSON = CATALOG_DIR / "seed-lesson.toml"


def test_seed_lesson_on_highway_env_seed_avoids_and_lane_keep_collides():
    spec = load_spec(LESSON).with_backend("highway")
    seed = run_episode(spec).row
    assert seed["backend"] == "highway"
    assert not seed["collision"] and seed["returned_to_lane"]
    lane_keep = run_episode(spec.with_controller("lane-keep")).row
    assert lane_keep["collision"] and lane_keep["collision_with"] == "obstacle"


def test_the_lidar_sees_the_same_static_scene_on_both_backends():
    spec = load_spec(LESSON)
    sumo, highway = run_episode(spec), run_episode(spec.with_backend("highway"))
    a, b = np.array(sumo.trace.lidar), np.array(highway.trace.lidar)
    assert a.shape == b.shape
    finite = np.isfinite(a)
    assert np.array_equal(finite, np.isfinite(b))
    assert np.max(np.abs(a[finite] - b[finite])) < 0.01
    # no traffic: nothing of the world differs, so the whole trace is the same
    assert sumo.row["trace_sha256"] == highway.row["trace_sha256"]


def test_highway_traffic_reacts_to_a_stopped_ego(lesson_plain):
    plain = copy.deepcopy(lesson_plain)
    plain["road"].update(length_m=400.0, speed_limit_mps=27.78)
    plain["traffic"] = {"flow_vph_per_lane": 1200.0, "speed_mean_mps": 20.0}
    plain["ego"].update(start_m=150.0, speed_mps=0.0)
    plain["obstacles"] = []
    plain["scenario"].update(duration_s=30.0, backend="highway")
    plain["controller"] = {"name": "lane-keep"}
    episode = run_episode(ScenarioSpec.from_plain(plain))
    # followers queue behind the ego or pass it; none drives through it
    assert episode.row["termination"] == "duration" and not episode.row["collision"]
    boxes = [np.asarray(t).reshape(-1, 5) for t in episode.trace.traffic]
    assert max(len(b) for b in boxes) >= 6
    behind = [b for b in boxes[-1] if b[0] < 150.0 and abs(b[1] + 3.5) < 1.0]
    assert behind and all(b[0] < 150.0 - 4.0 for b in behind)  # queued behind its rear


@pytest.mark.parametrize("radius_m", [200.0, -200.0])
def test_curved_roads_keep_traffic_in_the_spec_lanes(lesson_plain, radius_m):
    from scenarios.world_backends import make_road

    plain = copy.deepcopy(lesson_plain)
    plain["road"].update(kind="curve", curve_radius_m=radius_m, length_m=300.0,
                         speed_limit_mps=27.78)
    plain["traffic"] = {"flow_vph_per_lane": 900.0, "speed_mean_mps": 15.0}
    plain["ego"].update(start_m=100.0, speed_mps=15.0)  # clear of the traffic's entry
    plain["obstacles"] = []
    plain["scenario"].update(duration_s=12.0, backend="highway")
    plain["controller"] = {"name": "lane-keep"}
    spec = ScenarioSpec.from_plain(plain)
    episode = run_episode(spec)
    assert not episode.row["collision"] and episode.row["max_abs_lane_offset_m"] < 0.6
    road = make_road(spec)
    centres = np.array([road.lane_center_d_m(i) for i in range(3)])
    boxes = np.vstack([np.asarray(t).reshape(-1, 5) for t in episode.trace.traffic])
    assert len(boxes) > 100
    _, d = road.to_frenet(boxes[:, :2])
    off_centre = np.min(np.abs(d[:, None] - centres[None, :]), axis=1)
    assert np.mean(off_centre < 0.3) > 0.9  # lane changes aside, on a lane centre


def test_a_sweep_over_both_backends_reports_them_side_by_side(tmp_path):
    from analysis.report.sweep_report import write_report
    from analysis.report.sweep_words import COLLISION_TITLE
    from scenarios.spec.sweep_spec import load_sweep
    from sdc.batch.executors.local_executor import LocalExecutor
    from sdc.batch.sweeps.progress import QuietReporter
    from sdc.batch.sweeps.sweep_runner import run_sweep

    sweep_file = tmp_path / "both.toml"
    sweep_file.write_text(f"""[sweep]
name = "both"
base = "{LESSON}"
sampler = "grid"
controllers = ["seed", "lane-keep"]
[sweep.params]
"scenario.backend" = {{ choice = ["sumo", "highway"] }}
"ego.speed_mps" = {{ choice = [3.74, 9.0] }}
"scenario.duration_s" = {{ choice = [15.0] }}
""")
    run_sweep(load_sweep(sweep_file), tmp_path / "out", LocalExecutor(2), QuietReporter())
    report = write_report(tmp_path / "out")
    by_backend = report.summary["by_backend"]
    assert set(by_backend) == {"sumo", "highway"}
    for backend in by_backend:  # no traffic: the two simulators agree exactly
        assert by_backend[backend]["seed"]["collisions"] == 1  # the 9 m/s run
        assert by_backend[backend]["lane-keep"]["collisions"] == 2
    head = report.terminal.index(COLLISION_TITLE) + 1
    assert report.terminal[head].split()[:2] == ["controller", "backend"]
    assert report.terminal[head + 1].split()[:2] == ["seed", "sumo"]
    assert report.terminal[head + 2].split()[:2] == ["seed", "highway"]
