"""Finding a controller's class by its name, in any of the four forms of
``scenarios.spec.controller_ref``, and making one for a run.

A file controller is loaded from its bytes as a module of its own (named after
the file's hash, so two versions of a file never share a module); a module or
entry-point controller is imported the usual way. Every failure to find or
build one is a :class:`~scenarios.common.errors.SpecError` naming the field.
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.util
import sys
from importlib import metadata
from pathlib import Path
from typing import Any

from scenarios.common.errors import SpecError
from scenarios.spec.controller_ref import BUILTIN_CONTROLLERS, ENTRY_POINT_GROUP, controller_kind
from scenarios.spec.controller_spec import ControllerSpec
from sdc.car.controller_api import Controller


def _reason(e: BaseException) -> str:
    return f"{type(e).__name__}: {e}"


def _file_module(path: Path, field: str):
    try:
        source = path.read_bytes()
    except OSError as e:
        raise SpecError(field, f"cannot read {path} ({e.strerror or e})") from None
    name = f"sdc_controller_{hashlib.sha256(source).hexdigest()[:16]}"
    module = sys.modules.get(name)
    if module is None:
        spec = importlib.util.spec_from_file_location(name, path)
        module = importlib.util.module_from_spec(spec)
        try:
            exec(compile(source, str(path), "exec"), module.__dict__)
        except BaseException as e:  # noqa: BLE001 - any failure of the plug-in's own code
            if isinstance(e, KeyboardInterrupt):
                raise
            raise SpecError(field, f"importing {path} failed: {_reason(e)}") from None
        sys.modules[name] = module
    return module


def _import(module_name: str, field: str):
    try:
        return importlib.import_module(module_name)
    except BaseException as e:  # noqa: BLE001 - any failure of the plug-in's own code
        if isinstance(e, KeyboardInterrupt):
            raise
        raise SpecError(field, f"importing {module_name} failed: {_reason(e)}") from None


def _attribute(module, cls_name: str, where: str, field: str) -> type:
    cls = getattr(module, cls_name, None)
    if cls is None:
        raise SpecError(field, f"{where} has no class {cls_name!r}")
    if not isinstance(cls, type):
        raise SpecError(field, f"{where}:{cls_name} is a {type(cls).__name__}, not a class")
    return cls


def installed_controllers() -> dict[str, metadata.EntryPoint]:
    """The controllers installed packages register, by name."""
    return {ep.name: ep for ep in metadata.entry_points(group=ENTRY_POINT_GROUP)}


def controller_class(name: str, field: str = "controller.name") -> type:
    """The class ``name`` refers to."""
    kind = controller_kind(name)
    if kind == "builtin":  # where the registry says its class lives
        module_name, _, cls_name = BUILTIN_CONTROLLERS[name].controller.partition(":")
        return _attribute(_import(module_name, field), cls_name, module_name, field)
    if kind == "entry_point":
        entry = installed_controllers().get(name)
        if entry is None:
            installed = ", ".join(sorted(installed_controllers())) or "none"
            raise SpecError(field, f"unknown controller {name!r}: not a built-in "
                            f"({', '.join(BUILTIN_CONTROLLERS)}) nor an installed plug-in "
                            f"(entry points {ENTRY_POINT_GROUP}: {installed})")
        module_name, _, cls_name = entry.value.partition(":")
        where = f"entry point {name} ({entry.value})"
        return _attribute(_import(module_name, field), cls_name.strip(), where, field)
    target, _, cls_name = name.rpartition(":")
    if kind == "file":
        path = Path(target)
        if not path.is_file():
            raise SpecError(field, f"no controller file {path}")
        return _attribute(_file_module(path, field), cls_name, str(path), field)
    return _attribute(_import(target, field), cls_name, target, field)


def make_controller(spec: ControllerSpec, field: str = "controller.name") -> Controller:
    """A new controller for one run: its class built with the table's parameters.
    A constructor that raises is a :class:`SpecError` with its message."""
    cls = controller_class(spec.name, field)
    try:
        controller = cls(spec.plain_params())
    except SpecError:  # a built-in naming its bad parameter, controller.<field>
        raise
    except Exception as e:  # noqa: BLE001 - any failure of the plug-in's own code
        raise SpecError(field, f"{spec.label} could not be built: {_reason(e)}") from None
    if not callable(getattr(controller, "step", None)):
        raise SpecError(field, f"{spec.label} has no step(obs) method")
    return controller


def controller_source(name: str) -> dict:
    """Where a controller's code comes from, for the manifest: its form, and for a
    plug-in the file that defines the class with that file's sha256."""
    kind = controller_kind(name)
    source: dict[str, Any] = {"name": name, "kind": kind}
    if kind == "builtin":
        return source
    if kind == "file":  # its path is in the name: no need to load it
        path = Path(name.rpartition(":")[0])
    else:
        module = sys.modules.get(controller_class(name).__module__)
        path = Path(getattr(module, "__file__", "") or "")
    if path.is_file():
        source["file"] = str(path)
        source["sha256"] = hashlib.sha256(path.read_bytes()).hexdigest()
    if kind == "entry_point":
        entry = installed_controllers()[name]
        source["entry_point"] = entry.value
        source["distribution"] = (f"{entry.dist.name} {entry.dist.version}"
                                  if entry.dist is not None else None)
    return source
