"""An OpenDRIVE road (``road.kind = "opendrive"``): converted by netconvert, held to
the file's own reference line and lane widths, its lane ids mapped to SUMO's lanes
(checked against SUMO's own positions), and run like any network road."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

from scenarios.asam.xodr_places import XodrMap
from scenarios.asam.xodr_roads import read_xodr
from scenarios.common.errors import SpecError
from scenarios.common.file_read import file_sha256
from scenarios.scene.polyline_frame import PolylineFrame
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.spec.toml_io import load_spec
from scenarios.sumo_net.net_xml import read_net
from scenarios.sumo_net.opendrive_net import opendrive_network
from scenarios.sumo_net.road_source import road_source
from tests.asam_samples import write_arc_road


def _dense(polyline: np.ndarray, step_m: float = 0.01) -> np.ndarray:
    pieces = [np.linspace(a, b, max(2, int(np.hypot(*(b - a)) / step_m) + 1))
              for a, b in zip(polyline[:-1], polyline[1:], strict=True)]
    return np.vstack(pieces)


def _sumo_off_the_file_m(world: XodrMap, lane, trim_m: float = 2.0) -> float:
    """How far SUMO's lane strays from the centre the file's reference line and lane
    widths give its OpenDRIVE lane: its shape every 0.1 m (``trim_m`` left out at each
    end, where junctions shape it), to the file's lane centre line drawn through a
    point every 0.2 m (its chords stray under 1 mm from a curve of 5 m radius) [m]."""
    road_id, lane_id = world._original[lane.id]
    road = world.roads[road_id]
    s_m = [s for s in np.arange(0.0, road.length_m + 0.2, 0.2)
           if lane_id in road.section_at(min(s, road.length_m)).lanes]
    file_line = PolylineFrame([road.lane_point(lane_id, min(s, road.length_m))[:2]
                               for s in s_m], min_segment_m=1e-9)
    dense = _dense(lane.shape_xy, 0.1)
    along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(dense, axis=0).T))])
    inner = dense[(along > trim_m) & (along < along[-1] - trim_m)]
    return float(np.abs(file_line.project(inner)[1]).max()) if len(inner) else 0.0


@pytest.mark.parametrize("network", ["cross/cross.net.xml", "grid6/grid6.net.xml",
                                     "fokr_bs_demo/fokr_bs.net.xml.gz"])
def test_maps_nobody_here_wrote_lie_where_their_files_put_them(tmp_path, network):
    """SUMO's own shipped networks (a signalised crossing, a grid, Braunschweig's
    centre) written as OpenDRIVE by netconvert (lines, arcs and paramPoly3 curves,
    many roads, lane sections, junctions), then read back both ways: every driving
    lane SUMO imports carries its OpenDRIVE name, and lies within 5 cm of where the
    file's own geometry puts that lane."""
    import sumo

    xodr_file = tmp_path / "map.xodr"
    subprocess.run([str(Path(sumo.SUMO_HOME) / "bin" / "netconvert"), "--sumo-net-file",
                    str(Path(sumo.SUMO_HOME) / "tools" / "game" / network),
                    "--opendrive-output", str(xodr_file), "--no-warnings"],
                   capture_output=True, check=True)
    world = XodrMap(xodr_file, tmp_path)
    lanes = world.net.normal_lanes()
    assert len(lanes) > 20 and all(lane.id in world._original for lane in lanes)
    assert max(_sumo_off_the_file_m(world, lane) for lane in lanes) < 0.05


@pytest.mark.parametrize(("width_m", "radius_m", "spiral_m"),
                         [(2.8, 15.0, 20.0), (3.2, 80.0, 0.0), (3.5, 40.0, 30.0)])
def test_lanes_lie_where_the_file_puts_them(tmp_path, width_m, radius_m, spiral_m):
    """Every SUMO lane runs within 3 cm of the centre the file's reference line and
    lane widths give its OpenDRIVE lane (both ways: SUMO's points to the file's curve,
    the file's curve to SUMO's polyline), as wide as the file says."""
    xodr_file = write_arc_road(tmp_path / "road.xodr", width_m, radius_m, spiral_m=spiral_m,
                               turn_rad=math.pi / 3)
    road = read_xodr(xodr_file)["1"]
    world = XodrMap(xodr_file, tmp_path)
    checked = set()
    for lane in world.net.normal_lanes():
        road_id, lane_id = world._original[lane.id]
        checked.add(lane_id)
        s_m = np.arange(1.0, road.length_m - 1.0, 0.05)  # the junction ends left out
        file_xy = np.array([road.lane_point(lane_id, s)[:2] for s in s_m])
        assert cKDTree(_dense(file_xy)).query(lane.shape_xy[1:-1])[0].max() < 0.03
        assert cKDTree(_dense(lane.shape_xy)).query(file_xy)[0].max() < 0.03
        assert lane.width_m == pytest.approx(width_m)
    assert checked == {-2, -1, 1, 2}


def test_road_edges_where_the_outer_lanes_end(tmp_path):
    """The drivable area ends at the outer lanes' borders, 2 lane widths each side of
    the reference line: a point 0.15 m inside is on the road, 0.15 m outside is off."""
    width_m = 3.0
    xodr_file = write_arc_road(tmp_path / "road.xodr", width_m, 60.0)
    road = read_xodr(xodr_file)["1"]
    spec = _spec(xodr_file, 200.0)
    geometry = road_source(spec.road).geometry(spec, tmp_path)
    for s_m in (30.0, 100.0 + 60.0 * math.pi / 4, 250.0):
        for side in (1, -1):
            inside = road.point(s_m, side * (2 * width_m - 0.15))[:2]
            outside = road.point(s_m, side * (2 * width_m + 0.15))[:2]
            assert not geometry.off_road(np.array([inside]))[0]
            assert geometry.off_road(np.array([outside]))[0]


def test_lane_ids_map_to_sumo_lanes_by_sumos_own_positions(tmp_path):
    """OpenDRIVE's lane -1 is the right lane next to the reference line, SUMO's lane 0
    the outermost right one: on a road with two right lanes, -1 is SUMO's index 1 and
    -2 index 0. Where SUMO itself (libsumo's convert2D, in a process of its own) puts
    each mapped lane position is where the file puts the OpenDRIVE one."""
    xodr_file = write_arc_road(tmp_path / "road.xodr", 3.2, 50.0)
    road = read_xodr(xodr_file)["1"]
    world = XodrMap(xodr_file, tmp_path)
    cases = [(lane_id, s_m) for lane_id in (-2, -1, 1, 2) for s_m in (20.0, 130.0, 230.0)]
    places = [world.lane_place("1", lane_id, s_m, 0.0, "here") for lane_id, s_m in cases]
    mapped = {(lane_id, p.lane.edge, p.lane.index)
              for (lane_id, _), p in zip(cases, places, strict=True)}
    assert mapped == {(-1, "-1", 1), (-2, "-1", 0), (1, "1", 1), (2, "1", 0)}
    code = ("import json, sys, libsumo\n"
            "libsumo.start(['sumo', '--net-file', sys.argv[1], '--no-step-log', 'true'])\n"
            "print(json.dumps([libsumo.simulation.convert2D(e, p, i) for e, p, i in "
            "json.loads(sys.argv[2])]))\nlibsumo.close()\n")
    asked = [(p.lane.edge, p.sumo_pos_m, p.lane.index) for p in places]
    out = subprocess.run([sys.executable, "-c", code, str(world.net_path), json.dumps(asked)],
                         capture_output=True, text=True, check=True).stdout
    sumo_xy = np.array(json.loads(out.strip().splitlines()[-1]))
    file_xy = np.array([road.lane_point(lane_id, s_m)[:2] for lane_id, s_m in cases])
    assert np.hypot(*(sumo_xy - file_xy).T).max() < 0.05


def test_a_lane_position_offset_and_a_world_position(tmp_path):
    xodr_file = write_arc_road(tmp_path / "road.xodr", 3.5, 80.0)
    road = read_xodr(xodr_file)["1"]
    world = XodrMap(xodr_file, tmp_path)
    place = world.lane_place("1", -2, 50.0, 0.4, "here")
    assert place.lateral_m == pytest.approx(0.4, abs=0.01)
    x_m, y_m, heading = road.lane_point(-1, 150.0)
    there = world.world_place(x_m, y_m, heading, "here")
    assert (there.lane.edge, there.lane.index) == ("-1", 1)
    with pytest.raises(SpecError, match="drives the other way from the heading"):
        world.world_place(x_m, y_m, heading + math.pi, "here")  # against its traffic
    x_m, y_m, heading = road.lane_point(1, 150.0)
    back = world.world_place(x_m, y_m, heading + math.pi, "here")  # the left lanes' way
    assert (back.lane.edge, back.lane.index) == ("1", 1)
    with pytest.raises(SpecError, match="lane -3"):
        world.lane_place("1", -3, 50.0, 0.0, "here")
    with pytest.raises(SpecError, match="road '7' is not in"):
        world.lane_place("7", -1, 50.0, 0.0, "here")


def _spec(xodr_file, length_m: float, lane: int | None = None, **extra) -> ScenarioSpec:
    road = {"kind": "opendrive", "xodr_file": str(xodr_file), "length_m": length_m,
            "route_edges": ["-1"]} | ({} if lane is None else {"route_lane": lane})
    return ScenarioSpec.from_plain({"scenario": {"name": "od", "duration_s": 20.0},
                                    "road": road, "ego": {"lane": 0, "start_m": 10.0,
                                                          "speed_mps": 12.0}} | extra)


def test_conversion_is_cached_and_the_same_bytes_in_every_process(tmp_path):
    xodr_file = write_arc_road(tmp_path / "road.xodr")
    first = opendrive_network(str(xodr_file), tmp_path / "a")
    again = opendrive_network(str(xodr_file), tmp_path / "a")
    other = opendrive_network(str(xodr_file), tmp_path / "b")
    assert first == again and first.read_bytes() == other.read_bytes()
    assert b"generated on" not in first.read_bytes()
    assert read_net(first).normal_lanes()


def test_preparing_a_sweep_converts_the_road_once_into_its_cache(tmp_path):
    """What a sweep prepares (the network and its road edges) lands in the cache it
    names, and what it then ships is that conversion: netconvert runs once."""
    write_arc_road(tmp_path / "road.xodr")
    source = road_source(_spec(tmp_path / "road.xodr", 200.0).road)
    cache = tmp_path / "cache"
    source.prepare(cache)
    converted = list(cache.glob("*.xodr.net.xml"))
    assert len(converted) == 1
    modified_ns = converted[0].stat().st_mtime_ns
    assert source.network_file(cache) == converted[0]
    assert source.shipped(cache).edges_key == file_sha256(converted[0])
    assert converted[0].stat().st_mtime_ns == modified_ns  # not converted again


def test_bad_opendrive_input_names_the_field(tmp_path):
    with pytest.raises(SpecError, match="road.xodr_file.*no such file"):
        opendrive_network(str(tmp_path / "missing.xodr"))
    broken = tmp_path / "broken.xodr"
    broken.write_text("<OpenDRIVE><road id='1' length='x'/></OpenDRIVE>")
    with pytest.raises(SpecError, match="road.xodr_file"):
        opendrive_network(str(broken), tmp_path)
    with pytest.raises(SpecError, match="road.route_lane.*road.route_edges"):
        ScenarioSpec.from_plain({"scenario": {"name": "x", "duration_s": 5.0}, "road": {
            "kind": "opendrive", "xodr_file": "a.xodr", "length_m": 50.0, "route_lane": 1},
            "ego": {"lane": 0, "start_m": 10.0, "speed_mps": 5.0}})
    with pytest.raises(SpecError, match="road.xodr_file.*only applies"):
        ScenarioSpec.from_plain({"scenario": {"name": "x", "duration_s": 5.0}, "road": {
            "lanes": 2, "length_m": 50.0, "xodr_file": "a.xodr"},
            "ego": {"lane": 0, "start_m": 10.0, "speed_mps": 5.0}})


def test_route_lane_chooses_the_start_lane(tmp_path):
    xodr_file = write_arc_road(tmp_path / "road.xodr")
    for lane in (0, 1):
        spec = _spec(xodr_file, 200.0, lane)
        geometry = road_source(spec.road).geometry(spec, tmp_path)
        assert geometry.sumo_place(20.0)[1] == lane
    with pytest.raises(SpecError, match="road.route_lane.*lanes that do: 0, 1"):
        spec = _spec(xodr_file, 200.0, 3)
        road_source(spec.road).geometry(spec, tmp_path)


@pytest.mark.parametrize("width_m", [2.8, 3.5])
def test_lane_keep_hits_the_parked_car_and_avoid_passes_it(tmp_path, width_m):
    """From a TOML scenario on a .xodr road (straight, arc, straight; two lanes each
    way): lane-keep runs into a car parked in its lane at the time the gap and its
    speed give; avoid, in the outer right lane (SUMO's 0, OpenDRIVE's -2), goes round
    it through the lane beside without a collision."""
    from sdc.cli.run import run_one

    write_arc_road(tmp_path / "road.xodr", width_m, 80.0)
    (tmp_path / "od.toml").write_text(
        '[scenario]\nname = "od"\nduration_s = 25.0\n'
        '[road]\nkind = "opendrive"\nxodr_file = "road.xodr"\nlength_m = 300.0\n'
        'route_edges = ["-1"]\nroute_lane = 0\n'
        '[ego]\nlane = 0\nstart_m = 10.0\nspeed_mps = 12.0\n'
        '[[obstacles]]\nkind = "car"\nlane = 0\nposition_m = 150.0\n')
    spec = load_spec(tmp_path / "od.toml")
    assert spec.road.xodr_file == str(tmp_path / "road.xodr")
    lane_keep = run_one(spec.with_controller("lane-keep"))
    gap_m = 150.0 - 10.0 - (4.5 + 4.92) / 2  # the parked car's and the X5's half lengths
    assert lane_keep["collision"] and lane_keep["collision_with"] == "obstacle"
    assert lane_keep["collision_time_s"] == pytest.approx(gap_m / 12.0, abs=0.15)
    avoid = run_one(spec.with_controller("avoid"))
    assert avoid["status"] == "ok" and not avoid["collision"], avoid
    assert avoid["maneuver_started"]


@pytest.mark.slow
def test_a_town_sweep_on_an_opendrive_road(tmp_path):
    """Like any network road: routes drawn from the seed, random trips, warm states
    and shared worlds; every run ok, two egos in a world, and a shared world's run
    replays to its trace bit for bit."""
    import pandas as pd
    from click.testing import CliRunner

    from sdc.cli import main

    write_arc_road(tmp_path / "road.xodr", 3.0, 60.0)
    (tmp_path / "base.toml").write_text(
        '[scenario]\nname = "od-town"\nduration_s = 12.0\nstep_s = 0.1\n'
        '[road]\nkind = "opendrive"\nxodr_file = "road.xodr"\nlength_m = 180.0\n'
        '[traffic]\nvehicles = 20\nwarm_up_s = 30.0\n'
        '[ego]\nlane = 0\nstart_m = 10.0\nspeed_mps = 10.0\n')
    (tmp_path / "sweep.toml").write_text(
        '[sweep]\nname = "od-town"\nbase = "base.toml"\nsamples = 6\nwarm_states = 2\n'
        'egos_per_world = 2\ncontrollers = ["avoid"]\n'
        '[sweep.params]\n"ego.speed_mps" = { uniform = [6.0, 12.0] }\n')
    out = tmp_path / "out"
    done = CliRunner().invoke(main, ["sweep", str(tmp_path / "sweep.toml"), "--out", str(out),
                                     "--workers", "2", "--traces", "all"])
    assert done.exit_code == 0, done.output
    rows = pd.read_parquet(out / "results.parquet")
    assert (rows.status == "ok").all() and rows.warm_state.nunique() == 2
    plan = pd.read_parquet(out / "plan.parquet")
    shared = plan.groupby("world_id").size()
    assert (shared == 2).any(), plan[["run_id", "world_id"]]
    run_id = plan[plan.world_id.isin(shared[shared == 2].index)].run_id.iloc[0]
    replay = CliRunner().invoke(main, ["replay", str(out), "--run", run_id, "--verify"])
    assert replay.exit_code == 0 and "identical" in replay.output, replay.output
