"""Roads that cross the route without a junction are on another level (a bridge, a
tunnel): found from the network (scenarios.sumo_net.grade_separation), and their
vehicles neither met nor seen by the ego in a real libsumo world, while SUMO
drives them across."""

from __future__ import annotations

import subprocess

import numpy as np
import pytest
import sumolib

from scenarios import ScenarioSpec
from scenarios.sumo.sumo_world import SumoWorld
from scenarios.sumo_net.build import sumo_binary
from scenarios.sumo_net.grade_separation import LEVEL_REACH_M
from scenarios.sumo_net.road_source import road_source
from scenarios.world_backends import make_road

NODES = """<nodes>
  <node id="a0" x="0" y="0"/><node id="a1" x="{a1_x}" y="0"/><node id="a2" x="300" y="0"/>
  <node id="b0" x="150" y="-150"/><node id="b1" x="150" y="30"/><node id="b2" x="150" y="180"/>
</nodes>"""
EDGES = """<edges>
  <edge id="A1" from="a0" to="a1" numLanes="2" speed="20"/>
  <edge id="A2" from="a1" to="a2" numLanes="2" speed="20"/>
  <edge id="B1" from="b0" to="b1" numLanes="1" speed="15"/>
  <edge id="B2" from="b1" to="b2" numLanes="1" speed="15"/>
</edges>"""


def crossing_net(folder, a1_x: float):
    """Road A west to east (its middle node at ``a1_x``) and road B south to north
    across it near x = 151.6, without a node there: a bridge. With ``a1_x`` = 150,
    A's node stands where they cross: a junction (at grade)."""
    (folder / "x.nod.xml").write_text(NODES.format(a1_x=a1_x))
    (folder / "x.edg.xml").write_text(EDGES)
    net = folder / "x.net.xml"
    subprocess.run([sumo_binary("netconvert"), "-n", str(folder / "x.nod.xml"),
                    "-e", str(folder / "x.edg.xml"), "-o", str(net),
                    "--offset.disable-normalization"], check=True, capture_output=True)
    return net


def spec_on(net, lesson_plain: dict, vehicles: int = 0) -> ScenarioSpec:
    plain = lesson_plain
    plain["road"] = {"kind": "sumo_net", "net_file": str(net), "length_m": 250.0,
                     "route_edges": ["A1", "A2"]}
    plain["traffic"] = {"vehicles": vehicles, "warm_up_s": 0.0}
    plain["obstacles"] = []
    plain["ego"].update(lane=0, start_m=10.0, speed_mps=0.0)
    return ScenarioSpec.from_plain(plain)


def test_a_road_crossing_without_a_junction_passes_over_or_under(tmp_path, lesson_plain):
    road = make_road(spec_on(crossing_net(tmp_path, 60.0), lesson_plain))
    crossings = road.crossings()
    assert crossings.lanes == {"B1_0", ":b1_0_0", "B2_0"}  # B near where it crosses
    assert np.allclose(crossings.points_xy, [[151.6, -4.8]], atol=0.05)
    # the oracle: sumolib reads no junction of B1's within 20 m of where it crosses A
    net = sumolib.net.readNet(str(tmp_path / "x.net.xml"))
    edge = net.getEdge("B1")
    for node in (edge.getFromNode(), edge.getToNode()):
        assert np.hypot(*(np.array(node.getCoord()) - crossings.points_xy[0])) > 20.0


def test_a_road_crossing_at_a_junction_is_on_the_same_level(tmp_path, lesson_plain):
    road = make_road(spec_on(crossing_net(tmp_path, 150.0), lesson_plain))
    assert road.crossings().lanes == frozenset()


@pytest.mark.slow
def test_the_ego_at_a_bridge_never_meets_nor_sees_the_traffic_crossing_it(tmp_path,
                                                                          lesson_plain):
    """The ego stands where B crosses its road for 60 s while SUMO drives cars along
    B across that point: none of them is in a snapshot near the crossing; the cars
    on the ego's own road are."""
    spec = spec_on(crossing_net(tmp_path, 60.0), lesson_plain, vehicles=30)
    road = make_road(spec)
    point = road.crossings().points_xy[0]
    s_m, _ = road.locate(*point)
    xy = road.xy_at(s_m, 0.0)
    box = np.array([xy[0], xy[1], float(road.heading_at(s_m)), 4.85, 1.93])
    across_on_b = seen_on_a = 0
    with SumoWorld(spec, road, source=road_source(spec.road)) as world:
        world.start(box, 0.0)
        vehicle = world._sumo.vehicle
        for _ in range(600):
            snapshot = world.step(box, 0.0)
            for vid in vehicle.getIDList():
                x_m, y_m = vehicle.getPosition(vid)
                near = np.hypot(x_m - point[0], y_m - point[1]) < 20.0
                across_on_b += near and vehicle.getLaneID(vid) == "B1_0"
            boxes = snapshot.traffic_boxes
            # body centres well within reach (the world measures from front bumpers)
            near = np.hypot(*(boxes[:, :2] - point).T) < LEVEL_REACH_M - 5.0
            assert not np.any(near & (np.abs(np.cos(boxes[:, 2])) < 0.5)), "a car on B"
            seen_on_a += int(np.sum(near & (np.abs(np.cos(boxes[:, 2])) > 0.9)))
    assert across_on_b > 10  # SUMO drove cars across the point the ego holds
    assert seen_on_a > 0  # and the ego's own road's cars are seen as ever
