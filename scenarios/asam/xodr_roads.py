"""An OpenDRIVE file's roads as the file itself says they lie: each road's reference
line (its ``planView``: lines, arcs, spirals, cubic and parametric cubic curves), its
lane offset and its lanes' widths, section by section. From them a point at
``(s, t)`` on a road and the centre of a lane at ``s``, computed from the file alone.

It is the independent account of an ``.xodr`` road: SUMO's netconvert turns the file
into the network a run drives (``scenarios/sumo_net/opendrive_net.py``), and this
module is what that network is checked against, and where an OpenSCENARIO position
(a road, a lane, an ``s``) is put on the map (``scenarios/asam/xodr_places.py``).
A lane given by ``<border>`` elements, or any other element of the plan view, is
refused by name.
"""

from __future__ import annotations

import dataclasses
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from scenarios.common.errors import FileError
from scenarios.common.file_read import read_bytes

#: the reference line is sampled this finely [m]: a chord of 0.05 m on a 5 m radius
#: strays 0.06 mm from the arc
SAMPLE_M = 0.05


@dataclasses.dataclass(frozen=True)
class Cubic:
    """``a + b ds + c ds^2 + d ds^3`` from ``s_m`` on (``ds = s - s_m``)."""

    s_m: float
    a: float
    b: float
    c: float
    d: float

    def at(self, s_m: np.ndarray | float) -> np.ndarray | float:
        ds = s_m - self.s_m
        return self.a + ds * (self.b + ds * (self.c + ds * self.d))


def _piecewise(pieces: tuple[Cubic, ...], s_m: float) -> float:
    """The piece in force at ``s_m`` (the last starting at or before it), 0 with none."""
    value = 0.0
    for piece in pieces:
        if piece.s_m <= s_m + 1e-9:
            value = piece.at(s_m)
    return float(value)


@dataclasses.dataclass(frozen=True)
class XodrLane:
    id: int
    type: str
    #: width polynomials, ``s_m`` from the road's start (the file's sOffset plus the
    #: section's s)
    widths: tuple[Cubic, ...]

    def width_m(self, s_m: float) -> float:
        return _piecewise(self.widths, s_m)


@dataclasses.dataclass(frozen=True)
class LaneSection:
    s_m: float
    lanes: dict[int, XodrLane]  # by OpenDRIVE id: + left of the reference line, - right


@dataclasses.dataclass(frozen=True)
class XodrRoad:
    id: str
    length_m: float
    #: the reference line sampled every :data:`SAMPLE_M` or finer: s, x, y, heading
    line: np.ndarray
    lane_offsets: tuple[Cubic, ...]
    sections: tuple[LaneSection, ...]

    def point(self, s_m: float, t_m: float = 0.0) -> tuple[float, float, float]:
        """The point ``t_m`` left of the reference line at ``s_m`` and the line's
        heading there [m, m, rad]."""
        s_m = min(max(s_m, 0.0), self.length_m)
        s, x, y, hdg = self.line.T
        i = int(np.clip(np.searchsorted(s, s_m, side="right") - 1, 0, len(s) - 2))
        f = (s_m - s[i]) / max(s[i + 1] - s[i], 1e-12)
        px, py = x[i] + f * (x[i + 1] - x[i]), y[i] + f * (y[i + 1] - y[i])
        heading = hdg[i] + f * _angle(hdg[i + 1] - hdg[i])
        return (px - t_m * math.sin(heading), py + t_m * math.cos(heading), heading)

    def section_at(self, s_m: float) -> LaneSection:
        found = self.sections[0]
        for section in self.sections:
            if section.s_m <= s_m + 1e-9:
                found = section
        return found

    def lane_t_m(self, lane_id: int, s_m: float) -> tuple[float, float]:
        """The centre of lane ``lane_id`` at ``s_m``, left of the reference line, and
        its width [m]: the lane offset, the widths of the lanes between the reference
        line and it, and half its own."""
        section = self.section_at(s_m)
        if lane_id == 0 or lane_id not in section.lanes:
            raise KeyError(f"road {self.id} has no lane {lane_id} at s = {s_m:g} m (its "
                           f"lanes there: {sorted(i for i in section.lanes if i)})")
        side = 1 if lane_id > 0 else -1
        inner = sum(section.lanes[side * k].width_m(s_m) for k in range(1, abs(lane_id)))
        width = section.lanes[lane_id].width_m(s_m)
        return _piecewise(self.lane_offsets, s_m) + side * (inner + width / 2), width

    def lane_point(self, lane_id: int, s_m: float, offset_m: float = 0.0):
        """The point ``offset_m`` left of lane ``lane_id``'s centre at ``s_m``."""
        t_m, _ = self.lane_t_m(lane_id, s_m)
        return self.point(s_m, t_m + offset_m)


def _angle(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def _floats(element: ET.Element, names: str, where: str, path: Path) -> list[float]:
    try:
        return [float(element.attrib.get(name, "0")) for name in names.split()]
    except ValueError:
        raise FileError(path, f"{where}: {names} must be numbers") from None


def _local_curve(shape: ET.Element, length_m: float, where: str, path: Path):
    """Points (u, v) of a curve in its own frame, sampled along its length, and its
    heading there: line, arc, spiral, poly3, paramPoly3."""
    n = max(2, math.ceil(length_m / SAMPLE_M) + 1)
    if shape.tag in ("line", "arc", "spiral"):
        ds = np.linspace(0.0, length_m, n)
        if shape.tag == "line":
            k0 = k1 = 0.0
        elif shape.tag == "arc":
            (k0,) = _floats(shape, "curvature", where, path)
            k1 = k0
        else:
            k0, k1 = _floats(shape, "curvStart curvEnd", where, path)
        heading = k0 * ds + (k1 - k0) * ds**2 / (2 * length_m)
        mid = (heading[1:] + heading[:-1]) / 2  # exact for arcs up to the chord
        step = np.diff(ds)
        u = np.concatenate([[0.0], np.cumsum(step * np.cos(mid) * _chord(np.diff(heading)))])
        v = np.concatenate([[0.0], np.cumsum(step * np.sin(mid) * _chord(np.diff(heading)))])
        return ds, u, v, heading
    if shape.tag == "poly3":
        a, b, c, d = _floats(shape, "a b c d", where, path)
        p = np.linspace(0.0, length_m * 1.5, 3 * n)  # u runs at most the length along
        u, v = p, a + p * (b + p * (c + p * d))
        dv = b + p * (2 * c + 3 * p * d)
        du = np.ones_like(p)
    elif shape.tag == "paramPoly3":
        au, bu, cu, du_, av, bv, cv, dv_ = _floats(shape, "aU bU cU dU aV bV cV dV", where, path)
        upper = 1.0 if shape.attrib.get("pRange", "arcLength") == "normalized" else length_m
        p = np.linspace(0.0, upper, n)
        u = au + p * (bu + p * (cu + p * du_))
        v = av + p * (bv + p * (cv + p * dv_))
        du = bu + p * (2 * cu + 3 * p * du_)
        dv = bv + p * (2 * cv + 3 * p * dv_)
    else:
        raise FileError(path, f"{where}: the plan view's <{shape.tag}> is not read (line, "
                        "arc, spiral, poly3 and paramPoly3 are)")
    s = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(u), np.diff(v)))])
    keep = s <= length_m + 1e-9
    return s[keep], u[keep], v[keep], np.arctan2(dv, du)[keep]


def _chord(turn: np.ndarray) -> np.ndarray:
    """A chord's length over its arc's, for an arc turning ``turn`` radians."""
    half = np.abs(turn) / 2
    return np.where(half > 1e-9, np.sin(half) / np.where(half > 1e-9, half, 1.0), 1.0)


def _reference_line(road: ET.Element, where: str, path: Path) -> np.ndarray:
    parts = []
    geometries = road.findall("planView/geometry")
    if not geometries:
        raise FileError(path, f"{where}: no <planView><geometry>")
    for i, geometry in enumerate(geometries):
        s0, x0, y0, hdg, length = _floats(geometry, "s x y hdg length", where, path)
        shape = next(iter(geometry), None)
        if shape is None:
            raise FileError(path, f"{where}/planView/geometry[{i}]: no shape element")
        ds, u, v, heading = _local_curve(shape, length, f"{where}/planView/geometry[{i}]",
                                         path)
        cos, sin = math.cos(hdg), math.sin(hdg)
        parts.append(np.column_stack([s0 + ds, x0 + cos * u - sin * v, y0 + sin * u + cos * v,
                                      hdg + heading]))
    line = np.vstack(parts)
    return line[np.concatenate([[True], np.diff(line[:, 0]) > 1e-9])]


def _cubics(elements: list[ET.Element], start_m: float, key: str, where: str,
            path: Path) -> tuple[Cubic, ...]:
    return tuple(Cubic(start_m + _floats(e, key, where, path)[0],
                       *_floats(e, "a b c d", where, path)) for e in elements)


def _section(section: ET.Element, where: str, path: Path) -> LaneSection:
    (s_m,) = _floats(section, "s", where, path)
    lanes = {}
    for side in ("left", "center", "right"):
        for lane in section.findall(f"{side}/lane"):
            lane_id = int(lane.attrib["id"])
            at = f"{where}/lane[id={lane_id}]"
            if lane.find("border") is not None and lane.find("width") is None:
                raise FileError(path, f"{at}: a lane given by <border> is not read (give "
                                "<width>)")
            lanes[lane_id] = XodrLane(lane_id, lane.attrib.get("type", "none"),
                                      _cubics(lane.findall("width"), s_m, "sOffset", at, path))
    return LaneSection(s_m, lanes)


def read_xodr(path: str | Path) -> dict[str, XodrRoad]:
    """The roads of the OpenDRIVE file ``path``, by id."""
    path = Path(path)
    try:
        root = ET.fromstring(read_bytes(path, "the OpenDRIVE file"))
    except ET.ParseError as e:
        raise FileError(path, f"the OpenDRIVE file is not well-formed XML ({e})") from None
    if root.tag != "OpenDRIVE":
        raise FileError(path, f"not an OpenDRIVE file (its root element is <{root.tag}>)")
    roads = {}
    for road in root.findall("road"):
        road_id = road.attrib.get("id", "")
        where = f"road[id={road_id}]"
        sections = tuple(_section(s, f"{where}/lanes/laneSection[{i}]", path)
                         for i, s in enumerate(road.findall("lanes/laneSection")))
        if not sections:
            raise FileError(path, f"{where}: no <lanes><laneSection>")
        roads[road_id] = XodrRoad(
            road_id, _floats(road, "length", where, path)[0], _reference_line(road, where, path),
            _cubics(road.findall("lanes/laneOffset"), 0.0, "s", where, path), sections)
    if not roads:
        raise FileError(path, "the OpenDRIVE file has no <road>")
    return roads
