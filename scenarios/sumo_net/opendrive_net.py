"""An OpenDRIVE road network (``.xodr``) as SUMO drives it: converted once by SUMO's
``netconvert --opendrive-files`` and cached by the file's sha256 (with netconvert's
version and options), like every network sdc builds.

The options keep what the file says:

- ``--offset.disable-normalization``: the file's own coordinates, so an OpenSCENARIO
  ``WorldPosition`` and an OpenDRIVE ``(road, lane, s)`` land where the file puts them;
- ``--output.original-names``: each SUMO lane carries its OpenDRIVE road and lane as
  ``origId`` (``"<road>_<lane>"``), which is how a lane id is mapped to SUMO's lane
  (``scenarios/asam/xodr_places.py``);
- ``--opendrive.curve-resolution 1`` and ``--precision 4``: arcs and spirals sampled
  every metre, in tenths of a millimetre. Measured against the file's own reference
  line and lane widths (``scenarios/asam/xodr_roads.py``) on straight-spiral-arc-straight
  roads of 2.8 and 3.5 m lanes: the lane centres stray at most 35 mm from the file's
  at a 15 m radius with netconvert's defaults (2 m, 2 decimals), 15 mm with these,
  20 mm at 40 and 200 m either way (SUMO's spirals).

Only driving lanes are imported (netconvert's default: sidewalks, shoulders and
borders are not lanes a car may take), so the drivable area is the driving lanes'.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import tempfile
from pathlib import Path

from scenarios.common.cache_dir import network_cache_dir
from scenarios.common.errors import SpecError
from scenarios.common.file_read import read_bytes
from scenarios.sumo_net.build import input_path, netconvert_version, sumo_binary

#: netconvert's options beyond its input and output (see the module's docstring)
OPTIONS = ("--offset.disable-normalization", "--output.original-names",
           "--opendrive.curve-resolution", "1", "--precision", "4", "--no-warnings")
FIELD = "road.xodr_file"


def opendrive_network(xodr_file: str, cache_dir: Path | None = None) -> Path:
    """The ``.net.xml`` SUMO runs for the OpenDRIVE file ``xodr_file`` (a spec's
    ``road.xodr_file``), converted on first use and cached in ``cache_dir`` (default
    :func:`~scenarios.common.cache_dir.network_cache_dir`). A file netconvert cannot
    convert is a :class:`SpecError` naming ``road.xodr_file`` and netconvert's words."""
    path = input_path(xodr_file)
    if not path.exists():
        raise SpecError(FIELD, f"no such file: {path}")
    data = read_bytes(path, "the OpenDRIVE file")
    key = hashlib.sha256(f"{netconvert_version()}\n{' '.join(OPTIONS)}\n".encode() + data)
    cache_dir = Path(cache_dir) if cache_dir is not None else network_cache_dir()
    target = cache_dir / f"{key.hexdigest()[:20]}.xodr.net.xml"
    if target.exists():
        return target
    cache_dir.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=cache_dir) as tmp:
        source, out = Path(tmp) / "road.xodr", Path(tmp) / "road.net.xml"
        source.write_bytes(data)
        proc = subprocess.run([sumo_binary("netconvert"), "--opendrive-files", str(source),
                               "--output-file", str(out), *OPTIONS],
                              capture_output=True, text=True, check=False)
        if proc.returncode != 0 or not out.exists():
            said = proc.stderr.strip().replace(str(source), path.name)[-1500:]
            raise SpecError(FIELD, f"{path}: SUMO's netconvert cannot convert it: {said}")
        out.write_bytes(_without_header(out.read_bytes()))
        os.replace(out, target)
    return target


def _without_header(net: bytes) -> bytes:
    """The network without netconvert's leading comment (the time and the temporary
    paths it ran with), so a conversion's bytes, and the road edges cached by their
    sha256, are the same in every process."""
    start = net.find(b"<!-- generated on")
    end = net.find(b"-->", start)
    return net if start < 0 or end < 0 else net[:start] + net[end + 3:].lstrip(b"\n")
