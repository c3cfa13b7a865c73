"""Scenario specs from and to TOML files (reading with the standard ``tomllib``)."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path
from typing import Any

from scenarios.errors import SpecError
from scenarios.scenario_spec import ScenarioSpec


def read_toml(path: str | Path) -> dict:
    """Parse a TOML file; a missing file or a syntax error is a :class:`SpecError`."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as e:
        raise SpecError("", f"cannot read {path}: {e.strerror or e}") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise SpecError("", f"{path}: invalid TOML: {e}") from None


def load_spec(path: str | Path) -> ScenarioSpec:
    """The scenario in a TOML file; a relative ``road.net_file`` is taken from the
    file's folder (and kept absolute, so the spec runs from anywhere)."""
    data = read_toml(path)
    road = data.get("road")
    if isinstance(road, dict) and isinstance(road.get("net_file"), str) and road["net_file"]:
        road["net_file"] = str((Path(path).parent / road["net_file"]).resolve())
    return ScenarioSpec.from_plain(data)


def _value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | float):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)  # a JSON string is a valid TOML basic string
    if isinstance(value, list):
        return "[" + ", ".join(_value(v) for v in value) + "]"
    raise TypeError(f"cannot write {type(value).__name__} to TOML")


def dumps_plain(plain: dict) -> str:
    """TOML text for a mapping of tables and arrays of tables (one level deep)."""
    lines: list[str] = []
    for table, body in plain.items():
        bodies = body if isinstance(body, list) else [body]
        header = f"[[{table}]]" if isinstance(body, list) else f"[{table}]"
        for item in bodies:
            lines.append(header)
            lines.extend(f"{key} = {_value(value)}" for key, value in item.items())
            lines.append("")
    return "\n".join(lines)


def dumps_spec(spec: ScenarioSpec) -> str:
    return dumps_plain(spec.to_plain())
