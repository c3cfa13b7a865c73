"""OpenDRIVE and OpenSCENARIO positions put on the SUMO network converted from the
same ``.xodr``: a lane position (road, lane, s, offset), a road position (road, s, t)
or a world position (x, y, heading) becomes a SUMO lane, a position along it and a
lateral offset from its centre.

A lane position is found by name, not by nearness: netconvert's
``--output.original-names`` writes each SUMO lane's OpenDRIVE road and lane as its
``origId`` (``"<road>_<lane>"``), so OpenDRIVE's lane -1 (the right lane next to the
reference line) is whichever SUMO lane carries ``<road>_-1``, though SUMO counts its
lanes from the outermost right one. The point itself is the file's own (its
reference line and lane widths: ``scenarios/asam/xodr_roads.py``), projected on that
lane; a SUMO lane farther from it than half its width is an error, never a guess.
"""

from __future__ import annotations

import dataclasses
import math
import xml.etree.ElementTree as ET
from pathlib import Path

from scenarios.asam.xodr_roads import XodrRoad, read_xodr
from scenarios.common.errors import SpecError
from scenarios.common.file_read import read_bytes
from scenarios.scene.polyline_frame import PolylineFrame
from scenarios.sumo_net.net_xml import NetFile, NetLane, read_net
from scenarios.sumo_net.opendrive_net import opendrive_network


@dataclasses.dataclass(frozen=True)
class MapPlace:
    lane: NetLane
    pos_m: float  # along the SUMO lane's shape from its start
    lateral_m: float  # from the lane's centre, + to the left of its direction
    heading_rad: float  # the lane's direction there

    @property
    def sumo_pos_m(self) -> float:
        """The position as SUMO counts it along the lane (every lane of an edge runs
        the edge's length, however long its own shape is)."""
        return self.pos_m * self.lane.sumo_length_m / self.lane.length_m


def original_lanes(net_path: Path) -> dict[str, tuple[str, int]]:
    """SUMO lane id -> its OpenDRIVE (road id, lane id), from each lane's ``origId``."""
    root = ET.fromstring(read_bytes(net_path, "the converted SUMO network"))
    found = {}
    for lane in root.iter("lane"):
        param = lane.find("param[@key='origId']")
        if param is not None:
            road, _, lane_id = param.get("value", "").rpartition("_")
            try:
                found[lane.get("id")] = (road, int(lane_id))
            except ValueError:
                continue
    return found


#: a point this far past a lane's end still lies on it [m]
ENDS_M = 0.01


class XodrMap:
    """An OpenDRIVE file and the SUMO network netconvert makes of it, side by side."""

    def __init__(self, xodr_file: Path, cache_dir: Path | None = None):
        self.xodr_file = Path(xodr_file)
        self.roads: dict[str, XodrRoad] = read_xodr(self.xodr_file)
        self.net_path = opendrive_network(str(self.xodr_file), cache_dir)
        self.net: NetFile = read_net(self.net_path)
        self._original = original_lanes(self.net_path)
        self._frames = {lane.id: PolylineFrame(lane.shape_xy, min_segment_m=1e-6)
                        for lane in self.net.normal_lanes()}

    def lane_frame(self, lane: NetLane) -> PolylineFrame:
        """The frame of a SUMO lane's shape (a place's ``pos_m`` and ``lateral_m``)."""
        return self._frames[lane.id]

    def road(self, road_id: str, where: str) -> XodrRoad:
        if road_id not in self.roads:
            raise SpecError(where, f"road {road_id!r} is not in {self.xodr_file.name} (its "
                            f"roads: {', '.join(sorted(self.roads))})")
        return self.roads[road_id]

    def _on(self, lane: NetLane, x_m: float, y_m: float) -> tuple[MapPlace, bool]:
        """The point on ``lane`` (its station held between the lane's ends), and
        whether it lies between them (within :data:`ENDS_M`)."""
        frame = self._frames[lane.id]
        s_m, d_m = frame.locate(x_m, y_m)
        length_m = float(frame.seg_start_s_m[-1] + frame.seg_len_m[-1])
        i = frame.segment(s_m)
        heading = math.atan2(frame.seg_dir[i, 1], frame.seg_dir[i, 0])
        return (MapPlace(lane, min(max(s_m, 0.0), length_m), d_m, heading),
                -ENDS_M <= s_m <= length_m + ENDS_M)

    def lane_place(self, road_id: str, lane_id: int, s_m: float, offset_m: float,
                   where: str) -> MapPlace:
        """A LanePosition: the SUMO lane whose ``origId`` is the road's lane, the point
        the file puts at ``s_m``, ``offset_m`` from the lane's centre (+ left of the
        reference line's direction, as OpenDRIVE's ``t``)."""
        road = self.road(road_id, where)
        if not 0 <= s_m <= road.length_m + 1e-6:
            raise SpecError(where, f"s = {s_m:g} m is off road {road_id} (0 to "
                            f"{road.length_m:g} m)")
        try:
            t_m, width_m = road.lane_t_m(lane_id, s_m)
        except KeyError as e:
            raise SpecError(where, str(e.args[0])) from None
        x_m, y_m, _ = road.point(s_m, t_m)
        lanes = [self.net.lanes[i] for i, orig in self._original.items()
                 if orig == (road_id, lane_id) and i in self._frames]
        if not lanes:
            kind = road.section_at(s_m).lanes[lane_id].type
            raise SpecError(where, f"road {road_id} lane {lane_id} (a {kind!r} lane) is no lane "
                            "SUMO drives: netconvert imports driving lanes")
        places = [self._on(lane, x_m, y_m)[0] for lane in lanes]
        best = min(places, key=lambda p: abs(p.lateral_m))
        if abs(best.lateral_m) > width_m / 2:
            raise SpecError(where, f"SUMO's lane {best.lane.id} for road {road_id} lane "
                            f"{lane_id} lies {abs(best.lateral_m):.2f} m from where "
                            f"{self.xodr_file.name} puts s = {s_m:g} m")
        x_m, y_m, _ = road.point(s_m, t_m + offset_m)
        return self._on(best.lane, x_m, y_m)[0]

    def road_place(self, road_id: str, s_m: float, t_m: float, where: str,
                   facing: bool = True) -> MapPlace:
        """A RoadPosition: the point ``t_m`` left of the road's reference line at
        ``s_m``, on the SUMO lane it lies in (``facing``: one whose direction is the
        reference line's there, as the position faces)."""
        x_m, y_m, heading = self.road(road_id, where).point(s_m, t_m)
        return self.world_place(x_m, y_m, heading if facing else None, where)

    def world_place(self, x_m: float, y_m: float, heading_rad: float | None,
                    where: str) -> MapPlace:
        """A WorldPosition: the SUMO lane it lies in (the nearest centre among those
        whose direction is within 90 degrees of ``heading_rad``)."""
        best = None
        for lane in self.net.normal_lanes():
            place, between_ends = self._on(lane, x_m, y_m)
            if not between_ends or abs(place.lateral_m) > lane.width_m / 2:
                continue
            if heading_rad is not None and math.cos(place.heading_rad - heading_rad) < 0:
                continue
            if best is None or abs(place.lateral_m) < abs(best.lateral_m):
                best = place
        if best is None and heading_rad is not None:
            against = self.world_place(x_m, y_m, None, where)  # else: on no lane at all
            raise SpecError(where, f"({x_m:g}, {y_m:g}) lies on SUMO's lane {against.lane.id}, "
                            f"whose traffic drives the other way from the heading the position "
                            f"gives ({heading_rad:.3f} rad; a RoadPosition faces along its "
                            "road's reference line): place it with a LanePosition")
        if best is None:
            raise SpecError(where, f"({x_m:g}, {y_m:g}) is on no driving lane of "
                            f"{self.xodr_file.name}")
        return best
