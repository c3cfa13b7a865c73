"""SUMO road networks built with ``netconvert`` and cached by content hash.

The road is one edge ``road`` from node ``start`` to node ``end`` whose shape is
the centre line of :mod:`scenarios.scene.road_geometry`; ``spreadType="center"`` puts the lanes
on both sides of it, so SUMO's lane ``road_i`` is our lane ``i``.
"""

from __future__ import annotations

import functools
import hashlib
import os
import subprocess
import tempfile
from importlib import metadata
from pathlib import Path

from scenarios.common.cache_dir import network_cache_dir
from scenarios.common.errors import SdcError
from scenarios.scene.road_geometry import EDGE_ID, RoadGeometry
from scenarios.spec.scenario_tables import SUMO_HOME_PREFIX, RoadSpec


def sumo_binary(name: str) -> str:
    """Path of a SUMO tool (``netconvert``, ``sumo``) shipped by eclipse-sumo."""
    import sumo  # the eclipse-sumo package

    return str(Path(sumo.SUMO_HOME) / "bin" / name)


def input_path(text: str) -> Path:
    """The file a spec's path names: ``sumo:<path>`` inside SUMO's installation, else
    the path itself."""
    if text.startswith(SUMO_HOME_PREFIX):
        import sumo  # the eclipse-sumo package

        return Path(sumo.SUMO_HOME) / text.removeprefix(SUMO_HOME_PREFIX)
    return Path(text)


def sumo_load_error(net_path: Path) -> str | None:
    """What goes wrong when SUMO loads the network ``net_path`` (None: nothing). In
    a process of its own: SUMO crashes on some networks it cannot use."""
    return process_problem(subprocess.run(
        [sumo_binary("sumo"), "--net-file", str(net_path), "--end", "0", "--no-step-log",
         "true", "--no-warnings", "true"], capture_output=True, text=True, check=False))


def process_problem(proc: subprocess.CompletedProcess) -> str | None:
    """What went wrong in a finished SUMO process (None: nothing): the signal it
    crashed on, or its error lines."""
    if proc.returncode == 0:
        return None
    if proc.returncode < 0:
        return f"it crashes (signal {-proc.returncode})"
    errors = [line for line in proc.stderr.splitlines() if line.startswith("Error")]
    return "; ".join(errors)[-1000:] or f"sumo exits with status {proc.returncode}"


def _xml_sources(road: RoadSpec, geometry: RoadGeometry) -> tuple[str, str]:
    (x0, y0), (x1, y1) = geometry.center_xy[0], geometry.center_xy[-1]
    nodes = (
        "<nodes>\n"
        f'  <node id="start" x="{x0:.6f}" y="{y0:.6f}"/>\n'
        f'  <node id="end" x="{x1:.6f}" y="{y1:.6f}"/>\n'
        "</nodes>\n"
    )
    shape = " ".join(f"{x:.6f},{y:.6f}" for x, y in geometry.center_xy)
    edges = (
        "<edges>\n"
        f'  <edge id="{EDGE_ID}" from="start" to="end" numLanes="{road.lanes}" '
        f'speed="{road.speed_limit_mps:.6f}" width="{road.lane_width_m:.6f}" '
        f'spreadType="center" shape="{shape}"/>\n'
        "</edges>\n"
    )
    return nodes, edges


@functools.cache
def netconvert_version() -> str:
    """What makes netconvert's output differ between installations: its package's
    version (not its path, so nodes installed elsewhere name a network alike); read
    once a process (a sweep names a network per run)."""
    try:
        return f"eclipse-sumo {metadata.version('eclipse-sumo')}"
    except metadata.PackageNotFoundError:
        return sumo_binary("netconvert")


def network_file_name(road: RoadSpec, geometry: RoadGeometry) -> str:
    """The cache's name for the network of ``road`` (its ``geometry``): a hash of
    netconvert's inputs."""
    nodes, edges = _xml_sources(road, geometry)
    digest = hashlib.sha256(f"{netconvert_version()}\n{nodes}\n{edges}".encode())
    return f"{digest.hexdigest()[:20]}.net.xml"


def build_network(road: RoadSpec, geometry: RoadGeometry, cache_dir: Path | None = None
                  ) -> Path:
    """Path of the ``.net.xml`` for ``road`` (its ``geometry``: its source's,
    :class:`~scenarios.sumo_net.road_source.BuiltRoad`), built on first use and cached
    (in ``cache_dir``, by default
    :func:`~scenarios.common.cache_dir.network_cache_dir`, as :func:`network_file_name`).

    Concurrent builders of the same network are safe: each writes a temporary
    file and renames it into place.
    """
    cache_dir = Path(cache_dir) if cache_dir is not None else network_cache_dir()
    target = cache_dir / network_file_name(road, geometry)
    if target.exists():
        return target
    nodes, edges = _xml_sources(road, geometry)
    tool = sumo_binary("netconvert")
    cache_dir.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=cache_dir) as tmp:
        tmp = Path(tmp)
        (tmp / "road.nod.xml").write_text(nodes)
        (tmp / "road.edg.xml").write_text(edges)
        out = tmp / "road.net.xml"
        proc = subprocess.run(
            [tool, "--node-files", str(tmp / "road.nod.xml"),
             "--edge-files", str(tmp / "road.edg.xml"), "--output-file", str(out),
             "--offset.disable-normalization", "--no-turnarounds", "--no-warnings",
             "--precision", "4",
             # the inputs are ours, written just above: checking them against SUMO's
             # schemas costs 45 ms of a 185 ms build and changes nothing built
             "--xml-validation", "never"],
            capture_output=True, text=True, check=False,
        )
        if proc.returncode != 0:
            raise SdcError(f"netconvert failed: {proc.stderr.strip()[-2000:]}")
        os.replace(out, target)
    return target
