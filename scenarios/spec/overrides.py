"""One-off changes to a spec file, ``--set PATH=VALUE``: set in the file's plain TOML
data before it is validated, so every rule that checks a file checks them, and an
error about a field one set names the option, not the file.

``PATH`` addresses a field as a sweep parameter does (``ego.speed_mps``,
``obstacles[0].lane``, ``controller.look_ahead_m``); a table the file leaves out is
added. In a sweep file ``sweep.<key>`` is its own ``[sweep]`` table's and
``sweep.params.<path>`` one parameter's distribution (the rest of the path is the
parameter's, one key); any other path is its base scenario's
(``scenarios/spec/sweep_spec.py``, ``load_sweep``). ``VALUE`` is a TOML value (``9``,
``2.5``, ``true``, ``"curve"``, ``["a", "b"]``, ``{ uniform = [2.0, 9.0] }``); text
that is not one is taken as a string, so ``controller.name=avoid`` needs no shell
quoting.
"""

from __future__ import annotations

import dataclasses
import tomllib
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

from scenarios.common.errors import OptionError, SpecError
from scenarios.spec.spec_fields import join, parse_path

OPTION = "--set"
#: the sweep file's table of parameters: under it, the rest of a path is one key
SWEEP_PARAMS = "sweep.params"


def toml_value(text: str) -> Any:
    """``text`` as a TOML value; text that is not one value is the string itself."""
    try:
        parsed = tomllib.loads(f"value = {text}")
    except tomllib.TOMLDecodeError:
        return text
    return parsed["value"] if len(parsed) == 1 else text


@dataclasses.dataclass(frozen=True)
class Override:
    """One ``--set``: its text as given, the path and the value."""

    text: str
    path: str
    value: Any

    @classmethod
    def parse(cls, text: str) -> Override:
        path, equals, value = text.partition("=")
        override = cls(text, path.strip(), toml_value(value.strip()))
        if not equals or not override.path:
            raise override.error("expected PATH=VALUE, e.g. ego.speed_mps=9")
        override.keys()  # a malformed path is refused here
        return override

    def keys(self) -> list[tuple[str, int | None]]:
        """The path's keys and indices (a sweep parameter's path one key)."""
        param = self._sweep_param
        try:
            return ([*parse_path(SWEEP_PARAMS), (param, None)] if param is not None
                    else parse_path(self.path))
        except ValueError as e:
            raise self.error(str(e)) from None

    @property
    def _sweep_param(self) -> str | None:
        head, dot, param = self.path.partition(f"{SWEEP_PARAMS}.")
        return param if dot and not head else None

    @property
    def table(self) -> str:
        """The top-level table the path starts in (``sweep``: a sweep file's own)."""
        return self.keys()[0][0]

    @property
    def field(self) -> str:
        """The path as an error names the field (a sweep parameter's quoted)."""
        param = self._sweep_param
        return self.path if param is None else f'{SWEEP_PARAMS}."{param}"'

    def error(self, message: str) -> OptionError:
        return OptionError(f"{OPTION} {self.text}", message)

    def value_in(self, plain: dict) -> Any:
        """The value at the path in a spec's plain data (``ScenarioSpec.to_plain``: as
        the spec holds it, ``9`` as ``9.0``), else the value set."""
        node: Any = plain
        for name, index in self.keys():
            if not isinstance(node, dict) or name not in node:
                return self.value
            node = node[name]
            if index is not None:
                if not isinstance(node, list) or index >= len(node):
                    return self.value
                node = node[index]
        return node

    def apply(self, data: dict) -> None:
        """Set the value in a file's plain data, in place."""
        node: Any = data
        where = ""
        keys = self.keys()
        for depth, (name, index) in enumerate(keys, start=1):
            if not isinstance(node, dict):
                raise self.error(f"{where} is not a table")
            last = depth == len(keys)
            if index is None:
                if last:
                    node[name] = self.value
                    return
                node = node.setdefault(name, {})
            else:
                items = node.get(name)
                count = len(items) if isinstance(items, list) else 0
                if index >= count:
                    raise self.error(f"{join(where, name)}[{index}] does not exist: the file "
                                     f"has {count} [[{join(where, name)}]]")
                if last:
                    items[index] = self.value
                    return
                node = items[index]
            where = join(where, name if index is None else f"{name}[{index}]")


def apply_overrides(data: dict, texts: Iterable[str]) -> tuple[Override, ...]:
    """Set each of ``texts`` (``PATH=VALUE``) in ``data``, in order; the overrides."""
    overrides = tuple(Override.parse(text) for text in texts)
    for override in overrides:
        override.apply(data)
    return overrides


def _on_path(field: str, path: str) -> bool:
    """Is ``field`` the field ``path`` names, inside it, or a table on its way?"""
    def within(inner: str, outer: str) -> bool:
        return inner == outer or inner.startswith((f"{outer}.", f"{outer}["))

    return bool(field) and (within(field, path) or within(path, field))


def blame(error: SpecError, overrides: Sequence[Override], file: str | Path) -> SpecError:
    """``error``, raised reading ``file`` changed by ``overrides``: the option's when it is
    about a field one of them set (or a table on its path), else the file's, saying
    which options it was read with (an error an option made is left as it is)."""
    if isinstance(error, OptionError):
        return error
    for override in overrides:
        if _on_path(error.field, override.field):
            return override.error(error.message if error.field == override.field
                                  else f"{error.field}: {error.message}")
    if not overrides or error.file not in (None, str(file)):
        return error.in_file(file)
    given = " ".join(f"{OPTION} {override.text}" for override in overrides)
    return SpecError(error.field, f"{error.message} (with {given})", file)
