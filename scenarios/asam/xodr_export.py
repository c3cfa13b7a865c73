"""A run's road written as OpenDRIVE (``.xodr``), in the frame of the run's trace.

- ``opendrive`` roads: the file the spec names, its bytes copied as they came;
- SUMO networks (the built ``straight`` and ``curve`` roads, ``sumo_net``, the network
  inside a ``sumo_config`` bundle): SUMO's ``netconvert --sumo-net-file X
  --opendrive-output Y``.

The frame. A trace's positions are in the SUMO network's frame. ``netconvert`` keeps
that frame in the OpenDRIVE it writes (its planView x, y are the network's own), and
turns the network's ``location netOffset`` into the header's ``<offset>`` (its
negation: where the projection's origin lies), which players such as esmini keep as
geographic information and do not apply to the geometry. Measured here (SUMO 1.28) on
the built roads, on the 4x4 grid (netOffset 0) and on SUMO's Braunschweig and A10
networks (netOffsets of 500 m and 5,800 km): the planView starts on the network's
lanes, no shift. :func:`frame_shift_m` measures it for every network exported (the
network's lane points against the written reference lines, with no shift and with the
netOffset either way), and :func:`write_sumo_xodr` moves the planView by the shift
that fits, should a netconvert ever apply the offset.

The geometry is read back by :func:`reference_points` (the reference lines as
``scenarios/asam/xodr_roads.py`` samples them) for those checks.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from scenarios.asam.xodr_roads import read_xodr
from scenarios.common.errors import SdcError
from scenarios.common.file_read import read_bytes, unzipped
from scenarios.spec.scenario_tables import RoadSpec
from scenarios.sumo_net.build import process_problem, sumo_binary
from scenarios.sumo_net.net_xml import parse_net
from scenarios.sumo_net.road_source import road_source

#: the largest typical distance [m] from a network's lane points to the written
#: reference lines that counts as the same frame: a reference line runs along a road's
#: lanes, a few lane widths from the farthest lane's centre
SAME_FRAME_M = 15.0


def export_road(road: RoadSpec, out: Path, cache_dir: Path | None = None) -> tuple[float, float]:
    """Write ``road`` as OpenDRIVE to ``out``; the shift (dx, dy) [m] applied to bring
    it into the trace's frame ((0, 0): none). Unreadable input is a :class:`SdcError`."""
    source = road_source(road)
    original = source.opendrive_file()
    if original is not None:
        out.write_bytes(read_bytes(original, "the OpenDRIVE road"))
        return 0.0, 0.0
    name, data = source.network_data(cache_dir)
    with tempfile.TemporaryDirectory() as tmp:
        net = Path(tmp) / name
        net.write_bytes(data)
        return write_sumo_xodr(net, out)


def write_sumo_xodr(net_path: Path, out: Path) -> tuple[float, float]:
    """The SUMO network ``net_path`` written as OpenDRIVE to ``out`` by netconvert, in
    the network's frame; the shift it took to get there (:func:`frame_shift_m`)."""
    with tempfile.TemporaryDirectory() as tmp:
        written = Path(tmp) / "road.xodr"
        proc = subprocess.run(
            [sumo_binary("netconvert"), "--sumo-net-file", str(net_path),
             "--opendrive-output", str(written), "--no-warnings"],
            capture_output=True, text=True, check=False)
        problem = process_problem(proc)
        if problem is not None or not written.is_file():
            raise SdcError(f"netconvert could not write {net_path} as OpenDRIVE: "
                           f"{problem or 'no file written'}")
        data = read_bytes(net_path, "the SUMO network")
        lanes = np.concatenate([lane.shape_xy for lane in
                                parse_net(data, net_path).lanes.values() if not lane.internal])
        shift = frame_shift_m(written, lanes, net_offset_m(net_path, data))
        if shift != (0.0, 0.0):
            shift_planview(written, shift)
        shutil.copyfile(written, out)
    return shift


def net_offset_m(path: Path, data: bytes) -> tuple[float, float]:
    """A SUMO network's ``<location netOffset>`` (0, 0 when it has none)."""
    text = unzipped(path, data, "the SUMO network")[:20_000].decode("utf-8", "replace")
    found = re.search(r'<location[^>]*\bnetOffset="([^"]*)"', text)
    if found is None:
        return 0.0, 0.0
    x, y = (float(v) for v in found.group(1).split(",")[:2])
    return x, y


def frame_shift_m(xodr: Path, lane_xy: np.ndarray, net_offset: tuple[float, float]
                  ) -> tuple[float, float]:
    """The shift that puts the reference lines of ``xodr`` on the network's lanes
    (``lane_xy``, points of its lanes' centre lines): (0, 0) or the ``net_offset``
    either way, whichever brings them within :data:`SAME_FRAME_M` (the median distance
    of the lane points to the nearest reference line), the first of those; a file that
    none brings there is a :class:`SdcError`."""
    from scipy.spatial import cKDTree

    tree = cKDTree(reference_points(xodr))
    points = lane_xy[:: max(1, len(lane_xy) // 4000)]
    ox, oy = net_offset
    tried = []
    for shift in ((0.0, 0.0), (ox, oy), (-ox, -oy)):
        gap = float(np.median(tree.query(points - np.array(shift))[0]))
        if gap <= SAME_FRAME_M:
            return (0.0, 0.0) if shift == (0.0, 0.0) else shift
        tried.append(f"{gap:.1f} m shifted by ({shift[0]:g}, {shift[1]:g})")
    raise SdcError(f"the OpenDRIVE netconvert wrote from the network is not in the "
                   f"network's frame: its lanes lie {', '.join(tried)} from its roads")


def shift_planview(xodr: Path, shift: tuple[float, float]) -> None:
    """Move every planView geometry of ``xodr`` by ``shift`` (dx, dy) [m]."""
    tree = ET.parse(xodr)
    for geometry in tree.getroot().iter("geometry"):
        geometry.set("x", repr(float(geometry.get("x")) + shift[0]))
        geometry.set("y", repr(float(geometry.get("y")) + shift[1]))
    tree.write(xodr, encoding="utf-8", xml_declaration=True)


def is_opendrive(path: Path) -> bool:
    """Is ``path`` an OpenDRIVE file with at least one road and a planView geometry?"""
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError):
        return False
    return (root.tag == "OpenDRIVE" and root.find("header") is not None
            and root.find("road/planView/geometry") is not None)


def reference_points(xodr: Path) -> np.ndarray:
    """Points (N, 2) along every road's reference line in ``xodr``, as the file's own
    geometry gives them (``scenarios/asam/xodr_roads.py``)."""
    return np.vstack([road.line[:, 1:3] for road in read_xodr(xodr).values()])


def distance_to_roads_m(xodr: Path, xy: np.ndarray) -> np.ndarray:
    """Each point's distance [m] to the nearest reference line of ``xodr``."""
    from scipy.spatial import cKDTree

    return cKDTree(reference_points(xodr)).query(np.asarray(xy, float).reshape(-1, 2))[0]
