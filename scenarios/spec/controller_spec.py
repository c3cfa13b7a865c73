"""The ``[controller]`` table: the controller's name and its parameters, a built-in's
checked into its params class, a plug-in's kept as plain values."""

from __future__ import annotations

import dataclasses
import json
import math
from typing import Any

from scenarios.common.errors import SpecError
from scenarios.spec.controller_params import (
    CONTROLLER_PARAMS,
    DEFAULT_LOOK_AHEAD_M,
    AvoidParams,
    LaneKeepParams,
    SeedParams,
)
from scenarios.spec.controller_ref import check_name, controller_label
from scenarios.spec.spec_fields import build, to_plain


def _check_plain(value: Any, field: str) -> None:
    """A plug-in's parameter must be plain data (numbers, strings, booleans, and
    lists and tables of them): what a manifest and a plan can hold."""
    if isinstance(value, dict):
        for key, item in value.items():
            _check_plain(item, f"{field}.{key}")
    elif isinstance(value, list):
        for i, item in enumerate(value):
            _check_plain(item, f"{field}[{i}]")
    elif isinstance(value, float) and not math.isfinite(value):
        raise SpecError(field, f"must be a finite number, got {value!r}")
    elif not isinstance(value, str | int | float | bool):
        raise SpecError(field, f"must be a number, string, boolean, array or table, "
                        f"got {type(value).__name__}")


@dataclasses.dataclass(frozen=True)
class ControllerSpec:
    """The ``[controller]`` table: a name (see ``scenarios.spec.controller_ref``) and the
    parameters. A built-in's parameters are validated here, into its params class;
    a plug-in's are kept as the plain TOML values, for its constructor to judge."""

    name: str
    params: LaneKeepParams | AvoidParams | dict

    @classmethod
    def from_plain(cls, data: Any, path: str = "controller") -> ControllerSpec:
        if not isinstance(data, dict):
            raise SpecError(path, f"must be a table, got {type(data).__name__}")
        name = check_name(data.get("name", "seed"), f"{path}.name")
        params = {k: v for k, v in data.items() if k != "name"}
        if name in CONTROLLER_PARAMS:
            return cls(name, build(CONTROLLER_PARAMS[name], params, path))
        for key, value in params.items():
            _check_plain(value, f"{path}.{key}")
        return cls(name, params)

    @property
    def builtin(self) -> bool:
        return self.name in CONTROLLER_PARAMS

    @property
    def label(self) -> str:
        """The short name in run IDs and result rows (``controller_label``)."""
        return controller_label(self.name)

    def plain_params(self) -> dict:
        """The parameters as plain values: what the controller's constructor gets."""
        if isinstance(self.params, dict):
            return json.loads(json.dumps(self.params))  # a deep copy the plug-in may keep
        return to_plain(self.params)

    def to_plain(self) -> dict:
        return {"name": self.name, **self.plain_params()}

    @property
    def look_ahead_m(self) -> float:
        """Where the lane reading's preview offset is taken, ahead of the body centre."""
        value = (self.params.get("look_ahead_m") if isinstance(self.params, dict)
                 else self.params.look_ahead_m)
        return float(value) if isinstance(value, int | float) else DEFAULT_LOOK_AHEAD_M

    @property
    def detect_beams(self) -> int:
        """The central beams the seed controller watches (the lesson's 11 for the others):
        their shortest range is the detection range in metrics and drawings."""
        value = getattr(self.params, "detect_beams", None)
        return value if isinstance(value, int) else SeedParams().detect_beams

    def takes(self, name: str, field: str) -> bool:
        """Does the controller ``name``, in a sweep of this base controller, take the
        parameter ``field``? A built-in when its params class has the field, a
        plug-in when it is this one."""
        if name in CONTROLLER_PARAMS:
            return field in {f.name for f in dataclasses.fields(CONTROLLER_PARAMS[name])}
        return name == self.name

    def renamed(self, name: str, values: dict[str, Any] | None = None) -> ControllerSpec:
        """The controller ``name`` with those of this one's parameters it takes (see
        :meth:`takes`), then the swept ``values`` (field -> value) it takes."""
        if name == self.name and not values:
            return self
        merged = {**self.plain_params(), **(values or {})}
        return ControllerSpec.from_plain(
            {"name": name, **{k: v for k, v in merged.items() if self.takes(name, k)}})
