"""Typed, range-checked frozen dataclasses built from plain mappings (TOML tables).

A spec class derives from :class:`Spec` and declares its fields with :func:`num`
for bounds. Constructing one checks every field's type and range and raises
:class:`SpecError` naming the field; :func:`build` adds the path of the table
(``obstacles[0].lane``) and rejects unknown or missing keys.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import re
import types
import typing
from collections.abc import Mapping
from typing import Any, Literal

from scenarios.common.errors import SpecError


def num(default: Any = dataclasses.MISSING, *, gt=None, ge=None, lt=None, le=None):
    """A numeric field with optional bounds (``gt`` ``ge`` ``lt`` ``le``)."""
    bounds = {k: v for k, v in {"gt": gt, "ge": ge, "lt": lt, "le": le}.items() if v is not None}
    return dataclasses.field(default=default, metadata={"bounds": bounds})


_BOUND_CHECKS = {
    "gt": (lambda v, b: v > b, "must be > {b}"),
    "ge": (lambda v, b: v >= b, "must be >= {b}"),
    "lt": (lambda v, b: v < b, "must be < {b}"),
    "le": (lambda v, b: v <= b, "must be <= {b}"),
}


def _type_name(tp) -> str:
    if typing.get_origin(tp) is Literal:
        return " | ".join(repr(a) for a in typing.get_args(tp))
    return getattr(tp, "__name__", str(tp))


def _coerce(value: Any, tp) -> Any:
    """Return ``value`` as type ``tp`` or raise ``ValueError`` with what was expected."""
    origin = typing.get_origin(tp)
    if origin in (types.UnionType, typing.Union):
        options = typing.get_args(tp)
        if value is None and type(None) in options:
            return None
        (inner,) = [a for a in options if a is not type(None)]
        return _coerce(value, inner)
    if origin is tuple:  # tuple[X, ...]: a list of X
        (inner, _) = typing.get_args(tp)
        if not isinstance(value, list | tuple) or not value:
            raise ValueError(f"must be a non-empty list, got {value!r}")
        return tuple(_coerce(item, inner) for item in value)
    if origin is Literal:
        if value not in typing.get_args(tp) or isinstance(value, bool):
            raise ValueError(f"must be one of {_type_name(tp)}, got {value!r}")
        return value
    if tp is bool:
        if not isinstance(value, bool):
            raise ValueError(f"must be true or false, got {value!r}")
        return value
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ValueError(f"must be an integer, got {value!r}")
        return value
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ValueError(f"must be a number, got {value!r}")
        if not math.isfinite(value):
            raise ValueError(f"must be finite, got {value!r}")
        return float(value)
    if tp is str:
        if not isinstance(value, str) or not value:
            raise ValueError(f"must be a non-empty string, got {value!r}")
        return value
    if isinstance(tp, type) and isinstance(value, tp):
        return value
    raise ValueError(f"must be {_type_name(tp)}, got {type(value).__name__}")


@functools.cache
def _field_types(cls: type) -> dict[str, Any]:
    """A spec class's field types, its string annotations evaluated once a process."""
    return typing.get_type_hints(cls)


class Spec:
    """Mixin for frozen spec dataclasses: checks types and bounds on construction."""

    def __post_init__(self):
        hints = _field_types(type(self))
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            try:
                value = _coerce(value, hints[f.name])
            except ValueError as e:
                raise SpecError(f.name, str(e)) from None
            object.__setattr__(self, f.name, value)
            if value is None:
                continue
            for kind, bound in f.metadata.get("bounds", {}).items():
                ok, message = _BOUND_CHECKS[kind]
                if not ok(value, bound):
                    raise SpecError(f.name, f"{message.format(b=bound)}, got {value!r}")


def join(path: str, name: str) -> str:
    return f"{path}.{name}" if path else name


_SEGMENT = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*)(?:\[(\d+)\])?$")


def parse_path(path: str) -> list[tuple[str, int | None]]:
    """A field's path as a sweep parameter and ``--set`` address it:
    ``"obstacles[0].kind"`` -> ``[("obstacles", 0), ("kind", None)]``."""
    segments = []
    for part in path.split("."):
        match = _SEGMENT.match(part)
        if match is None:
            raise ValueError(f"bad path segment {part!r} (expected name or name[index])")
        name, index = match.groups()
        segments.append((name, None if index is None else int(index)))
    return segments


def build(cls, data: Any, path: str, **nested):
    """Construct spec class ``cls`` from mapping ``data`` found at ``path``.

    ``nested`` holds already-built values for fields that are themselves specs.
    """
    if not isinstance(data, Mapping):
        raise SpecError(path, f"must be a table, got {type(data).__name__}")
    names = {f.name for f in dataclasses.fields(cls)}
    for key in data:
        if key not in names:
            raise SpecError(join(path, key), f"unknown key (known: {', '.join(sorted(names))})")
    for f in dataclasses.fields(cls):
        missing = f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
        if missing and f.name not in data and f.name not in nested:
            raise SpecError(join(path, f.name), "is required")
    try:
        return cls(**{**data, **nested})
    except SpecError as e:
        raise SpecError(join(path, e.field), e.message) from None


def to_plain(spec) -> dict:
    """The spec as a plain dict of TOML-able values (``None`` fields left out)."""
    out = {}
    for f in dataclasses.fields(spec):
        value = getattr(spec, f.name)
        if value is None:
            continue
        if dataclasses.is_dataclass(value):
            value = to_plain(value)
        elif isinstance(value, tuple):
            value = [to_plain(v) if dataclasses.is_dataclass(v) else v for v in value]
        out[f.name] = value
    return out
