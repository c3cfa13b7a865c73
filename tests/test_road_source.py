"""One road source per kind (scenarios/sumo_net/road_source.py): every kind answers the same
questions, the warm-state identity is the same whoever asks, and no module outside
the road's own asks a road its kind: a built road's shape is its geometry's class."""

from __future__ import annotations

import ast
import dataclasses
import re
from pathlib import Path

import pytest

from scenarios.common.errors import SpecError
from scenarios.common.file_read import file_sha256, sha256_hex
from scenarios.scene.road_geometry import CurveRoad, StraightRoad
from scenarios.spec.toml_io import load_spec
from scenarios.sumo.warm_state import uses_warm_state, warm_key, warm_state_key
from scenarios.sumo_net.build import build_network, input_path
from scenarios.sumo_net.net_xml import parse_net
from scenarios.sumo_net.road_source import BuiltRoad, ConfigRoad, NetworkFileRoad, road_source
from scenarios.sumo_net.sumo_config import load_bundle
from sdc.batch.tasks.job_files import FileCatalog

ROOT = Path(__file__).resolve().parents[1]
CATALOG = ROOT / "scenarios" / "catalog"
GRID = str(CATALOG / "networks" / "grid-4x4.net.xml")
SQUARE = "sumo:tools/game/square.sumocfg"


def spec_of(kind: str):
    """A spec of each road kind, with a warm-up."""
    base = load_spec(CATALOG / "highway-obstacle.toml")
    traffic = dataclasses.replace(base.traffic, warm_up_s=20.0)
    if kind == "straight":
        return dataclasses.replace(base, traffic=traffic)
    if kind == "sumo_net":
        road = dataclasses.replace(base.road, kind="sumo_net", net_file=GRID, lanes=None,
                                   length_m=200.0)
        traffic = dataclasses.replace(traffic, flow_vph_per_lane=0, vehicles=20)
        return dataclasses.replace(base, road=road, traffic=traffic, obstacles=())
    road = dataclasses.replace(base.road, kind="sumo_config", config_file=SQUARE, lanes=None,
                               length_m=300.0)
    traffic = dataclasses.replace(traffic, flow_vph_per_lane=0, warm_up_s=0.0, enter_s=30.0)
    return dataclasses.replace(base, road=road, traffic=traffic, obstacles=())


@pytest.mark.parametrize(("kind", "cls"), [("straight", BuiltRoad), ("sumo_net", NetworkFileRoad),
                                           ("sumo_config", ConfigRoad)])
def test_each_kind_has_one_source_and_one_warm_state_identity(kind, cls, tmp_path):
    spec = spec_of(kind)
    source = road_source(spec.road)
    assert type(source) is cls and source.road == spec.road
    assert uses_warm_state(spec)
    # the identity: a configuration's content, else the network file SUMO runs on
    if kind == "sumo_config":
        assert source.identity_sha256() == load_bundle(SQUARE).sha256
        assert source.configuration(spec) is load_bundle(SQUARE)
        entry = source.manifest_entry(spec.scenario.step_s)
        assert (entry["file"], entry["step_s"]) == (SQUARE, spec.scenario.step_s)
    else:
        assert source.identity_sha256(tmp_path) == file_sha256(source.network_file(tmp_path))
        assert source.configuration(spec) is None
        assert source.manifest_entry(spec.scenario.step_s) is None
    # a job ships the file the identity is of (a configuration: as one bundle)
    shipped = source.shipped(tmp_path)
    assert shipped.field == {"straight": "network", "sumo_net": "road.net_file",
                             "sumo_config": "road.config_file"}[kind]
    assert shipped.identity_sha256 == source.identity_sha256(tmp_path)
    if kind != "sumo_config":
        assert sha256_hex(shipped.data) == source.identity_sha256(tmp_path)
    assert (shipped.edges_key is None) == (kind == "straight")
    # the driver's catalog and a run agree on the warm state
    assert FileCatalog(tmp_path).warm_key(spec) == warm_state_key(spec, source, tmp_path)
    assert warm_state_key(spec, source, tmp_path) == warm_key(spec,
                                                              source.identity_sha256(tmp_path))


def test_a_warm_up_counts_from_its_road_s_clock():
    built, config = spec_of("straight"), spec_of("sumo_config")
    assert road_source(built.road).warm_up_steps(built) == round(20.0 / built.scenario.step_s)
    source = road_source(config.road)
    begin_s = load_bundle(SQUARE).begin_s
    assert source.warm_up_begin_s() == begin_s
    assert source.warm_up_steps(config) == max(1, round((30.0 - begin_s)
                                                        / config.scenario.step_s))
    early = dataclasses.replace(config, traffic=dataclasses.replace(config.traffic,
                                                                    enter_s=begin_s + 1e-6))
    assert source.warm_up_steps(early) == 1  # the demand departing at its begin is in
    assert {road_source(s.road).warm_up_field for s in (built, config)} == {"warm_up_s",
                                                                             "enter_s"}


def test_has_traffic_is_each_kinds_own_demand():
    built, net, config = (spec_of(k) for k in ("straight", "sumo_net", "sumo_config"))
    assert road_source(net.road).has_traffic(net.traffic)
    assert not road_source(net.road).has_traffic(dataclasses.replace(net.traffic, vehicles=0))
    assert road_source(config.road).has_traffic(config.traffic)  # its configuration's
    assert road_source(built.road).has_traffic(built.traffic) == (
        built.traffic.flow_vph_per_lane > 0)


#: where a road's kind may be named: the spec that defines the kinds (and its file
#: reader: a configuration's step length), and the one dispatch
KIND_HOMES = {"scenarios/spec/scenario_spec.py", "scenarios/spec/scenario_tables.py",
              "scenarios/spec/toml_io.py", "scenarios/sumo_net/road_source.py"}


def test_no_module_outside_the_roads_own_asks_a_road_its_kind():
    """Nor compares a kind's name, nor asks a geometry its class: a built road's shape
    is its geometry's own (a curve's curvature), a network road's network its source's."""
    asking = re.compile(r"\b(road|r)\.kind\b"
                        r"|kind\s*(==|!=|in)\s*\(?[\"'](straight|curve|sumo_net|sumo_config|opendrive)"
                        r"|isinstance\([^)]*(NetworkRoad|StraightRoad|CurveRoad)")
    found = [f"{p.relative_to(ROOT)}:{n}" for folder in ("sdc", "analysis", "scenarios")
             for p in sorted((ROOT / folder).rglob("*.py"))
             if str(p.relative_to(ROOT)) not in KIND_HOMES
             for n, line in enumerate(p.read_text().splitlines(), 1) if asking.search(line)]
    assert not found, found


@pytest.mark.parametrize(("kind", "shape"), [("straight", StraightRoad), ("curve", CurveRoad)])
def test_a_built_roads_geometry_is_of_its_shapes_class(kind, shape, tmp_path):
    """The kind picks the shape once (road_source); the geometry says the rest: a
    straight road does not turn, a curve turns at 1 / its radius."""
    base = spec_of("straight")
    road = dataclasses.replace(base.road, kind=kind,
                               curve_radius_m=None if kind == "straight" else -400.0)
    spec = dataclasses.replace(base, road=road)
    source = road_source(road)
    assert type(source) is BuiltRoad and source.shape is shape
    geometry = source.geometry(spec)
    assert type(geometry) is shape
    assert geometry.curvature_1pm == (0.0 if kind == "straight" else 1 / -400.0)
    assert source.network_file(tmp_path) == build_network(road, geometry, tmp_path)


def test_a_network_roads_network_is_its_sources_and_a_bad_file_names_its_field(tmp_path):
    net, config = spec_of("sumo_net"), spec_of("sumo_config")
    assert road_source(net.road).network().path == input_path(GRID)
    bundle = load_bundle(SQUARE)
    assert road_source(config.road).network().lanes.keys() == parse_net(
        bundle.files[bundle.net_name], Path(bundle.net_name)).lanes.keys()
    missing = dataclasses.replace(net.road, net_file=str(tmp_path / "none.net.xml"))
    with pytest.raises(SpecError, match="no such file") as raised:
        road_source(missing).network()
    assert raised.value.field == "road.net_file"


#: the modules a run goes through once it has its road source: it is handed to them
#: (obtained once where the run starts: ``sdc/run/episode.py``, ``sdc/run/shared_world.py``,
#: the warm-up child's ``main``), never asked for again. The door (``world_backends.py``)
#: obtains one in one place only, for a caller that hands it a spec alone.
PER_RUN_SOURCE_CALLS = {"scenarios/world_backends.py": 1, "scenarios/sumo/sumo_world.py": 0,
                        "scenarios/sumo/routes_xml.py": 0, "scenarios/sumo/warm_state.py": 0,
                        "scenarios/sumo/warm_up.py": 0, "scenarios/sumo/warm_up_child.py": 1}


def _road_source_calls(path: Path) -> list[int]:
    """The lines where ``path`` calls ``road_source(...)`` (by name or attribute)."""
    return [node.lineno for node in ast.walk(ast.parse(path.read_text()))
            if isinstance(node, ast.Call)
            and (getattr(node.func, "id", None) == "road_source"
                 or getattr(node.func, "attr", None) == "road_source")]


def test_a_run_obtains_its_road_source_once_and_hands_it_down():
    found = {name: lines for name, most in PER_RUN_SOURCE_CALLS.items()
             if len(lines := _road_source_calls(ROOT / name)) > most}
    assert not found, f"road_source(...) called again on a run's way (file: lines): {found}"
