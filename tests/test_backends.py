"""A backend's abilities are asked of it (scenarios/spec/backends.py), never found by
comparing its name: only the door that builds its world names one."""

from __future__ import annotations

import re
import typing
from pathlib import Path

import pytest

from scenarios.common.errors import SpecError
from scenarios.spec.backends import BACKENDS
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.spec.scenario_tables import ScenarioMeta

ROOT = Path(__file__).resolve().parents[1]
#: a comparison with a backend's name: `backend == "sumo"`, `"highway" != ...backend`
NAMES = "|".join(BACKENDS)
NAME_TEST = re.compile(r"""backend\s*(?:==|!=|in|not in)\s*[("'\[]"""
                       rf"""|["'](?:{NAMES})["']\s*(?:==|!=|in|not in)\s*\S*backend""")
#: the door that builds each backend's world, by its name
DOORS = {ROOT / "scenarios" / "world_backends.py"}


def test_every_backend_a_spec_may_name_has_its_abilities_and_no_other():
    assert set(typing.get_args(typing.get_type_hints(ScenarioMeta)["backend"])) == set(BACKENDS)


def test_no_module_outside_the_door_compares_a_backends_name():
    found = [f"{path.relative_to(ROOT)}:{n}: {line.strip()}"
             for folder in ("sdc", "scenarios", "analysis")
             for path in sorted((ROOT / folder).rglob("*.py")) if path not in DOORS
             for n, line in enumerate(path.read_text().splitlines(), 1)
             if NAME_TEST.search(line)]
    assert found == []


def test_the_name_test_finds_each_way_of_comparing(tmp_path):
    for line in ('if spec.scenario.backend == "sumo":', "x = backend != 'highway'",
                 'if "scripted" == spec.scenario.backend:', 'ok = backend in ("sumo",)'):
        assert NAME_TEST.search(line), line
    assert not NAME_TEST.search("if spec.scenario.world_backend.warm_states:")


@pytest.mark.parametrize("backend", sorted(BACKENDS))
def test_a_network_road_runs_only_where_its_backend_loads_networks(lesson_plain, backend):
    plain = {**lesson_plain, "scenario": {**lesson_plain["scenario"], "backend": backend},
             "road": {"kind": "sumo_net", "net_file": "town.net.xml", "length_m": 200.0}}
    if BACKENDS[backend].loads_networks:
        assert ScenarioSpec.from_plain(plain).scenario.world_backend is BACKENDS[backend]
    else:
        with pytest.raises(SpecError, match="scenario.backend"):
            ScenarioSpec.from_plain(plain)
