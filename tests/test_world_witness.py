"""Whose overlap is it: SUMO's own bodies, laid along their lanes, against the world
audit; and SUMO without the ego as the oracle of what is SUMO's own."""

from __future__ import annotations

import dataclasses
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from analysis.measures.world_audit import overlap_steps, pairs_overlap
from scenarios import CATALOG_DIR
from scenarios.scene.lane_bodies import BODY_PIECES, LanePath
from scenarios.spec.bodies import VEHICLE_MODELS
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.spec.toml_io import read_toml
from scenarios.sumo_net.build import input_path
from scenarios.world_backends import make_road, make_shared_world, make_world
from sdc.car.vehicle import Vehicle
from sdc.run.episode import run_episode
from sdc.run.shared_world import Seats, run_world
from sdc.run.world_witness import Judged, witness_overlaps, witness_world

REPO = Path(__file__).resolve().parent.parent


def along_lane(shape_xy, lane_length_m, front_pos_m, lateral_m, length_m, width_m,
               pieces=BODY_PIECES, behind_xy=None) -> np.ndarray:
    """A body laid as the witness lays it, in ``pieces`` boxes, along one lane (and
    ``behind_xy``, the lanes before it, as long as drawn)."""
    lanes = [(shape_xy, lane_length_m)]
    if behind_xy is not None:
        lanes.insert(0, (behind_xy, float(np.hypot(*np.diff(behind_xy, axis=0).T).sum())))
    return np.array(LanePath(lanes).body(front_pos_m, lateral_m, length_m, width_m, pieces))


def test_a_body_on_a_straight_lane_is_its_rigid_box():
    lane = np.array([[0.0, 0.0], [100.0, 0.0]])
    boxes = along_lane(lane, 100.0, 50.0, 0.4, 12.0, 2.5, pieces=4)
    np.testing.assert_allclose(boxes[:, 0], [39.5, 42.5, 45.5, 48.5])
    np.testing.assert_allclose(boxes[:, 1:], [[0.4, 0.0, 3.0, 2.5]] * 4)


def test_a_body_laid_along_a_curve_follows_the_arc_and_sumos_length():
    radius_m = 15.0
    theta = np.linspace(0.0, math.pi / 2, 200)
    arc = np.column_stack([radius_m * np.sin(theta), radius_m * (1 - np.cos(theta))])
    shape_m = float(np.hypot(*np.diff(arc, axis=0).T).sum())
    # SUMO's lane is 2% longer than its shape: positions scale onto the shape
    boxes = along_lane(arc, shape_m * 1.02, 0.8 * shape_m * 1.02, 0.0, 16.0, 2.5)
    centre = np.array([0.0, radius_m])
    ends = np.vstack([boxes[:, :2] - boxes[:, 3:4] / 2 * np.column_stack(
        [np.cos(boxes[:, 2]), np.sin(boxes[:, 2])]), boxes[-1:, :2] + boxes[-1, 3] / 2 * np.array(
        [[math.cos(boxes[-1, 2]), math.sin(boxes[-1, 2])]])])
    np.testing.assert_allclose(np.hypot(*(ends - centre).T), radius_m, atol=1e-3)
    assert np.all(np.diff(boxes[:, 2]) > 0)  # turning left, piece by piece
    # a rigid 16 m box along the chord would stand 2.1 m inside the arc at its middle
    assert radius_m - np.hypot(*(boxes[:, :2] - centre).T).min() < 0.6


INGOLSTADT = "sumo:tools/game/fkk_in.sumocfg"


def ingolstadt_spec(enter_s: float, speed_mps: float) -> ScenarioSpec:
    plain = read_toml(CATALOG_DIR / "real-traffic.toml")
    plain["road"]["config_file"] = INGOLSTADT
    plain["traffic"]["enter_s"] = enter_s
    plain["ego"]["speed_mps"] = speed_mps
    return ScenarioSpec.from_plain(plain)


def bare_sumo_boxes(spec: ScenarioSpec, times_s: list[float], ids: set[str]) -> dict:
    """SUMO alone on the spec's configuration (no ego, no obstacle: its own demand,
    our options): the rigid boxes SUMO's position, angle and size give ``ids`` at each
    of ``times_s``."""
    import libsumo

    from scenarios.scene import traffic_model
    libsumo.start(["sumo", "-c", str(input_path(spec.road.config_file)),
                   "--step-length", repr(spec.scenario.step_s), "--seed",
                   str(spec.scenario.seed), "--collision.action", "none",
                   "--time-to-teleport", "-1",
                   *traffic_model.sumo_options(spec.traffic.lane_change_s),
                   "--no-step-log", "true", "--no-warnings", "true"])
    found = {}
    try:
        for t_s in sorted(set(times_s)):
            while libsumo.simulation.getTime() < t_s - 1e-6:
                libsumo.simulationStep()
            present = set(libsumo.vehicle.getIDList())
            for vid in ids & present:
                x, y = libsumo.vehicle.getPosition(vid)
                yaw = math.radians(90.0 - libsumo.vehicle.getAngle(vid))
                length_m = libsumo.vehicle.getLength(vid)
                found[t_s, vid] = np.array([x - length_m / 2 * math.cos(yaw),
                                            y - length_m / 2 * math.sin(yaw), yaw, length_m,
                                            libsumo.vehicle.getWidth(vid)])
    finally:
        libsumo.close()
    return found


@pytest.mark.slow
@pytest.mark.parametrize(("enter_s", "speed_mps"), [(123.061257, 11.134009),
                                                   (142.963198, 11.798109)])
def test_sumos_own_overlaps_on_ingolstadt_are_there_without_the_ego_too(enter_s, speed_mps):
    """Two of SUMO's bicycles wait inside each other on Ingolstadt's junction, 60-145 m
    from the ego: the run counts them as SUMO's (``sumo_overlaps``), none as ours, and
    SUMO alone, without the ego, holds the same two inside each other at the same
    times."""
    spec = ingolstadt_spec(enter_s, speed_mps)
    episode = run_episode(spec)
    row = episode.row
    assert row["world_overlaps"] == 0 and row["sumo_overlaps"] > 0, row
    steps = overlap_steps(episode.trace.traffic, np.zeros((0, 5)), episode.trace.traffic_class,
                          traffic_bodies=episode.trace.traffic_body)
    vehicle = Vehicle(VEHICLE_MODELS[spec.vehicle.model], spec.vehicle.friction_mu)
    witnessed = witness_overlaps(make_world(spec, make_road(spec)), episode.trace, vehicle,
                                 steps, ())
    assert {w.step for w in witnessed} == set(steps.tolist())  # every step judged
    assert all(w.sumo_holds_both for w in witnessed)
    sample = witnessed[:: max(1, len(witnessed) // 25)]
    alone = bare_sumo_boxes(spec, [w.sumo_time_s for w in sample],
                            {v for w in sample for v in (w.first, w.second)})
    for w in sample:
        a, b = alone[w.sumo_time_s, w.first], alone[w.sumo_time_s, w.second]
        assert pairs_overlap(a[None], b[None])[0], w


@pytest.mark.slow
def test_a_shared_worlds_runs_are_judged_as_one_replay_of_the_world_judges_them():
    """The same Ingolstadt run shares its world with a second ego placed apart (another
    route): each run's overlaps, judged in the run, are those one replay of the whole
    world judges, every step of both judged; the bicycles waiting inside each other
    count as SUMO's for the first run, none as ours, and SUMO alone (no ego) holds the
    same two inside each other at those times."""
    first = ingolstadt_spec(123.061257, 11.134009)
    first = dataclasses.replace(first, traffic=dataclasses.replace(first.traffic, warm_seed=1))
    second = first.with_seed(2)
    egos = [(spec, make_road(spec)) for spec in (first, second)]
    assert Seats(egos, 2).entering([0, 1], {}, 0) == [0, 1]  # together from the start
    outcomes = run_world(egos, ["first", "second"])
    rows = [outcome.row for outcome in outcomes]
    assert [row["world_egos"] for row in rows] == [2, 2]
    assert rows[0]["world_overlaps"] == 0 and rows[0]["sumo_overlaps"] > 0, rows[0]
    assert rows[1]["world_overlaps"] == 0, rows[1]
    vehicle = Vehicle(VEHICLE_MODELS[first.vehicle.model], first.vehicle.friction_mu)
    judged = [Judged(outcome.trace, vehicle,
                     overlap_steps(outcome.trace.traffic, np.zeros((0, 5)),
                                   outcome.trace.traffic_class,
                                   traffic_bodies=outcome.trace.traffic_body), ())
              for outcome in outcomes]
    witnessed = witness_world(make_shared_world(egos, None, None), judged)
    for run, seen, row in zip(judged, witnessed, rows, strict=True):
        assert {w.step for w in seen} == set(run.steps.tolist())  # every step judged
        assert len({w.step for w in seen if w.sumo_holds_both}) == row["sumo_overlaps"]
    sample = witnessed[0][:: max(1, len(witnessed[0]) // 25)]
    alone = bare_sumo_boxes(first, [w.sumo_time_s for w in sample],
                            {v for w in sample for v in (w.first, w.second)})
    for w in sample:
        a, b = alone[w.sumo_time_s, w.first], alone[w.sumo_time_s, w.second]
        assert pairs_overlap(a[None], b[None])[0], w


@pytest.mark.slow
@pytest.mark.parametrize("family, samples, seats", [("ingolstadt", 3, 2), ("people", 2, 1)])
def test_the_audit_in_the_run_judges_every_pair_as_the_replay_does(family, samples, seats):
    """The in-run audit and the replay it replaced (benchmarks/audit_in_run.py): runs
    alone and the same runs in one world of fewer seats, some entering as a seat frees
    (their obstacles with them: on fokr_bs_demo SUMO's insertion checks would hold one
    back), SUMO's bicycles waiting inside each other in Ingolstadt and its people in
    fokr_bs_demo among their overlaps. Every overlapping step of every trace is judged
    in the run, pair by pair as the replay judges it."""
    done = subprocess.run([sys.executable, str(REPO / "benchmarks" / "audit_in_run.py"),
                           "--samples", str(samples), "--seats", str(seats), "--per-world",
                           str(samples), "--families", family],
                          capture_output=True, text=True, check=False, cwd=REPO)
    assert done.returncode == 0, done.stderr[-3000:]
    (line,) = done.stdout.splitlines()  # no difference was printed
    figures = dict(zip(line.split()[1::2], line.split()[2::2], strict=True))
    assert figures["runs"] == str(2 * samples), line
    assert figures["worlds"] == str(samples + 1), line  # alone, then all in one
    assert int(figures["entered_later"]) >= 1, line
    assert int(figures["overlapped"]) >= 3 and int(figures["steps_judged"]) > 100, line
    assert figures["steps_differing"] == "0", line


def test_a_body_reaching_back_off_its_lane_lies_along_the_lanes_before_it():
    # a 16 m truck 6 m into a lane heading +y, its back on the junction's quarter turn
    # (radius 10 m, from +x) and the lane before it: as SUMO holds it, bent round
    theta = np.linspace(0.0, math.pi / 2, 50)
    turn = np.column_stack([10.0 * np.sin(theta), 10.0 * (1 - np.cos(theta))])
    before = np.vstack([[[-30.0, 0.0]], turn])
    lane = np.array([[10.0, 10.0], [10.0, 60.0]])
    boxes = along_lane(lane, 50.0, 6.0, 0.0, 16.0, 2.5, pieces=4, behind_xy=before)
    front = boxes[-1, :2] + boxes[-1, 3] / 2 * np.array([math.cos(boxes[-1, 2]),
                                                          math.sin(boxes[-1, 2])])
    np.testing.assert_allclose(front, [10.0, 16.0], atol=1e-9)
    assert boxes[-1, 2] == pytest.approx(math.pi / 2)  # its cab along its lane
    assert boxes[0, 2] < math.pi / 4  # its tail still turning in
    alone = along_lane(lane, 50.0, 6.0, 0.0, 16.0, 2.5, pieces=4)
    assert np.allclose(alone[:, 2], math.pi / 2)  # without them: straight back
