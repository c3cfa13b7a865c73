"""A road as SUMO gets it, one class per ``road.kind``: the rest of the code asks
the road's source and never its kind.

- :class:`BuiltRoad` (``straight``, ``curve``): a network netconvert builds from
  the spec, its geometry of its shape's class (:class:`StraightRoad`,
  :class:`CurveRoad`), traffic entering as flows per lane at the road's start;
- :class:`NetworkFileRoad` (``sumo_net``): a network file, its traffic random trips
  across it (``traffic.vehicles``);
- :class:`OpenDriveRoad` (``opendrive``): an OpenDRIVE file as netconvert converts it,
  then a network file's road;
- :class:`ConfigRoad` (``sumo_config``): a SUMO configuration with its own demand,
  which runs from the configuration's begin until ``traffic.enter_s`` as the
  warm-up of every run.

Each says what its runs are built on (its geometry, its network file, a network
road's network as read, what a job ships of it), the identity of its warm states, and
how its warm-up is counted.
Where SUMO places a lane position and which edges a route takes are the
geometry's (:meth:`RoadGeometry.sumo_place`, :meth:`RoadGeometry.route_edges`).
:func:`road_source` is the one place a kind is turned into its class.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
from collections.abc import Callable
from pathlib import Path
from typing import Protocol

from scenarios.common.errors import SdcError, SpecError
from scenarios.common.file_read import file_sha256, read_bytes, sha256_hex
from scenarios.scene.road_geometry import CurveRoad, RoadGeometry, StraightRoad
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.spec.scenario_tables import RoadSpec, TrafficSpec
from scenarios.sumo_net.build import build_network, input_path, sumo_load_error
from scenarios.sumo_net.net_xml import NetFile, parse_net, read_net
from scenarios.sumo_net.opendrive_net import opendrive_network


@dataclasses.dataclass(frozen=True)
class ShippedFile:
    """What a job ships of a road: the field that names it, how the driver names it
    (its path), its bytes, the name its copy takes, the key of its network's cached
    road edges (the network file's sha256; None: a built road's edges are its
    geometry's), and its warm states' identity (:meth:`RoadSource.identity_sha256`,
    from the bytes read here: the file is read once)."""

    field: str
    driver_path: str
    data: bytes
    name: str
    edges_key: str | None
    identity_sha256: str


class RoadSource(Protocol):
    road: RoadSpec
    #: the background traffic enters as flows per lane at the road's start (a built
    #: road; elsewhere SUMO routes it across a network)
    flows: bool
    #: the field whose seconds a warm-up runs to: ``traffic.warm_up_s`` from 0, or a
    #: configuration's ``traffic.enter_s`` on SUMO's clock
    warm_up_field: str

    def geometry(self, spec: ScenarioSpec, cache_dir: Path | None = None) -> RoadGeometry:
        """The road a run drives (a network road's route drawn from the seed)."""
    def check_inputs(self, spec: ScenarioSpec) -> None:
        """Read what a run reads besides the spec, so bad input is named before a run."""
    def prepare(self, cache_dir: Path | None = None) -> None:
        """Build and cache what parallel runs need ready (unreadable input is left to
        the runs to report)."""
    def network_file(self, cache_dir: Path | None = None) -> Path:
        """The ``.net.xml`` SUMO runs on."""
    def shipped(self, cache_dir: Path | None = None) -> ShippedFile:
        """What a job ships of the road."""
    def identity_sha256(self, cache_dir: Path | None = None) -> str:
        """The sha256 its warm states are keyed by (``scenarios/sumo/warm_state.py``)."""
    def always_warm(self) -> bool:
        """Does every run start from a warm state, whatever ``traffic.warm_up_s``?"""
    def warm_up_begin_s(self) -> float:
        """SUMO's clock where a warm-up starts [s]."""
    def warm_up_steps(self, spec: ScenarioSpec) -> int:
        """SUMO steps of ``spec``'s warm-up."""
    def has_traffic(self, traffic: TrafficSpec) -> bool:
        """Is there background traffic to watch?"""
    def configuration(self, spec: ScenarioSpec):
        """The configuration a run loads (a ``ConfigBundle``; None: none), ``spec``'s
        ``traffic.enter_s`` checked against its demand first."""
    def manifest_entry(self, step_s: float) -> dict | None:
        """What a sweep's manifest records of its configuration, run in steps of
        ``step_s`` (None: it has none)."""
    def network_data(self, cache_dir: Path | None = None) -> tuple[str, bytes]:
        """The network SUMO runs: its file's name and bytes."""
    def opendrive_file(self) -> Path | None:
        """The OpenDRIVE file the road came as (None: it came as SUMO's own)."""


class _Exported:
    """What a road gives a run written out (``sdc export``): its network's bytes, and
    no OpenDRIVE file of its own."""

    def network_data(self, cache_dir: Path | None = None) -> tuple[str, bytes]:
        path = self.network_file(cache_dir)
        return path.name, read_bytes(path, "the SUMO network")

    def opendrive_file(self) -> Path | None:
        return None


class _WarmsUpFromZero:
    """A road whose warm-up is ``traffic.warm_up_s`` from SUMO's 0 (none: no warm state)."""

    warm_up_field = "warm_up_s"

    def always_warm(self) -> bool:
        return False

    def warm_up_begin_s(self) -> float:
        return 0.0

    def warm_up_steps(self, spec: ScenarioSpec) -> int:
        return round(spec.traffic.warm_up_s / spec.scenario.step_s)

    def configuration(self, spec: ScenarioSpec):
        return None

    def manifest_entry(self, step_s: float) -> dict | None:
        return None


class BuiltRoad(_Exported, _WarmsUpFromZero):
    """A ``straight`` or ``curve`` road: its geometry of its ``shape``'s class, and
    netconvert builds its network from the spec and that geometry."""

    flows = True

    def __init__(self, road: RoadSpec, shape: type[StraightRoad | CurveRoad]):
        self.road, self.shape = road, shape

    def geometry(self, spec: ScenarioSpec, cache_dir: Path | None = None) -> RoadGeometry:
        return self.shape.from_spec(self.road)

    def check_inputs(self, spec: ScenarioSpec) -> None:
        pass

    def prepare(self, cache_dir: Path | None = None) -> None:
        self.network_file(cache_dir)

    def network_file(self, cache_dir: Path | None = None) -> Path:
        return build_network(self.road, self.shape.from_spec(self.road), cache_dir)

    def shipped(self, cache_dir: Path | None = None) -> ShippedFile:
        path = self.network_file(cache_dir)
        data = read_bytes(path, "the built SUMO network")
        return ShippedFile("network", str(path), data, path.name, None, sha256_hex(data))

    def identity_sha256(self, cache_dir: Path | None = None) -> str:
        return file_sha256(self.network_file(cache_dir))

    def has_traffic(self, traffic: TrafficSpec) -> bool:
        return traffic.flow_vph_per_lane > 0


class _NetworkRoad(_Exported):
    """A road drawn through a SUMO network: the route its seed draws."""

    flows = False

    def __init__(self, road: RoadSpec):
        self.road = road

    def network(self, cache_dir: Path | None = None) -> NetFile:
        """The road's network as read (its network file, cached in ``cache_dir`` where
        it is converted); a missing, unreadable or foreign file is a
        :class:`SpecError` naming the road's field (``road.network_field``)."""
        path = self.network_file(cache_dir)
        if not path.exists():
            raise SpecError(self.road.network_field, f"no such file: {path}")
        try:
            return read_net(path)
        except SdcError as e:
            raise SpecError(self.road.network_field, str(e)) from None

    def geometry(self, spec: ScenarioSpec, cache_dir: Path | None = None) -> RoadGeometry:
        from scenarios.sumo_net.route_road import network_road

        return network_road(spec, self.network(cache_dir), cache_dir)

    def prepare(self, cache_dir: Path | None = None) -> None:
        from scenarios.sumo_net.route_road import network_area

        with contextlib.suppress(SdcError):
            network_area(self.network(cache_dir), cache_dir)


class NetworkFileRoad(_NetworkRoad, _WarmsUpFromZero):
    """A ``sumo_net`` road: a network file, its traffic ``traffic.vehicles`` random
    trips."""

    def check_inputs(self, spec: ScenarioSpec) -> None:
        from scenarios.sumo_net.random_trips import trip_edges

        road = self.geometry(spec)
        if spec.traffic.vehicles:
            trip_edges(road.net)
        problem = sumo_load_error(road.net.path)
        if problem is not None:
            raise SpecError(self.road.network_field,
                            f"{road.net.path}: SUMO cannot load the network: {problem}")

    def network_file(self, cache_dir: Path | None = None) -> Path:
        return input_path(self.road.net_file)

    def shipped(self, cache_dir: Path | None = None) -> ShippedFile:
        path = self.network_file()
        data = read_bytes(path, "the SUMO network")
        digest = sha256_hex(data)
        return ShippedFile("road.net_file", str(path), data, path.name, digest, digest)

    def identity_sha256(self, cache_dir: Path | None = None) -> str:
        return file_sha256(self.network_file())

    def has_traffic(self, traffic: TrafficSpec) -> bool:
        return traffic.vehicles > 0


class OpenDriveRoad(NetworkFileRoad):
    """An ``opendrive`` road: an OpenDRIVE file, converted by netconvert and cached
    (``scenarios/sumo_net/opendrive_net.py``), then a network as ``sumo_net``'s. A job
    ships the ``.xodr``; each worker converts it once (the same bytes everywhere), and
    the network's road edges travel beside it."""

    def network_file(self, cache_dir: Path | None = None) -> Path:
        return opendrive_network(self.road.xodr_file, cache_dir)

    def shipped(self, cache_dir: Path | None = None) -> ShippedFile:
        path = input_path(self.road.xodr_file)
        data = read_bytes(path, "the OpenDRIVE file")
        net_sha256 = file_sha256(self.network_file(cache_dir))
        return ShippedFile("road.xodr_file", str(path), data, path.name, net_sha256, net_sha256)

    def identity_sha256(self, cache_dir: Path | None = None) -> str:
        return file_sha256(self.network_file(cache_dir))

    def opendrive_file(self) -> Path | None:
        return input_path(self.road.xodr_file)


class ConfigRoad(_NetworkRoad):
    """A ``sumo_config`` road: a configuration, its network and its own demand, shipped
    as one bundle (``scenarios/sumo_net/sumo_config.py``) and keyed by its content."""

    warm_up_field = "enter_s"

    def _bundle(self):
        from scenarios.sumo_net.sumo_config import load_bundle

        return load_bundle(self.road.config_file)

    def check_inputs(self, spec: ScenarioSpec) -> None:
        from scenarios.sumo_net.sumo_config import check_config

        self.geometry(spec)
        check_config(self.road.config_file, spec.traffic.enter_s)

    def network_file(self, cache_dir: Path | None = None) -> Path:
        raise SdcError("a configuration's network is one of its files: a run writes "
                       "them out (SumoWorld.net_path)")

    def network(self, cache_dir: Path | None = None) -> NetFile:
        """The configuration's network, read from its bundle (a bad one is a
        :class:`SpecError` naming ``road.config_file``)."""
        from scenarios.sumo_net.sumo_config import FIELD

        bundle = self._bundle()
        try:
            return parse_net(bundle.files[bundle.net_name], Path(bundle.net_name))
        except SdcError as e:
            raise SpecError(FIELD, str(e)) from None

    def shipped(self, cache_dir: Path | None = None) -> ShippedFile:
        from scenarios.sumo_net.sumo_config import BUNDLE_SUFFIX

        bundle = self._bundle()
        name = f"{input_path(self.road.config_file).stem}{BUNDLE_SUFFIX}"
        return ShippedFile("road.config_file", self.road.config_file, bundle.to_bytes(), name,
                           sha256_hex(bundle.files[bundle.net_name]), bundle.sha256)

    def identity_sha256(self, cache_dir: Path | None = None) -> str:
        return self._bundle().sha256  # its content, not its bundle's bytes

    def always_warm(self) -> bool:
        return self.road.own_demand

    def warm_up_begin_s(self) -> float:
        return self._bundle().begin_s

    def warm_up_steps(self, spec: ScenarioSpec) -> int:
        """From the configuration's begin to ``traffic.enter_s``, one step at least
        (the demand departing at its begin is in before the ego enters)."""
        steps = (spec.traffic.enter_s - self.warm_up_begin_s()) / spec.scenario.step_s
        return max(1, round(steps))

    def has_traffic(self, traffic: TrafficSpec) -> bool:
        return True  # its own demand

    def configuration(self, spec: ScenarioSpec):
        from scenarios.sumo_net.sumo_config import check_enter_s

        check_enter_s(self.road.config_file, spec.traffic.enter_s)
        return self._bundle()

    def manifest_entry(self, step_s: float) -> dict | None:
        from scenarios.sumo_net.sumo_config import config_manifest

        return config_manifest(self.road.config_file, step_s)

    def network_data(self, cache_dir: Path | None = None) -> tuple[str, bytes]:
        bundle = self._bundle()
        return Path(bundle.net_name).name, bundle.files[bundle.net_name]


_BY_KIND: dict[str, Callable[[RoadSpec], RoadSource]] = {
    "straight": functools.partial(BuiltRoad, shape=StraightRoad),
    "curve": functools.partial(BuiltRoad, shape=CurveRoad),
    "sumo_net": NetworkFileRoad, "sumo_config": ConfigRoad, "opendrive": OpenDriveRoad}


def road_source(road: RoadSpec) -> RoadSource:
    """The source of ``road``, by its kind."""
    return _BY_KIND[road.kind](road)

