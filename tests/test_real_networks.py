"""SUMO's own real scenarios (the OpenStreetMap and hand-built networks its package
ships in ``tools/game``) read as SUMO reads them: gzipped networks included, every
lane's shape, width, length and permissions as sumolib reads them."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import sumo
import sumolib

from scenarios.sumo_net.net_xml import read_net

GAME_DIR = Path(sumo.SUMO_HOME) / "tools" / "game"
#: motorway, city (plain and gzipped), ring, corridor, a grid
REAL_NETWORKS = ["A10KW/osm.net.xml", "bs3d/bs.net.xml", "fkk_in/ingolstadt.net.xml.gz",
                 "fokr_bs_demo/fokr_bs.net.xml.gz", "square/square.net.xml",
                 "corridor/corridor.net.xml", "grid6/grid6.net.xml"]


@pytest.mark.parametrize("name", REAL_NETWORKS)
def test_the_network_reader_agrees_with_sumolib(name):
    path = GAME_DIR / name
    ours = read_net(path)
    theirs = sumolib.net.readNet(str(path), withInternal=True)
    lanes = {lane.getID(): lane for edge in theirs.getEdges(withInternal=True)
             if edge.getFunction() in ("", "normal", "internal") for lane in edge.getLanes()}
    assert set(ours.lanes) == set(lanes)
    for lane_id, lane in ours.lanes.items():
        other = lanes[lane_id]
        assert np.allclose(lane.shape_xy, np.array(other.getShape())[:, :2], atol=1e-6), lane_id
        assert lane.width_m == pytest.approx(other.getWidth()), lane_id
        assert lane.sumo_length_m == pytest.approx(other.getLength()), lane_id
        assert lane.passenger == other.allows("passenger"), lane_id
        assert lane.internal == (other.getEdge().getFunction() == "internal")
        if not lane.internal:
            targets = {c.getToLane().getID() for c in other.getOutgoing()} & set(lanes)
            assert {turn.to for turn in ours.turns[lane_id]} == targets, lane_id


def test_a_gzipped_network_reads_as_the_plain_one(tmp_path):
    import gzip

    plain = GAME_DIR / "bs3d" / "bs.net.xml"
    packed = tmp_path / "bs.net.xml.gz"
    packed.write_bytes(gzip.compress(plain.read_bytes()))
    a, b = read_net(plain), read_net(packed)
    assert a.lanes.keys() == b.lanes.keys() and a.turns == b.turns
    assert all(np.array_equal(a.lanes[k].shape_xy, b.lanes[k].shape_xy) for k in a.lanes)


def real_net_spec(lesson_plain: dict, net: Path, **traffic) -> dict:
    """The seed lesson on a route through ``net``, with random-trip traffic."""
    plain = lesson_plain
    plain["road"] = {"kind": "sumo_net", "net_file": str(net), "length_m": 300.0}
    plain["traffic"] = {"vehicles": 100, "speed_dev": 0.1, **traffic}
    plain["obstacles"] = [{"kind": "car", "lane": 0, "position_m": 150.0}]
    plain["ego"].update(lane=0, start_m=10.0, speed_mps=8.0)
    plain["scenario"].update(duration_s=5.0)
    return plain


def test_a_run_on_a_gzipped_network(lesson_plain):
    from scenarios.scenario_spec import ScenarioSpec
    from sdc.run.episode import run_episode

    spec = ScenarioSpec.from_plain(real_net_spec(lesson_plain,
                                                 GAME_DIR / "fkk_in" / "ingolstadt.net.xml.gz"))
    row = run_episode(spec).row
    assert row["status"] == "ok" and row["network_vehicles"] >= 90


def test_a_broken_gzipped_network_is_bad_input_naming_the_file(tmp_path):
    from scenarios.errors import FileError

    broken = tmp_path / "x.net.xml.gz"
    broken.write_bytes((GAME_DIR / "fkk_in" / "ingolstadt.net.xml.gz").read_bytes()[:500])
    with pytest.raises(FileError, match="x.net.xml.gz.*gzip-compressed but cannot be unpacked"):
        read_net(broken)
