"""Where the cache lives: SDC_CACHE_DIR, else XDG_CACHE_HOME/sdc, else ~/.cache/sdc."""

from __future__ import annotations

from pathlib import Path

import pytest

from scenarios.common.cache_dir import network_cache_dir, sdc_cache_dir
from scenarios.spec.scenario_tables import RoadSpec
from scenarios.sumo_net.road_source import road_source


@pytest.fixture
def home(tmp_path, monkeypatch) -> Path:
    """A home of its own, and neither variable set."""
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    monkeypatch.delenv("SDC_CACHE_DIR", raising=False)
    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
    return tmp_path / "home"


def test_without_either_variable_the_cache_is_under_the_home(home, monkeypatch):
    assert sdc_cache_dir() == home / ".cache" / "sdc"
    assert network_cache_dir() == home / ".cache" / "sdc" / "networks"
    monkeypatch.setenv("XDG_CACHE_HOME", "")  # empty is unset
    assert sdc_cache_dir() == home / ".cache" / "sdc"


def test_xdg_cache_home_when_absolute(home, tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert sdc_cache_dir() == tmp_path / "xdg" / "sdc"
    assert network_cache_dir() == tmp_path / "xdg" / "sdc" / "networks"
    monkeypatch.setenv("XDG_CACHE_HOME", "relative/cache")  # the XDG spec: ignore it
    assert sdc_cache_dir() == home / ".cache" / "sdc"


def test_sdc_cache_dir_overrides_both(home, tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    monkeypatch.setenv("SDC_CACHE_DIR", str(tmp_path / "mine"))
    assert sdc_cache_dir() == tmp_path / "mine"
    assert network_cache_dir() == tmp_path / "mine" / "networks"


def test_networks_are_built_where_the_environment_says_at_the_time(home, tmp_path, monkeypatch):
    road = RoadSpec(length_m=120.0, lanes=2)
    monkeypatch.setenv("SDC_CACHE_DIR", str(tmp_path / "first"))
    first = road_source(road).network_file()
    monkeypatch.setenv("SDC_CACHE_DIR", str(tmp_path / "second"))
    second = road_source(road).network_file()
    assert first.parent == tmp_path / "first" / "networks" and first.is_file()
    assert second.parent == tmp_path / "second" / "networks" and second.is_file()
    assert first.name == second.name  # the same network, named by its content
    assert not home.exists()
