"""How a scenario names its controller: the forms of ``[controller] name``.

- a built-in name (:data:`BUILTIN_CONTROLLERS`);
- ``path/to/file.py:ClassName``: a class in a Python file (a relative path is
  taken from the scenario or sweep file's folder, or from the working directory
  on the command line, and kept absolute);
- ``package.module:ClassName``: a class in an importable module;
- any other plain name: one registered by an installed package under the
  entry-point group ``sdc.controllers``.

This module only parses and labels the names; ``sdc.car.controller_plugins``
loads them. No import happens here.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Literal, NamedTuple

from scenarios.common.errors import SpecError

ENTRY_POINT_GROUP = "sdc.controllers"


class Builtin(NamedTuple):
    """A built-in controller, as the registry holds it: where its class lives and the
    spec class of its parameters. Names only: nothing is imported here."""

    controller: str  # "package.module:ClassName" (``sdc.car.controller_plugins`` imports it)
    params: str  # its parameters' class in ``scenarios.spec.scenario_spec`` (validated there)


#: the built-in controllers, the one registry: adding one is adding its line here
#: (``controller_params.CONTROLLER_PARAMS`` and ``sdc.car.controller_plugins`` read it)
BUILTIN_CONTROLLERS: dict[str, Builtin] = {
    "seed": Builtin("sdc.car.controllers:SeedController", "SeedParams"),
    "lane-keep": Builtin("sdc.car.controllers:LaneKeepController", "LaneKeepParams"),
    "avoid": Builtin("sdc.car.avoid.controller:AvoidController", "AvoidParams"),
}

Kind = Literal["builtin", "file", "module", "entry_point"]
_IDENTIFIER = r"[A-Za-z_][A-Za-z0-9_]*"
_MODULE_REF = re.compile(rf"^{_IDENTIFIER}(\.{_IDENTIFIER})*:{_IDENTIFIER}$")
_ENTRY_POINT = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.\-]*$")
_LABEL = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_\-]*$")


def controller_kind(name: str) -> Kind:
    """Which of the four forms ``name`` takes (see the module's doc)."""
    if name in BUILTIN_CONTROLLERS:
        return "builtin"
    if ":" in name:
        target, _, cls = name.rpartition(":")
        return "file" if target.endswith(".py") or "/" in target else "module"
    return "entry_point"


def check_name(name: object, field: str) -> str:
    """``name`` if it is a well-formed controller name, else a :class:`SpecError`."""
    if not isinstance(name, str) or not name:
        raise SpecError(field, f"must be a controller name, got {name!r}")
    kind = controller_kind(name)
    if kind == "file":
        target, _, cls = name.rpartition(":")
        if not target.endswith(".py") or not re.fullmatch(_IDENTIFIER, cls):
            raise SpecError(field, f"{name!r}: a file controller is written "
                            "'path/to/file.py:ClassName'")
    elif kind == "module" and not _MODULE_REF.match(name):
        raise SpecError(field, f"{name!r}: a module controller is written "
                        "'package.module:ClassName'")
    elif kind == "entry_point" and not _ENTRY_POINT.match(name):
        raise SpecError(field, f"unknown controller {name!r}: not a built-in "
                        f"({', '.join(BUILTIN_CONTROLLERS)}), 'file.py:Class', "
                        f"'package.module:Class' or an installed plug-in's name")
    return name


def resolve_file(name: str, base_dir: Path, field: str) -> str:
    """``name`` with a file controller's path made absolute from ``base_dir``
    (other forms unchanged)."""
    check_name(name, field)
    if controller_kind(name) != "file":
        return name
    target, _, cls = name.rpartition(":")
    try:
        path = (Path(base_dir) / target).resolve()
    except (OSError, ValueError, RuntimeError) as e:  # a NUL byte, a symlink loop
        raise SpecError(field, f"{target!r} is not a usable path ({e})") from None
    return f"{path}:{cls}"


def controller_label(name: str) -> str:
    """The short name a controller goes by in run IDs and result rows: the name
    itself, or the class name of a file or module controller."""
    label = name.rpartition(":")[2] if ":" in name else name
    return label if _LABEL.match(label) else re.sub(r"[^A-Za-z0-9_\-]", "_", label)
