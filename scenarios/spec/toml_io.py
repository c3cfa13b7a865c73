"""Scenario specs from and to TOML files (reading with the standard ``tomllib``)."""

from __future__ import annotations

import json
import os
import tomllib
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from scenarios.common.errors import FileError, SpecError
from scenarios.common.file_read import read_text
from scenarios.spec.controller_ref import resolve_file
from scenarios.spec.overrides import apply_overrides, blame
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.spec.scenario_tables import SUMO_HOME_PREFIX, ScenarioMeta
from scenarios.spec.spec_fields import build


def read_toml(path: str | Path, what: str = "the TOML file") -> dict:
    """Parse a TOML file; a file that cannot be read or parsed is a :class:`FileError`."""
    text = read_text(path, what)
    try:
        return tomllib.loads(text)
    except (tomllib.TOMLDecodeError, RecursionError) as e:
        raise FileError(path, f"{what} is invalid TOML ({e})") from None


def _resolved(path: Path, spec_path: str | Path, field: str) -> str:
    try:
        return str(path.resolve())
    except (OSError, ValueError, RuntimeError) as e:  # a NUL byte, a symlink loop
        raise SpecError(field, f"is not a usable path ({e})", spec_path) from None


#: the road's fields that name a file, relative to the scenario file's folder
_FILE_FIELDS = ("net_file", "config_file", "xodr_file")


def load_spec(path: str | Path, overrides: Sequence[str] = ()) -> ScenarioSpec:
    """The scenario in a TOML file, changed by ``overrides`` (``PATH=VALUE``, as if
    the file said so: ``scenarios/spec/overrides.py``); a relative ``road.net_file``,
    ``road.config_file`` or controller file is taken from the file's folder (and kept
    absolute, so the spec runs from anywhere); ``sumo:<path>`` is inside SUMO's
    installation. On a ``sumo_config`` road without ``scenario.step_s`` the step is the
    one the configuration asks for (its ``step-length``), where it asks one. Every
    error names the file, or the override it is about."""
    data = read_toml(path, "the scenario file")
    changes = apply_overrides(data, overrides)
    try:
        road = data.get("road")
        for name in _FILE_FIELDS:
            value = road.get(name) if isinstance(road, dict) else None
            if isinstance(value, str) and value and not value.startswith(SUMO_HOME_PREFIX):
                road[name] = _resolved(Path(path).parent / value, path, f"road.{name}")
        _config_step(data)
        controller = data.get("controller")
        if isinstance(controller, dict) and "name" in controller:
            controller["name"] = resolve_file(controller["name"], Path(path).parent,
                                              "controller.name")
        return ScenarioSpec.from_plain(data)
    except SpecError as e:
        raise blame(e, changes, path) from None


def written_path(path: str | Path, folder: str | Path) -> str:
    """``path`` as a file in ``folder`` names it: relative to the folder, unless its
    absolute path is shorter (a file far away)."""
    try:
        relative = os.path.relpath(path, Path(folder).resolve())
    except ValueError:  # another drive
        return str(path)
    return min(relative, str(path), key=len)


def as_written(error: SpecError, spec: ScenarioSpec, path: str | Path) -> SpecError:
    """``error``, about a file ``spec`` names (its network), as the scenario file ``path``
    it was loaded from writes it: naming that file and the field, the network's path
    relative to its folder rather than as :func:`load_spec` resolved it."""
    named = {value: f"road.{name}" for name in _FILE_FIELDS
             if (value := getattr(spec.road, name)) and not value.startswith(SUMO_HOME_PREFIX)}
    field, message = error.field, error.message
    if error.file is not None:  # a file's own error (the network's: its field names it)
        field, message = named.get(error.file, field), f"{error.file}: {message}"
    for value in named:
        message = message.replace(value, written_path(value, Path(path).parent))
    return SpecError(field, message, path)


def _config_step(data: dict) -> None:
    """Set ``scenario.step_s`` of a ``sumo_config`` road's spec that leaves it out to
    the step length its configuration asks for (none asked: the spec's default)."""
    from scenarios.sumo_net.sumo_config import config_step_s

    road, meta = data.get("road"), data.get("scenario")
    if not (isinstance(road, dict) and isinstance(meta, dict) and "step_s" not in meta
            and road.get("kind") == "sumo_config" and isinstance(road.get("config_file"), str)):
        return
    asked = config_step_s(road["config_file"])
    if asked is None:
        return
    try:
        build(ScenarioMeta, {**meta, "step_s": asked}, "scenario")
    except SpecError as e:
        try:
            build(ScenarioMeta, meta, "scenario")
        except SpecError:
            return  # the table's own fields are wrong: from_plain names them
        raise SpecError("scenario.step_s", f"the configuration asks a step-length of "
                        f"{asked:g} s, which a run cannot take ({e}); set "
                        "scenario.step_s") from None
    meta["step_s"] = asked


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
