"""Runs on a SUMO network file (road kind ``sumo_net``) in a real libsumo simulation."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from scenarios import CATALOG_DIR, ScenarioSpec, load_spec
from scenarios.world_backends import make_road, make_world
from sdc.run.episode import Simulation, run_episode
from sdc.run.world_loop import WorldLoop

SPEED_MPS = 3.74  # the lesson's


def town(seed: int, vehicles: int = 0, **ego) -> ScenarioSpec:
    plain = load_spec(CATALOG_DIR / "grid-town.toml").to_plain()
    plain["scenario"]["seed"] = seed
    plain["traffic"].update(vehicles=vehicles, warm_up_s=0.0 if vehicles == 0 else 5.0)
    plain["ego"].update(speed_mps=SPEED_MPS, **ego)
    return ScenarioSpec.from_plain(plain)


def straight_seed() -> int:
    """A seed whose route runs straight from the start to 70 m past the obstacle."""
    for seed in range(1, 50):
        spec = town(seed)
        road = make_road(spec)
        s_m = np.linspace(0.0, spec.obstacles[0].position_m + 70.0, 200)
        if np.ptp(road.heading_at(s_m)) < 1e-6:
            return seed
    raise AssertionError("no straight route among 49 seeds")


@pytest.fixture(scope="module")
def seed() -> int:
    return straight_seed()


def test_lane_keep_meets_the_obstacle_on_time(seed):
    spec = town(seed).with_controller("lane-keep")
    row = run_episode(spec).row
    assert row["collision_with"] == "obstacle"
    obstacle, ego_length_m = spec.obstacles[0], 4.85
    gap_m = obstacle.position_m - spec.ego.start_m - (obstacle.size_m[0] + ego_length_m) / 2
    assert row["collision_time_s"] == pytest.approx(gap_m / SPEED_MPS,
                                                    abs=spec.scenario.step_s + 1e-9)


def test_seed_avoids_the_obstacle_in_town_and_returns_to_its_lane(seed):
    row = run_episode(town(seed)).row
    assert row["maneuver_started"] and row["returned_to_lane"]
    assert row["collision_with"] == "none"
    # the ~4.5 m swing crosses the lane to its left and the line between the two
    # directions, which are all road: no road-edge collision
    assert row["max_abs_lane_offset_m"] > 3.2


@pytest.mark.slow
def test_same_seed_same_trace_in_another_process_and_other_seeds_differ(seed):
    spec = town(seed, vehicles=200)
    here = run_episode(spec).row["trace_sha256"]
    code = ("import sys; from scenarios import ScenarioSpec; import json;"
            "from sdc.run.episode import run_episode;"
            "spec = ScenarioSpec.from_plain(json.loads(sys.stdin.read()));"
            "print(run_episode(spec).row['trace_sha256'])")
    there = subprocess.run([sys.executable, "-c", code], input=json.dumps(spec.to_plain()),
                           capture_output=True, text=True, check=True).stdout.strip()
    assert there == here
    assert run_episode(town(seed + 1, vehicles=200)).row["trace_sha256"] != here


@pytest.mark.slow
def test_random_trips_fill_the_network(seed):
    spec = town(seed, vehicles=400)
    # network_vehicles is counted as the traffic enters, one step after the ego
    # (sdc/run/episode.py, Simulation.arrive): a 1 s run counts it as a 30 s one does
    spec = dataclasses.replace(spec, scenario=dataclasses.replace(spec.scenario,
                                                                  duration_s=1.0))
    row = run_episode(spec).row
    # a few may be taken off where the ego enters, none are lost otherwise
    assert 390 <= row["network_vehicles"] <= 400


@pytest.mark.slow
def test_every_car_that_arrives_starts_a_new_trip(seed):
    """The network keeps its traffic.vehicles cars: without new trips, the grid
    loses more than 5% of 400 in two minutes."""
    spec = town(seed, vehicles=400)
    with make_world(spec, make_road(spec)) as world:
        sim = Simulation(spec, world, 5.0)
        WorldLoop(world, [sim]).start()
        counts = []
        for _ in range(1200):  # 2 minutes, the ego standing
            world.step(sim.box, 0.0)
            counts.append(world.vehicle_count())
        arrived = world._demand.made - 400
    assert arrived > 20  # cars did arrive, and
    assert min(counts) >= 390 and max(counts) <= 400  # were replaced


#: the catalog's grid-town with a 10 s warm-up (its own is minutes of SUMO)
QUICK_TOWN = Path(__file__).parent / "data" / "grid-town-quick.toml"


@pytest.mark.slow
def test_a_2000_vehicle_town_runs_end_to_end_in_a_sweep(tmp_path):
    out = tmp_path / "town"
    sweep = tmp_path / "grid-town.toml"  # the catalog's sweep on the quick-warm-up town
    sweep.write_text((CATALOG_DIR / "sweeps" / "grid-town.toml").read_text().replace(
        'base = "../grid-town.toml"', f'base = "{QUICK_TOWN}"'))
    proc = subprocess.run(
        [sys.executable, "-m", "sdc", "sweep", str(sweep), "--out", str(out), "--samples", "1",
         "--workers", "2", "--quiet"], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    results = pd.read_parquet(out / "results.parquet")
    assert list(results.status) == ["ok", "ok"]
    assert (results.network_vehicles >= 1900).all()
    assert results.steps.min() > 50
    report = subprocess.run([sys.executable, "-m", "sdc", "report", str(out)],
                            capture_output=True, text=True, timeout=300)
    assert report.returncode == 0, report.stderr
    assert (out / "report.html").stat().st_size > 10_000


@pytest.mark.slow
def test_a_network_converted_from_openstreetmap_runs(tmp_path):
    """netconvert a small hand-written OpenStreetMap town (a curved four-lane
    primary road, a residential street, a one-way) and run in it."""
    from scenarios.sumo_net.build import sumo_binary

    osm = Path(__file__).parent / "data" / "osm-town.osm"
    net = tmp_path / "osm-town.net.xml"
    subprocess.run([sumo_binary("netconvert"), "--osm-files", str(osm), "-o", str(net),
                    "--geometry.remove", "--junctions.join", "--no-turnarounds"],
                   capture_output=True, check=True, timeout=120)
    plain = town(1, vehicles=40).to_plain()
    plain["road"].update(net_file=str(net), length_m=200.0, route_turns="any")
    plain["obstacles"][0]["position_m"] = 60.0
    for seed in range(1, 5):
        plain["scenario"]["seed"] = seed
        spec = ScenarioSpec.from_plain(plain)
        road = make_road(spec)
        assert road.area.contains(road.center_xy).all()  # the route runs on the road
        row = run_episode(spec).row
        assert row["status"] == "ok" and row["network_vehicles"] >= 35
        assert row["maneuver_started"]  # it met the barrel
