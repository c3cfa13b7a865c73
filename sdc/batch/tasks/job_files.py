"""Files that travel with a job: what a run reads besides its spec, read and
hashed once on the driver, so every worker, on any node, runs on exactly the
driver's bytes.

A run of a ``sumo_net`` road reads ``road.net_file`` and that network's road
edges (cached beside the built networks), one of a ``sumo_config`` road its
configuration as one bundle (``scenarios/sumo_net/sumo_config.py``) and the road
edges; a SUMO run of a built-in road reads
the network netconvert built for it on the driver; a ``file.py:Class``
controller reads its file; a run with a warm-up starts from its warm state, once
the driver has it (:mod:`sdc.batch.sweeps.warm_states`). Each is a :class:`JobFile`:
the field that names it, the driver's path (for messages and the manifest; no
worker opens it), its sha256 and the file name its copy takes. :class:`FileCatalog` is the driver's
side; :mod:`sdc.batch.executors.worker_files` is the worker's.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from scenarios.common.errors import SdcError
from scenarios.common.file_read import read_bytes, sha256_hex
from scenarios.spec.controller_ref import controller_kind
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.spec.scenario_tables import RoadSpec
from scenarios.sumo.warm_state import cached_path, uses_warm_state, warm_key
from scenarios.sumo_net.road_source import road_source
from scenarios.sumo_net.route_road import edges_cache_path

#: JobFile.field of the files a run finds in its cache directory, by name
CACHED_FIELDS = ("network", "road edges")
#: JobFile.field of the warm state a run starts from (scenarios/sumo/warm_state.py)
WARM_STATE_FIELD = "warm state"


@dataclasses.dataclass(frozen=True)
class JobFile:
    """One file a run reads besides its spec, identified by its content."""

    field: str  # what names it: road.net_file, road.config_file, controller.name, or one
    # of CACHED_FIELDS
    driver_path: str  # where the driver read it; never opened by a worker
    sha256: str
    name: str  # the copy's file name (a cached file's: the name the run looks it up by)

    @property
    def cached(self) -> bool:
        return self.field in CACHED_FIELDS

    def describe(self) -> str:
        """How a message names the file: its field, the driver's path, its hash."""
        return f"{self.field}: {self.driver_path} (sha256 {self.sha256[:12]}...)"


class FileCatalog:
    """The driver's side: the files of runs, each read and hashed once for the
    catalog's lifetime (an executor's ``with`` block), and their bytes by sha256.

    A file that cannot be read is an :class:`~scenarios.common.errors.SdcError` naming it.
    """

    def __init__(self, cache_dir: Path | None = None):
        self.cache_dir = cache_dir  # the driver's network cache (default: network_cache_dir())
        self._by_path: dict[str, JobFile] = {}
        self._payloads: dict[str, bytes] = {}
        self._by_road: dict[RoadSpec, tuple[JobFile, ...]] = {}
        self._identity: dict[RoadSpec, str] = {}  # its warm states' (RoadSource.identity_sha256)

    def payload(self, sha256: str) -> bytes:
        """The bytes of a file this catalog read."""
        return self._payloads[sha256]

    def _read(self, field: str, path: Path, what: str, name: str | None = None) -> JobFile:
        key = str(path)
        if key not in self._by_path:
            self._add(field, key, read_bytes(path, what), name or path.name)
        return self._by_path[key]

    def _add(self, field: str, key: str, data: bytes, name: str) -> JobFile:
        digest = sha256_hex(data)
        self._payloads[digest] = data
        self._by_path[key] = JobFile(field, key, digest, name)
        return self._by_path[key]

    def _road_files(self, spec: ScenarioSpec) -> tuple[JobFile, ...]:
        """The road's own file (a configuration travels as one bundle) and, where a
        network's road edges are cached, those."""
        road = spec.road
        if not spec.scenario.world_backend.loads_networks:
            return ()
        if road not in self._by_road:
            source = road_source(road)
            source.prepare(self.cache_dir)  # builds the network, caches its road edges
            own = source.shipped(self.cache_dir)
            main = self._by_path.get(own.driver_path) or self._add(
                own.field, own.driver_path, own.data, own.name)
            edges = None if own.edges_key is None else edges_cache_path(own.edges_key,
                                                                        self.cache_dir)
            self._by_road[road] = (main,) + ((self._read("road edges", edges, "road edges"),)
                                             if edges is not None and edges.is_file() else ())
            self._identity[road] = own.identity_sha256
        return self._by_road[road]

    def warm_key(self, spec: ScenarioSpec) -> str | None:
        """The key of the warm state a run of ``spec`` starts from (None: none)."""
        if not uses_warm_state(spec):
            return None
        self._road_files(spec)
        return warm_key(spec, self._identity[spec.road])

    def files(self, spec: ScenarioSpec) -> tuple[JobFile, ...]:
        """What a run of ``spec`` reads besides the spec."""
        files = self._road_files(spec)
        key = self.warm_key(spec)
        if key is not None and cached_path(key).is_file():
            files += (self._read(WARM_STATE_FIELD, cached_path(key), "the warm state"),)
        if controller_kind(spec.controller.name) == "file":
            path = Path(spec.controller.name.rpartition(":")[0])
            files += (self._read("controller.name", path, "the controller file"),)
        return files

    def manifest_entries(self) -> dict[str, dict]:
        """Every file read so far, by the driver's path: its field and sha256."""
        return {f.driver_path: {"field": f.field, "sha256": f.sha256}
                for f in self._by_path.values()}


def with_files(task, catalog: FileCatalog):
    """``task`` (any kind: :class:`~sdc.batch.tasks.task.Task`) with the files of its
    spec, or the :class:`SdcError` that says which one the driver cannot read."""
    try:
        return dataclasses.replace(task, files=catalog.files(task.spec))
    except SdcError as e:
        return e
