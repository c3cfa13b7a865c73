"""Every traffic vehicle is seen, hit and recorded with its own vehicle type's size
and class: a stopped 16.5 m truck is reached at its rear, not 12 m later."""

from __future__ import annotations

import numpy as np
import pytest

from analysis.measures.trace_file import read_trace
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.sumo.sumo_world import SumoWorld
from scenarios.sumo_net.road_source import road_source
from scenarios.world_backends import make_road
from sdc.car.controller_plugins import make_controller
from sdc.run.episode import Simulation
from sdc.run.world_loop import run_alone

TRUCK_LENGTH_M, TRUCK_WIDTH_M = 16.5, 2.55


def truck_ahead(tmp_path, lesson_plain: dict, stop_front_m: float, length_m: float,
                vclass: str = "truck") -> tuple[ScenarioSpec, tuple[str, ...]]:
    """The lesson's straight road, no obstacle of ours, and a SUMO vehicle of its own
    type (``length_m`` long, of ``vclass``) standing in lane 0 with its front bumper at
    ``stop_front_m``: the spec, and the SUMO options that add it."""
    plain = lesson_plain
    plain["obstacles"] = []
    plain["traffic"] = {}
    plain["road"].update(length_m=400.0, speed_limit_mps=33.33)
    plain["ego"].update(lane=0, start_m=20.0, speed_mps=20.0)
    plain["scenario"].update(duration_s=12.0)
    plain["controller"] = {"name": "lane-keep"}
    spec = ScenarioSpec.from_plain(plain)
    add = tmp_path / "standing.add.xml"
    add.write_text(f"""<additional>
  <vType id="big" length="{length_m}" width="{TRUCK_WIDTH_M}" vClass="{vclass}"/>
  <route id="stand" edges="road"/>
  <vehicle id="standing" type="big" route="stand" depart="0" departLane="0"
           departPos="{stop_front_m - length_m:.3f}">
    <stop lane="road_0" endPos="{stop_front_m:.3f}" duration="1000"/>
  </vehicle>
</additional>
""")
    return spec, ("--additional-files", str(add))


def run_into(spec: ScenarioSpec, options: tuple[str, ...]):
    road = make_road(spec)
    controller = make_controller(spec.controller)
    with SumoWorld(spec, road, sumo_options=options, source=road_source(spec.road)) as world:
        sim = Simulation(spec, world, controller=controller)
        termination = run_alone(world, sim)
    return sim.finish(termination, None), road


@pytest.mark.parametrize("length_m, vclass", [(TRUCK_LENGTH_M, "truck"), (4.5, "passenger"),
                                              (2.2, "motorcycle")])
def test_a_standing_vehicle_is_hit_at_its_own_rear(tmp_path, lesson_plain, length_m, vclass):
    """lane-keep at 20 m/s into a vehicle standing 150 m ahead: the collision comes
    within one step of the time at which the ego's front reaches that vehicle's rear
    (a 16.5 m truck 0.6 s before a 4.5 m car), and the row says what it was."""
    spec, options = truck_ahead(tmp_path, lesson_plain, 200.0, length_m, vclass)
    episode, road = run_into(spec, options)
    row = episode.row
    assert row["collision_with"] == "vehicle" and row["collision_vclass"] == vclass
    assert row["collision_part"] == "front"
    ego_front_m = spec.ego.start_m + 4.85 / 2  # the X5's body centre starts at start_m
    expected_s = (200.0 - length_m - ego_front_m) / spec.ego.speed_mps
    assert abs(row["collision_time_s"] - expected_s) <= spec.scenario.step_s + 1e-9
    last = np.asarray(episode.trace.traffic[-1]).reshape(-1, 5)
    assert last[:, 3] == pytest.approx([length_m]) and last[:, 4] == pytest.approx([TRUCK_WIDTH_M])
    assert episode.trace.traffic_class[-1] == [vclass]


def test_the_trace_file_keeps_each_vehicles_class(tmp_path, lesson_plain):
    spec, options = truck_ahead(tmp_path, lesson_plain, 200.0, TRUCK_LENGTH_M)
    episode, road = run_into(spec, options)
    path = tmp_path / "trace.parquet"
    episode.trace.write(path, episode.metadata)
    trace, _ = read_trace(path)
    assert trace.traffic_class == episode.trace.traffic_class
    assert trace.sha256() == episode.row["trace_sha256"]


def test_a_trace_written_before_the_class_column_reads_as_cars(tmp_path, lesson_plain):
    import pyarrow.parquet as pq

    spec, options = truck_ahead(tmp_path, lesson_plain, 200.0, TRUCK_LENGTH_M)
    episode, _ = run_into(spec, options)
    path = tmp_path / "trace.parquet"
    episode.trace.write(path, episode.metadata)
    pq.write_table(pq.read_table(path).drop_columns(["traffic_class"]), path)
    trace, _ = read_trace(path)
    assert [len(c) for c in trace.traffic_class] == [len(t) // 5 for t in trace.traffic]
    assert {c for classes in trace.traffic_class for c in classes} == {"passenger"}


@pytest.mark.parametrize("road", [{"kind": "straight", "lanes": 2},
                                  {"kind": "curve", "lanes": 3, "curve_radius_m": -300.0}])
def test_an_obstacle_of_its_own_size_is_hit_at_its_own_rear(lesson_plain, road):
    """An obstacle given its own ``length_m`` and ``width_m`` (as an OpenSCENARIO
    body's bounding box sets them) is that long to the car, to the checks and to SUMO:
    a 9 m car parked with its centre where a 4.5 m one stood is reached 2.25 m sooner,
    and SUMO's type for it is 9 m long."""
    from scenarios.sumo.routes_xml import _obstacle_types
    from sdc.cli.run import run_one

    plain = lesson_plain
    plain["road"].update(road, length_m=400.0)
    plain["traffic"] = {}
    plain["ego"].update(lane=0, start_m=20.0, speed_mps=15.0)
    plain["scenario"].update(duration_s=15.0)
    plain["controller"] = {"name": "lane-keep"}
    plain["obstacles"] = [{"kind": "car", "lane": 0, "position_m": 150.0}]
    spec = ScenarioSpec.from_plain(plain)
    default = run_one(spec)
    plain["obstacles"][0].update(length_m=9.0, width_m=2.2)
    long = ScenarioSpec.from_plain(plain)
    own = run_one(long)
    assert default["collision"] and own["collision"]
    assert default["collision_time_s"] - own["collision_time_s"] == pytest.approx(
        (9.0 - 4.5) / 2 / 15.0, abs=long.scenario.step_s)
    assert '<vType id="obstacle_car.9x2.2" length="9.0" width="2.2"/>' in [
        line.strip() for line in _obstacle_types([(long, None)])]
    assert not any("x" in line.split('"')[1] for line in _obstacle_types([(spec, None)]))
