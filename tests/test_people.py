"""People on the road: SUMO's persons stay in the world, are bodies the lidar sees and
the ego can hit (``collision_with = "pedestrian"``), count in the world audit, and a
standing person can be the obstacle.

The SUMO tests run real libsumo simulations: SUMO's own scenarios with pedestrian
demand (``tools/game`` of the installed package, read at run time) and a junction with
two crossings built here with netconvert. Contacts are judged independently of the
run's own collision test: libsumo's person getters (not the subscription the run
reads) against the ego's box, with the brute-force overlap of ``tests/test_geometry``.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import math
import subprocess
from pathlib import Path

import numpy as np
import pytest

from analysis.measures.world_audit import world_overlaps
from scenarios.scene.snapshot import Snapshot
from scenarios.spec.bodies import OBSTACLE_SIZES_M, PEDESTRIAN
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.sumo_net.build import sumo_binary
from scenarios.world_backends import make_road, make_world
from sdc.car.collision import OBSTACLE, RAN_INTO, VEHICLE, collision_with, describe
from sdc.car.controller_plugins import make_controller
from sdc.car.geometry import box_edges, ray_segment_ranges
from sdc.car.geometry_kernels import Contacts
from sdc.car.sensors import Lidar
from sdc.run.episode import Simulation, run_episode
from sdc.run.world_loop import WorldLoop
from tests.test_geometry import brute_overlap

PERSON = [0.215, 0.478]  # SUMO's default pedestrian: length, width [m]
#: a person's front farther than this from the ego's centre cannot touch it [m]
NEAR_M = 10.0


def game(name: str) -> str:
    return f"sumo:tools/game/{name}"


def config_spec(lesson_plain: dict, config: str, enter_s: float, *, seed: int = 1,
                controller: str = "lane-keep", route_edges: list[str] | None = None,
                start_m: float = 10.0, duration_s: float = 30.0) -> ScenarioSpec:
    plain = copy.deepcopy(lesson_plain)
    plain["scenario"].update(seed=seed, duration_s=duration_s, step_s=0.1)
    plain["road"] = {"kind": "sumo_config", "config_file": config, "length_m": 300.0,
                     **({"route_edges": route_edges} if route_edges else {})}
    plain["traffic"] = {"enter_s": enter_s}
    plain["obstacles"] = []
    plain["ego"] = {"lane": 0, "start_m": start_m, "speed_mps": 8.0}
    plain["lidar"] = {"beams": 360, "fov_deg": 360.0, "max_range_m": 60.0}
    plain["controller"] = {"name": controller}
    return ScenarioSpec.from_plain(plain)


def persons_on_foot(sumo) -> list[str]:
    return [p for p in sumo.person.getIDList() if not sumo.person.getVehicle(p)]


# ---------------------------------------------------------------- people stay in the world


def sumo_own_person_counts(config: str, times_s: list[float], seed: int, step_s: float
                           ) -> list[int]:
    """Persons in SUMO's own run of its configuration ``config`` (``tools/game``; nothing
    of ours in it) at ``times_s``."""
    import libsumo
    import sumo

    libsumo.start(["sumo", "-c", str(Path(sumo.SUMO_HOME) / "tools" / "game" / config),
                   "--seed", str(seed), "--step-length", repr(step_s),
                   "--no-step-log", "true", "--no-warnings", "true",
                   "--duration-log.disable", "true"])
    counts = []
    try:
        for t_s in times_s:
            while libsumo.simulation.getTime() < t_s - 1e-9:
                libsumo.simulationStep()
            counts.append(len(libsumo.person.getIDList()))
    finally:
        libsumo.close()
    return counts


@pytest.mark.slow
@pytest.mark.parametrize("config, times_s", [
    ("fokr_bs_demo.sumocfg", [54300.0, 54600.0, 54900.0]),  # Braunschweig: people walking
    ("DRT2.sumocfg", [300.0, 600.0, 900.0]),  # a town's people waiting for their rides
])
def test_a_configurations_persons_are_there_when_the_ego_enters(lesson_plain, config,
                                                                times_s):
    import libsumo

    ours = []
    for t_s in times_s:
        spec = config_spec(lesson_plain, game(config), t_s)
        with make_world(spec, make_road(spec, None), None, False, None) as world:
            WorldLoop(world, [Simulation(spec, world)]).start()  # the ego has entered:
            # one step after t_s
            ours.append(len(libsumo.person.getIDList()))
    # on the same clock: what departs at t_s is in after its step
    own = sumo_own_person_counts(config, [t_s + 0.1 for t_s in times_s], seed=1, step_s=0.1)
    assert min(own) > 0, own
    for t_s, n_own, n_ours in zip(times_s, own, ours, strict=True):
        assert abs(n_ours - n_own) <= 0.1 * n_own, (t_s, n_own, n_ours)


# ---------------------------------------------------------------- a person is a body


def crossing_config(folder: Path, people_first: bool = True) -> Path:
    """A junction of a 3.2 m east-west road and a north-south one, with a crossing over
    each east-west arm (``people_first``: pedestrians have the right of way there, else
    the cars), and people walking north-south all the time, nothing else: every
    contact of the ego is with a person."""
    folder.mkdir(parents=True, exist_ok=True)
    first = "true" if people_first else "false"
    (folder / "x.nod.xml").write_text(
        '<nodes><node id="W" x="-250" y="0"/><node id="M" x="0" y="0" type="priority"/>'
        '<node id="E" x="250" y="0"/><node id="N" x="0" y="150"/>'
        '<node id="S" x="0" y="-150"/></nodes>')
    arms = [("W2M", "W", "M", 2), ("M2E", "M", "E", 2), ("E2M", "E", "M", 2),
            ("M2W", "M", "W", 2), ("N2M", "N", "M", 1), ("M2N", "M", "N", 1),
            ("S2M", "S", "M", 1), ("M2S", "M", "S", 1)]
    (folder / "x.edg.xml").write_text("<edges>" + "".join(
        f'<edge id="{e}" from="{a}" to="{b}" numLanes="1" speed="13.9" priority="{p}" '
        'width="3.2" sidewalkWidth="2"/>' for e, a, b, p in arms) + "</edges>")
    (folder / "x.con.xml").write_text(
        f'<connections><crossing node="M" edges="M2E E2M" priority="{first}"/>'
        f'<crossing node="M" edges="W2M M2W" priority="{first}"/></connections>')
    subprocess.run([sumo_binary("netconvert"), "-n", "x.nod.xml", "-e", "x.edg.xml",
                    "-x", "x.con.xml", "-o", "cross.net.xml", "--no-turnarounds", "true",
                    "--walkingareas", "true"], cwd=folder, check=True, capture_output=True)
    (folder / "cross.rou.xml").write_text(
        '<routes><personFlow id="ns" begin="0" end="3600" period="4">'
        '<walk from="N2M" to="M2S"/></personFlow>'
        '<personFlow id="sn" begin="1" end="3600" period="5">'
        '<walk from="S2M" to="M2N"/></personFlow></routes>')
    (folder / "cross.sumocfg").write_text(
        '<configuration><input><net-file value="cross.net.xml"/>'
        '<route-files value="cross.rou.xml"/></input>'
        '<time><begin value="0"/><end value="3600"/></time></configuration>')
    return folder / "cross.sumocfg"


@pytest.fixture(scope="module")
def crossings(tmp_path_factory):
    """:func:`crossing_config` built once per ``people_first`` in this module (the
    tests only read its files): ``crossings(people_first)``."""
    @functools.cache
    def config(people_first: bool = True) -> Path:
        return crossing_config(tmp_path_factory.mktemp("cross") / "cross", people_first)
    return config


def box_of(x_m: float, y_m: float, angle_deg: float, length_m: float, width_m: float):
    """SUMO's front position and angle as our box (centre half a length behind)."""
    yaw = math.radians(90.0 - angle_deg)
    return np.array([x_m - length_m / 2 * math.cos(yaw), y_m - length_m / 2 * math.sin(yaw),
                     yaw, length_m, width_m])


def run_against_the_oracle(spec: ScenarioSpec) -> tuple[dict, int | None, int]:
    """Run ``spec``; the first step at which libsumo's own person getters put a person on
    foot inside the ego's box (None: never), and the run's last step."""
    import libsumo

    controller = make_controller(spec.controller)
    with make_world(spec, make_road(spec, None), None, False, None) as world:
        sim = Simulation(spec, world, controller=controller)
        loop = WorldLoop(world, [sim])
        loop.start()
        first = None
        while loop.going():
            person = libsumo.person
            near = [p for p in persons_on_foot(libsumo)  # the rest cannot touch it
                    if math.dist(person.getPosition(p), sim.box[:2]) < NEAR_M]
            if first is None and any(
                    brute_overlap(sim.box, box_of(*person.getPosition(p), person.getAngle(p),
                                                  person.getLength(p), person.getWidth(p)))
                    for p in near):
                first = sim.k
            loop.step()
        last = sim.k
    return sim.finish(loop.ends[0]).row, first, last


def check_against_the_oracle(row: dict, first: int | None, last: int) -> None:
    if row["collision_with"] == PEDESTRIAN:
        assert first == last, (first, last)
        assert row["collision_vclass"] == PEDESTRIAN
        assert row["collision_part"] in ("front", "side", "rear")
        assert row["collision_role"] in ("ran_into", "was_hit")
    else:
        assert first is None, (row["collision_with"], first, last)


@pytest.mark.slow
def test_every_contact_with_a_person_at_a_crossing_is_a_pedestrian_collision(lesson_plain,
                                                                           crossings):
    config = crossings()
    outcomes = []
    for enter_s in (75.0, 105.0, 135.0):
        for controller in ("lane-keep", "seed"):
            spec = config_spec(lesson_plain, str(config), enter_s, controller=controller,
                               route_edges=["W2M", "M2E"], start_m=150.0)
            row, first, last = run_against_the_oracle(spec)
            check_against_the_oracle(row, first, last)
            outcomes.append(row["collision_with"])
            assert row["world_overlaps"] == 0
    assert PEDESTRIAN in outcomes  # the check was put to the test
    assert set(outcomes) <= {PEDESTRIAN, "none"}  # nothing else to hit there


@pytest.mark.slow
def test_avoid_gives_way_to_people_crossing_where_lane_keep_runs_into_them(lesson_plain,
                                                                         crossings):
    """At 13 m/s through the crossings with people first: the entries at which
    lane-keep hits a person (measured: 6 of 27 entries from 60 to 294 s), and avoid
    hits nobody there, stopping for the people on the crossing."""
    config = crossings()
    for enter_s in (123.0, 258.0, 267.0):
        for controller in ("lane-keep", "avoid"):
            spec = config_spec(lesson_plain, str(config), enter_s, controller=controller,
                               route_edges=["W2M", "M2E"], start_m=100.0)
            spec = dataclasses.replace(spec, ego=dataclasses.replace(spec.ego, speed_mps=13.0))
            row, first, last = run_against_the_oracle(spec)
            check_against_the_oracle(row, first, last)
            if controller == "lane-keep":
                assert row["collision_with"] == PEDESTRIAN, enter_s
            else:
                assert row["collision_with"] == "none" and first is None, enter_s
                assert row["outcome"] == "completed", enter_s


@pytest.mark.slow
def test_people_wait_for_the_ego_where_the_cars_go_first(lesson_plain, crossings):
    """SUMO's pedestrians see the ego pushed in with moveToXY as they see its own cars:
    at a crossing where cars go first they wait for it. The same entries with people
    first put lane-keep into them (the test above)."""
    config = crossings(people_first=False)
    for enter_s in (105.0, 123.0, 150.0, 258.0):
        spec = config_spec(lesson_plain, str(config), enter_s, route_edges=["W2M", "M2E"],
                           start_m=150.0)
        row, first, last = run_against_the_oracle(spec)
        assert first is None and row["collision_with"] == "none", (enter_s, first)
        assert row["outcome"] == "completed"


@pytest.mark.slow
def test_on_a_real_junction_the_people_and_the_collisions_agree(lesson_plain):
    for seed, enter_s in ((1, 54600.0), (2, 55200.0), (3, 54900.0)):
        spec = config_spec(lesson_plain, game("fokr_bs_demo.sumocfg"), enter_s, seed=seed)
        row, first, last = run_against_the_oracle(spec)
        check_against_the_oracle(row, first, last)


@pytest.mark.slow
def test_the_lidar_sees_the_people_of_a_real_junction_as_brute_force_does(lesson_plain):
    spec = config_spec(lesson_plain, game("fokr_bs_demo.sumocfg"), 54600.0)
    controller = make_controller(spec.controller)
    with make_world(spec, make_road(spec, None), None, False, None) as world:
        sim = Simulation(spec, world, controller=controller)
        loop = WorldLoop(world, [sim])
        loop.start()
        while (sim.snapshot.traffic_classes == PEDESTRIAN).sum() < 10 and sim.k < 250:
            loop.step()  # on toward the junction
        snapshot = sim.snapshot
    people = snapshot.traffic_classes == PEDESTRIAN
    assert people.sum() >= 10  # a crowd around the ego
    np.testing.assert_allclose(snapshot.traffic_boxes[people, 3:5],
                               np.tile(PERSON, (people.sum(), 1)))
    lidar = Lidar(dataclasses.replace(spec.lidar, beams=3600), np.zeros((0, 4)),
                  np.random.default_rng(0))
    boxes = np.vstack([snapshot.obstacle_boxes, snapshot.traffic_boxes])
    # from each person's side, 3 m away: every person is seen by someone
    for box in snapshot.traffic_boxes[people]:
        origin = box[:2] + 3.0 * np.array([math.cos(box[2] + 1.0), math.sin(box[2] + 1.0)])
        ranges = lidar.scan(origin, 0.0, boxes, np.zeros((0, 5)))
        brute = ray_segment_ranges(origin, lidar.angles_rad, box_edges(boxes).reshape(-1, 4),
                                   spec.lidar.max_range_m)
        np.testing.assert_array_equal(np.isinf(ranges), np.isinf(brute))
        finite = np.isfinite(brute)
        np.testing.assert_allclose(ranges[finite], brute[finite], rtol=0, atol=5e-5)
        nearest = float(np.min(ranges))
        assert nearest <= 3.0  # the person it looks at, or one nearer still


# ---------------------------------------------------------------- collisions, without SUMO


def snapshot_of(traffic, classes, obstacles=(), speeds=None) -> Snapshot:
    traffic = np.asarray(traffic, float).reshape(-1, 5)
    return Snapshot(0.0, traffic, np.asarray(obstacles, float).reshape(-1, 5),
                    np.zeros(len(traffic)) if speeds is None else np.asarray(speeds, float),
                    np.array(classes, dtype=object))


EGO = np.array([0.0, 0.0, 0.0, 4.85, 1.93])


def test_a_person_touched_is_a_pedestrian_collision_before_anything_else_touched(lesson_plain):
    road = make_road(ScenarioSpec.from_plain(lesson_plain), None)
    car = [2.0, 1.5, 0.0, 4.5, 1.8]  # touches the ego's left side
    person = [2.5, 0.0, math.pi / 2, *PERSON]  # just before its front, walking left
    far_person = [30.0, 0.0, 0.0, *PERSON]
    both = snapshot_of([car, person], ["passenger", PEDESTRIAN], speeds=[5.0, 1.3])
    assert collision_with(EGO, Contacts(-1, 0, math.inf), road, both) == PEDESTRIAN
    hit = describe(PEDESTRIAN, EGO, 6.0, Contacts(-1, 0, math.inf), both, road, 0.0)
    assert hit.vehicle_class == PEDESTRIAN and hit.role == RAN_INTO and hit.part == "front"
    # a person walking into the side of the standing ego hit it
    beside = snapshot_of([[0.0, -1.05, math.pi / 2, *PERSON]], [PEDESTRIAN], speeds=[1.3])
    hit = describe(PEDESTRIAN, EGO, 0.0, Contacts(-1, 0, math.inf), beside, road, 0.0)
    assert (hit.part, hit.role) == ("side", "was_hit")
    only_car = snapshot_of([car, far_person], ["passenger", PEDESTRIAN])
    assert collision_with(EGO, Contacts(-1, 0, math.inf), road, only_car) == VEHICLE
    # a standing person among the obstacles, and a barrel
    standing = snapshot_of([], [], obstacles=[[0.6, 0.0, 0.0, 0.6, 0.6], [2.4, 0.0, 0.0,
                                                                          *PERSON]])
    assert collision_with(EGO, Contacts(0, -1, 0.0), road, standing,
                          (None, PEDESTRIAN)) == PEDESTRIAN
    assert collision_with(EGO, Contacts(0, -1, 0.0), road, standing, (None, None)) == OBSTACLE
    hit = describe(PEDESTRIAN, EGO, 6.0, Contacts(0, -1, 0.0), standing, road, 0.0,
                   (None, PEDESTRIAN))
    assert hit.vehicle_class == PEDESTRIAN and hit.role == RAN_INTO and hit.part == "front"


def test_the_audit_counts_a_vehicle_through_a_person_and_not_people_in_a_crowd():
    person, other_person = [0.0, 0.0, 0.0, *PERSON], [0.05, 0.1, 1.0, *PERSON]
    car, bicycle = [1.0, 0.0, 0.0, 4.5, 1.8], [0.3, 0.0, 0.0, 1.6, 0.65]
    row = lambda *boxes: np.asarray(boxes, float).ravel()  # noqa: E731
    crowd = [row(person, other_person)]
    assert world_overlaps(crowd, np.zeros((0, 5)), [[PEDESTRIAN, PEDESTRIAN]]) == 0
    assert world_overlaps(crowd, np.zeros((0, 5))) == 1  # without classes: two bodies
    through = [row(person, car), row(person, bicycle), row(person)]
    classes = [[PEDESTRIAN, "passenger"], [PEDESTRIAN, "bicycle"], [PEDESTRIAN]]
    assert world_overlaps(through, np.zeros((0, 5)), classes) == 2
    standing = np.array([[0.1, 0.0, 0.0, *PERSON]])
    assert world_overlaps([row(person)], standing, [[PEDESTRIAN]], (PEDESTRIAN,)) == 0
    assert world_overlaps([row(car)], standing, [["passenger"]], (PEDESTRIAN,)) == 1


# ---------------------------------------------------------------- a person as the obstacle


def straight(lesson_plain: dict, kind: str, *, controller: str, speed_mps: float,
             lateral_offset_m: float = 0.0, flow_vph: float = 0.0, lanes: int = 1,
             ego_lane: int = 0, duration_s: float = 30.0) -> ScenarioSpec:
    plain = copy.deepcopy(lesson_plain)
    plain["scenario"].update(duration_s=duration_s)
    plain["road"].update(length_m=400.0, lanes=lanes, lane_width_m=3.2, speed_limit_mps=14.0)
    plain["traffic"] = ({"flow_vph_per_lane": flow_vph, "speed_mean_mps": 12.0,
                         "speed_dev": 0.1} if flow_vph else {})
    plain["obstacles"] = [{"kind": kind, "lane": 0, "position_m": 120.0,
                           "lateral_offset_m": lateral_offset_m}]
    plain["ego"].update(lane=ego_lane, start_m=40.0, speed_mps=speed_mps)
    plain["controller"] = {"name": controller}
    return ScenarioSpec.from_plain(plain)


def assert_hit_a_standing_person(row: dict, part: str = "front") -> None:
    assert row["collision_with"] == PEDESTRIAN
    assert row["collision_vclass"] == PEDESTRIAN
    assert row["collision_role"] == RAN_INTO and row["collision_part"] == part
    assert row["outcome"] == "collided"


@pytest.mark.parametrize("speed_mps", [3.74, 10.0])
def test_lane_keep_hits_a_standing_person_in_its_lane_and_it_is_named_a_pedestrian(
        lesson_plain, speed_mps):
    assert_hit_a_standing_person(run_episode(straight(
        lesson_plain, "pedestrian", controller="lane-keep", speed_mps=speed_mps)).row)


def test_the_lessons_seed_maneuver_passes_a_person_at_its_speed_and_hits_one_faster(
        lesson_plain):
    """The lesson's scenario with its barrel a person: at 3.74 m/s the open-loop swerve
    clears it as it clears the barrel; at 14 m/s the fixed 5 m threshold leaves 0.36 s,
    and the swerving car hits the person with its right side."""
    lesson_plain["obstacles"][0]["kind"] = "pedestrian"
    row = run_episode(ScenarioSpec.from_plain(lesson_plain)).row
    assert row["collision_with"] == "none" and row["outcome"] == "completed"
    lesson_plain["ego"]["speed_mps"] = 14.0
    assert_hit_a_standing_person(run_episode(ScenarioSpec.from_plain(lesson_plain)).row, "side")


def test_a_stopped_bicycle_is_an_obstacle_of_its_size(lesson_plain):
    spec = straight(lesson_plain, "bicycle", controller="lane-keep", speed_mps=10.0)
    assert spec.obstacles[0].size_m == OBSTACLE_SIZES_M["bicycle"] == (1.6, 0.65)
    row = run_episode(spec).row
    assert row["collision_with"] == OBSTACLE and row["outcome"] == "collided"


@pytest.mark.parametrize("kind", ["pedestrian", "bicycle"])
def test_traffic_sees_a_standing_person_or_bicycle_and_does_not_drive_through(lesson_plain,
                                                                             kind):
    """One world: the ego keeps to the other lane; traffic in the person's lane stops
    behind it or changes lanes, and nobody drives through it."""
    spec = straight(lesson_plain, kind, controller="lane-keep", speed_mps=5.0, lanes=2,
                    ego_lane=1, flow_vph=600.0, duration_s=40.0)
    episode = run_episode(spec)
    assert episode.row["world_overlaps"] == 0
    assert episode.row["collision_with"] == "none"
    seen = [len(r) for r in episode.trace.traffic]
    assert max(seen) >= 5 * 3  # traffic came by


# ---------------------------------------------------------------- the verdicts count people


@pytest.fixture(scope="module")
def person_sweep(tmp_path_factory):
    from scenarios import CATALOG_DIR
    from scenarios.spec.sweep_spec import load_sweep
    from sdc.batch.executors.local_executor import LocalExecutor
    from sdc.batch.sweeps.progress import QuietReporter
    from sdc.batch.sweeps.sweep_runner import run_sweep

    root = tmp_path_factory.mktemp("people")
    (root / "sweep.toml").write_text(f"""[sweep]
name = "people"
base = "{CATALOG_DIR / 'seed-lesson.toml'}"
samples = 4
seed = 3
controllers = ["lane-keep", "seed"]

[sweep.params]
"ego.speed_mps" = {{ uniform = [3.0, 4.0] }}
"obstacles[0].kind" = {{ choice = ["pedestrian"] }}
""")
    out = root / "out"
    run_sweep(load_sweep(root / "sweep.toml"), out, LocalExecutor(2), QuietReporter())
    return out


@pytest.mark.slow
def test_the_report_counts_people_first_and_the_gate_holds_them_to_their_bound(person_sweep):
    import json

    from click.testing import CliRunner

    from sdc.cli import main

    result = CliRunner().invoke(main, ["report", str(person_sweep), "--fail-above", "1.0",
                                       "--max-pedestrian-rate", "0.5"])
    assert result.exit_code == 1, result.output
    lines = result.output.splitlines()
    assert lines[-1] == ("gate FAILED: lane-keep: collisions with people up to 100.0%, over "
                         "--max-pedestrian-rate 0.5")
    assert "lane-keep HIT PEOPLE in 4 runs of 4 (100.0%)" in lines
    head = next(line for line in lines if line.startswith("controller") and "people" in line)
    assert head.split()[:6] == ["controller", "ok", "runs", "collisions", "rate", "95%"]
    summary = json.loads((person_sweep / "summary.json").read_text())
    by = summary["by_controller"]
    assert list(by["lane-keep"]["collision_with"].items()) == [("pedestrian", 4)]
    assert list(by["seed"]["collision_with"].items()) == [("pedestrian", 0)]  # it swerved
    assert "hit a pedestrian with its front at" in (person_sweep / "report.md").read_text()
    passed = CliRunner().invoke(main, ["report", str(person_sweep), "--max-pedestrian-rate",
                                       "1.0"])
    assert passed.exit_code == 0 and passed.output.splitlines()[-1] == \
        "gate passed (--max-pedestrian-rate 1)"


# ---------------------------------------------------------------- avoid and the crossings


def test_the_map_gives_the_crossings_a_route_runs_across(lesson_plain, crossings):
    config = crossings()
    spec = config_spec(lesson_plain, str(config), 60.0, route_edges=["W2M", "M2E"],
                       start_m=150.0)
    road = make_road(spec, None)
    walks = road.crosswalks()
    stop_s_m = road.stops()[0].s_m  # the end of W2M: the junction begins
    assert len(walks) == 2
    before, after = walks
    # 4 m wide (netconvert's default), the first just before the junction, the second
    # just after it; each from the right kerb (1.6 m right of the lane's centre, the
    # lane 3.2 m) across both 3.2 m lanes
    for walk in walks:
        assert walk.far_s_m - walk.near_s_m == pytest.approx(4.0, abs=0.01)
        assert walk.right_d_m == pytest.approx(-1.6, abs=0.05)
        assert walk.left_d_m == pytest.approx(4.8, abs=0.05)
    assert before.far_s_m == pytest.approx(stop_s_m + 4.0, abs=0.5) or \
        before.near_s_m == pytest.approx(stop_s_m, abs=0.5)
    assert after.near_s_m > stop_s_m + 5.0
    from sdc.run.crosswalk_ahead import CrosswalkAhead

    ahead = CrosswalkAhead(walks)
    first = ahead.update(before.near_s_m - 10.0)
    assert first.distance_m == pytest.approx(10.0) and first.depth_m == pytest.approx(4.0)
    assert (first.right_m, first.left_m) == pytest.approx((1.6, 4.8), abs=0.05)
    assert ahead.update(before.near_s_m + 1.0).distance_m == pytest.approx(-1.0)  # on it
    assert ahead.update(before.far_s_m + 0.1).distance_m > 0  # the next one
    assert ahead.update(after.far_s_m + 0.1) is None


def avoid_at_a_crosswalk(person_lateral_m: float | None, speed_mps: float = 10.0,
                        seconds: float = 8.0, more=()) -> list:
    """avoid closing the loop toward a crossing 4 m deep whose near side is 40 m ahead
    of its front bumper, reaching 1.75 m right and 8.75 m left of its lane's centre
    (the kerbs of a road of three 3.5 m lanes), a person standing at
    ``person_lateral_m`` across it (None: nobody) and the boxes ``more`` (their x from
    the crossing's near side): its states."""
    from sdc.car.avoid.controller import AvoidController
    from sdc.car.controller_api import Crosswalk
    from sdc.car.vehicle import Vehicle
    from tests.test_avoid import FRONT_AHEAD_M, MODEL, STEP_S, FakeRoad, at_speed

    near_x_m = FRONT_AHEAD_M + 40.0  # from the rear axle's start
    people = ([] if person_lateral_m is None else
              [[near_x_m + 2.0, person_lateral_m, math.pi / 2, *PERSON]])
    road = FakeRoad(people + [[near_x_m + b[0], *b[1:]] for b in more], lanes_left=2,
                    lanes_right=0)
    controller, vehicle = AvoidController({}), Vehicle(MODEL, 0.9)
    state, states = at_speed(speed_mps), []
    for k in range(round(seconds / STEP_S)):
        front_x_m = state.x_m + FRONT_AHEAD_M
        walk = (Crosswalk(near_x_m - front_x_m, 4.0, 1.75, 8.75)
                if front_x_m < near_x_m + 4.0 else None)
        command = controller.step(road.observe(state, k * STEP_S)._replace(crosswalk=walk))
        states.append(state)
        state = vehicle.step(state, command, STEP_S)
    return states


def test_avoid_stops_short_of_a_crosswalk_with_someone_on_it_and_not_for_the_kerb():
    from tests.test_avoid import FRONT_AHEAD_M

    near_x_m = FRONT_AHEAD_M + 40.0
    for lateral_m in (3.0, 7.5, -1.0):  # across the road, on the far side, right of its lane
        states = avoid_at_a_crosswalk(lateral_m)
        front_m = max(s.x_m for s in states) + FRONT_AHEAD_M
        assert near_x_m - 3.0 < front_m < near_x_m, lateral_m  # stopped just short of it
        assert states[-1].speed_mps == 0.0
    for lateral_m in (None, 8.6, -1.6):  # nobody; waiting at either kerb, not on it
        states = avoid_at_a_crosswalk(lateral_m)
        assert max(s.x_m for s in states) + FRONT_AHEAD_M > near_x_m + 20.0, lateral_m
        assert min(s.speed_mps for s in states) == pytest.approx(10.0, abs=0.01), lateral_m
    # a car crossing the crossing in the far lane is no person: it passes behind it
    car = [2.0, 7.0, 0.0, 4.5, 1.8]
    states = avoid_at_a_crosswalk(None, more=[car])
    assert max(s.x_m for s in states) + FRONT_AHEAD_M > near_x_m + 20.0
    # a person beside that car is waited for all the same
    states = avoid_at_a_crosswalk(3.0, more=[car])
    assert max(s.x_m for s in states) + FRONT_AHEAD_M < near_x_m


def test_the_time_to_collision_counts_a_person_in_the_path(lesson_plain):
    """A person standing 20 m ahead of the front bumper, in the ego's path at 10 m/s:
    2 s to collision, as a barrel there; walking out of the path, none."""
    from sdc.car.geometry_kernels import step

    road = make_road(ScenarioSpec.from_plain(lesson_plain), None)
    ego = road.xy_at(20.0, road.lane_center_d_m(0))
    ego_box = np.array([ego[0], ego[1], 0.0, 4.85, 1.93])
    ahead = road.xy_at(20.0 + 4.85 / 2 + 20.0 + PERSON[0] / 2, road.lane_center_d_m(0))
    person = np.array([[ahead[0], ahead[1], math.pi / 2, *PERSON]])
    _, conflicts = step(ego_box, 10.0, np.zeros((0, 5)), person, np.zeros(1), road, 1.0)
    assert conflicts.ttc_s == pytest.approx(2.0, abs=0.02)
    aside = person + np.array([[0.0, 4.0, 0.0, 0.0, 0.0]])  # in the next lane, walking away
    _, conflicts = step(ego_box, 10.0, np.zeros((0, 5)), aside, np.array([1.4]), road, 1.0)
    assert conflicts.ttc_s == math.inf


@pytest.mark.slow
@pytest.mark.parametrize("lanes, width_m", [(1, 3.2), (2, 3.0), (3, 3.5)])
def test_avoid_never_hits_a_standing_person_and_keeps_clear_of_one(lesson_plain, lanes,
                                                                    width_m):
    """On the lesson's road, the barrel a person 80 m ahead at 1 m either side of the
    lane's centre or on it, 3.74 to 14 m/s: avoid stops on a road of one lane and
    passes on two or three, never nearer the person than 0.5 m."""
    for speed_mps in (3.74, 8.0, 14.0):
        for offset_m in (-1.0, 0.0, 1.0):
            plain = copy.deepcopy(lesson_plain)
            plain["obstacles"][0].update(kind="pedestrian", lateral_offset_m=offset_m,
                                         position_m=80.0)
            plain["ego"]["speed_mps"] = speed_mps
            plain["road"].update(lanes=lanes, lane_width_m=width_m)
            plain["controller"] = {"name": "avoid"}
            row = run_episode(ScenarioSpec.from_plain(plain)).row
            assert row["collision_with"] == "none" and row["stop_possible"]
            assert row["outcome"] == ("stuck" if lanes == 1 else "completed")
            assert row["min_gap_obstacle_m"] > 0.5, (speed_mps, offset_m)
