"""Reading a SUMO ``.net.xml`` into plain data: lanes, connections, junction shapes,
pedestrian crossings.

Only what sdc needs is read: every lane's centre-line shape, width and SUMO
length, which lanes follow which (through the junction's internal lanes), and
the junction outlines. Works for any network SUMO writes (netconvert,
netgenerate, OpenStreetMap imports), gzipped or not.

Not sumolib's ``readNet``: on SUMO's own OSM networks it takes 1-5x as long
(Braunschweig's 1,811 lanes 0.15 s against 0.03 s, a 7,328-lane city 0.48 against
0.24 s) to build objects sdc would convert again; the tests hold this reader to
sumolib's reading of the same networks.
"""

from __future__ import annotations

import functools
import hashlib
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from scenarios.common.errors import FileError
from scenarios.common.file_read import read_bytes, unzipped

DEFAULT_LANE_WIDTH_M = 3.2  # SUMO's default when a lane names none
STRAIGHT, U_TURN = "s", "t"  # SUMO's connection directions (dir) straight on and turnaround
#: SUMO's link states (a connection's state) where a car gives way: minor, equal
#: (right before left), stop, all-way stop
GIVE_WAY_STATES = frozenset("m=sw")


@dataclass(frozen=True)
class NetLane:
    id: str
    edge: str
    index: int  # 0 = rightmost
    shape_xy: np.ndarray  # (P, 2) centre line [m]
    width_m: float
    sumo_length_m: float  # SUMO's lane positions run from 0 to this
    internal: bool  # inside a junction
    passenger: bool  # open to passenger cars

    @property
    def length_m(self) -> float:
        """Length of the shape polyline (may differ slightly from SUMO's)."""
        return float(np.hypot(*np.diff(self.shape_xy, axis=0).T).sum())


@dataclass(frozen=True)
class Turn:
    """Leaving a lane: the junction lanes driven through (``via``), then ``to``."""

    to: str
    via: tuple[str, ...]
    direction: str  # SUMO's dir: s, l, r, t, ...
    #: the traffic light controlling it and its link's index in the light's state
    #: string (None, -1: none)
    tl: str | None = None
    link_index: int = -1
    #: SUMO's link state without a light: M major (right of way), m minor (give
    #: way), = equal (right before left), s stop, w all-way stop ("": unknown)
    state: str = ""
    #: the junction it goes through takes traffic from another road too (a crossing,
    #: a merge): not a mere bend or a change of lane count
    shared: bool = False

    @property
    def give_way(self) -> bool:
        """Must a car taking this turn give way where no light says so?"""
        return self.state in GIVE_WAY_STATES


@dataclass(frozen=True)
class NetFile:
    path: Path
    sha256: str
    lanes: dict[str, NetLane]
    turns: dict[str, tuple[Turn, ...]]  # by normal lane id
    junction_shapes: tuple[np.ndarray, ...]  # outlines (P, 2) of the non-internal junctions
    #: the pedestrian crossings over roads: each its centre line from kerb to kerb (P, 2)
    #: and its width [m]
    crosswalks: tuple[tuple[np.ndarray, float], ...] = ()
    #: what is worked out from this network once (its drivable area, by name): a
    #: process's runs on one network share their :class:`NetFile` (:func:`parse_net`)
    derived: dict[str, object] = field(default_factory=dict, compare=False, repr=False)

    def trip_edges(self) -> list[tuple[str, float]]:
        """Edges a passenger car may start or end a trip on, with their lengths [m]."""
        edges: dict[str, float] = {}
        for lane in self.normal_lanes():
            edges.setdefault(lane.edge, lane.length_m)
        return list(edges.items())

    def normal_lanes(self) -> list[NetLane]:
        """Lanes outside junctions open to passenger cars, in file order."""
        return [lane for lane in self.lanes.values() if not lane.internal and lane.passenger]


def _shape(text: str) -> np.ndarray:
    shape = np.array([[float(v) for v in p.split(",")[:2]] for p in text.split()])
    shape.flags.writeable = False
    return shape


def _required(element: ET.Element, name: str) -> str:
    value = element.get(name)
    if value is None:
        raise ValueError(f"<{element.tag} id={element.get('id')!r}> has no {name}")
    return value


def _passenger(element: ET.Element) -> bool:
    allow, disallow = element.get("allow"), element.get("disallow", "")
    if allow is not None and allow != "all" and "passenger" not in allow.split():
        return False
    return disallow != "all" and "passenger" not in disallow.split()


def read_net(path: str | Path) -> NetFile:
    """Parse ``path`` (plain or gzipped; ``sha256`` is of the file's bytes); a file
    that cannot be read, is not XML or not a SUMO network is a :class:`FileError`."""
    path = Path(path)
    return parse_net(read_bytes(path, "the SUMO network"), path)


def parse_net(data: bytes, path: Path) -> NetFile:
    """:func:`read_net` of the bytes ``data`` of the file ``path`` (named in errors).
    The same bytes at the same path are parsed once per process: a worker's runs on
    one network share what it read (its arrays are read-only, so none can change it
    under another)."""
    return _parsed(data, Path(path))


@functools.lru_cache(maxsize=4)
def _parsed(data: bytes, path: Path) -> NetFile:
    try:
        root = ET.fromstring(unzipped(path, data, "the SUMO network"))
    except ET.ParseError as e:
        raise FileError(path, f"the SUMO network is not well-formed XML ({e})") from None
    if root.tag != "net":
        raise FileError(path, f"is not a SUMO network (root element <{root.tag}>)")
    try:
        lanes, turns, junctions, crosswalks = _parse(root)
    except (TypeError, ValueError, AttributeError) as e:  # a missing or malformed attribute
        raise FileError(path, f"the SUMO network has a missing or malformed attribute "
                              f"({e})") from None
    if not any(not lane.internal for lane in lanes.values()):
        raise FileError(path, "the SUMO network holds no lanes")
    return NetFile(path, hashlib.sha256(data).hexdigest(), lanes, turns, junctions,
                   crosswalks)


def _parse(root: ET.Element):
    """The lanes, turns and junction outlines of a ``<net>`` element."""
    lanes: dict[str, NetLane] = {}
    for edge in root.iter("edge"):
        function = edge.get("function", "normal")
        if function not in ("normal", "internal"):
            continue  # crossings, walking areas, connectors
        for lane in edge.iter("lane"):
            lane_id = _required(lane, "id")
            lanes[lane_id] = NetLane(
                id=lane_id, edge=edge.get("id"), index=int(_required(lane, "index")),
                shape_xy=_shape(_required(lane, "shape")),
                width_m=float(lane.get("width", DEFAULT_LANE_WIDTH_M)),
                sumo_length_m=float(_required(lane, "length")), internal=function == "internal",
                passenger=_passenger(lane) and _passenger(edge))
    successor: dict[str, list[tuple[str, str | None, str]]] = {}
    control: dict[tuple[str, str], tuple[str | None, int, str]] = {}
    for c in root.iter("connection"):
        source, to = f"{c.get('from')}_{c.get('fromLane')}", f"{c.get('to')}_{c.get('toLane')}"
        successor.setdefault(source, []).append((to, c.get("via"), c.get("dir", "")))
        control[source, to] = (c.get("tl"), int(c.get("linkIndex", -1)), c.get("state", ""))
    ends_at = {e.get("id"): e.get("to") for e in root.iter("edge") if e.get("to")}
    arrivals = {j.get("id"): {lane.rsplit("_", 1)[0] for lane in j.get("incLanes", "").split()
                              if not lane.startswith(":")}
                for j in root.iter("junction")}
    turns: dict[str, tuple[Turn, ...]] = {}
    for lane in lanes.values():
        if lane.internal:
            continue
        found = []
        for to, via, direction in successor.get(lane.id, []):
            chain = []
            while via is not None and via in lanes and len(chain) < 8:
                chain.append(via)  # a junction lane may lead on to another (internal junction)
                via = next((v for t, v, _ in successor.get(via, []) if t == to), None)
            if to in lanes:
                found.append(Turn(to, tuple(chain), direction, *control[lane.id, to],
                                  shared=len(arrivals.get(ends_at.get(lane.edge), ())) > 1))
        turns[lane.id] = tuple(found)
    junctions = tuple(
        _shape(j.get("shape")) for j in root.iter("junction")
        if j.get("type") != "internal" and len(j.get("shape", "").split()) >= 3)
    crosswalks = tuple((_shape(_required(lane, "shape")),
                        float(lane.get("width", DEFAULT_LANE_WIDTH_M)))
                       for edge in root.iter("edge") if edge.get("function") == "crossing"
                       for lane in edge.iter("lane"))
    return lanes, turns, junctions, crosswalks
