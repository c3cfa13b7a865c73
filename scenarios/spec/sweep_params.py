"""A sweep's parameters: each a path into the scenario and a distribution
(:class:`Param`), parsed and checked from ``[sweep.params]``; the value a path
names in a spec read, and set in a spec's plain data."""

from __future__ import annotations

import dataclasses
import math
from statistics import NormalDist
from typing import Any, Literal

import numpy as np

from scenarios.common.errors import SpecError
from scenarios.spec.controller_params import CONTROLLER_PARAMS
from scenarios.spec.controller_spec import ControllerSpec
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.spec.spec_fields import parse_path


def _field_names(obj: Any) -> set[str]:
    if isinstance(obj, ControllerSpec):  # any built-in's parameters, a plug-in's own, the name
        own = set(obj.params) if isinstance(obj.params, dict) else set()
        return {"name"} | own | {f.name for p in CONTROLLER_PARAMS.values()
                                 for f in dataclasses.fields(p)}
    return {f.name for f in dataclasses.fields(obj)}


def _field_value(obj: Any, name: str) -> Any:
    if isinstance(obj, ControllerSpec) and name != "name":
        params = obj.params
        return params.get(name) if isinstance(params, dict) else getattr(params, name, None)
    return getattr(obj, name, None)


def check_path(spec: ScenarioSpec, path: str) -> Any:
    """The value ``path`` names in ``spec``; ``ValueError`` unless it names a single one."""
    obj: Any = spec
    segments = parse_path(path)
    for depth, (name, index) in enumerate(segments):
        where = ".".join(f"{n}" if i is None else f"{n}[{i}]" for n, i in segments[:depth])
        if not dataclasses.is_dataclass(obj) or name not in _field_names(obj):
            known = ", ".join(sorted(_field_names(obj))) if dataclasses.is_dataclass(obj) else ""
            raise ValueError(f"no field {name!r} in {where or 'the scenario'}"
                             + (f" (known: {known})" if known else ""))
        obj = _field_value(obj, name)
        if index is not None:
            if not isinstance(obj, tuple):
                raise ValueError(f"{name} is not a list")
            if index >= len(obj):
                raise ValueError(f"{name}[{index}] does not exist: the base has {len(obj)}")
            obj = obj[index]
    if dataclasses.is_dataclass(obj) or isinstance(obj, tuple):
        raise ValueError("names a table; address one of its fields")
    return obj


def set_path(plain: dict, path: str, value: Any) -> None:
    """Set the value at ``path`` in a scenario's plain mapping (in place)."""
    *parents, (leaf, leaf_index) = parse_path(path)
    node: Any = plain
    for name, index in parents:
        node = node.setdefault(name, {})
        if index is not None:
            node = node[index]
    if leaf_index is None:
        node[leaf] = value
    else:
        node[leaf][leaf_index] = value


@dataclasses.dataclass(frozen=True)
class Param:
    """One swept parameter: a path and a distribution with its arguments."""

    path: str
    kind: Literal["uniform", "loguniform", "normal", "int_range", "choice"]
    args: tuple

    def at(self, u: float) -> Any:
        """The parameter's value at quantile ``u`` in [0, 1) (the inverse CDF)."""
        a = self.args
        if self.kind == "uniform":
            return float(a[0] + u * (a[1] - a[0]))
        if self.kind == "loguniform":
            return float(math.exp(math.log(a[0]) + u * (math.log(a[1]) - math.log(a[0]))))
        if self.kind == "normal":
            return float(NormalDist(a[0], a[1]).inv_cdf(min(max(u, 1e-12), 1 - 1e-12)))
        if self.kind == "int_range":  # any size of range (len() stops at 2**63)
            count = a[1] - a[0] + 1
            return a[0] + min(int(u * count), count - 1)
        return a[min(int(u * len(a)), len(a) - 1)]

    def quantile_of(self, value: Any) -> float:
        """The quantile in [0, 1] where :meth:`at` gives ``value`` (a discrete value: the
        middle of its share), to place values of different units on one scale."""
        a = self.args
        if self.kind == "uniform":
            return (value - a[0]) / (a[1] - a[0])
        if self.kind == "loguniform":
            return math.log(value / a[0]) / math.log(a[1] / a[0])
        if self.kind == "normal":
            return NormalDist(a[0], a[1]).cdf(value)
        if self.kind == "int_range":
            return (value - a[0] + 0.5) / (a[1] - a[0] + 1)
        return (a.index(value) + 0.5) / len(a)

    @property
    def continuous(self) -> bool:
        return self.kind in ("uniform", "loguniform", "normal")

    def grid_size(self, levels: int) -> int:
        """How many values :meth:`grid` takes (without making them)."""
        if self.kind == "int_range":
            return self.args[1] - self.args[0] + 1
        return levels if self.kind in ("uniform", "loguniform") else len(self.args)

    def grid(self, levels: int) -> list:
        """The values a grid sweep takes: every choice or integer, else ``levels`` points."""
        a = self.args
        if self.kind == "uniform":
            return [float(v) for v in np.linspace(a[0], a[1], levels)]
        if self.kind == "loguniform":
            return [float(v) for v in np.geomspace(a[0], a[1], levels)]
        if self.kind == "int_range":
            return list(range(a[0], a[1] + 1))
        return list(a)

    @property
    def value_type(self) -> type:
        """``float``, ``int``, ``bool`` or ``str``: the type of every value it yields."""
        if self.kind in ("uniform", "loguniform", "normal"):
            return float
        if self.kind == "int_range":
            return int
        return type(self.args[0])


def _number(value: Any) -> bool:
    """A finite number; an integer within TOML's (and the result columns') 64 bits."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        return False
    return -(2**63) <= value < 2**63 if isinstance(value, int) else math.isfinite(value)


def parse_param(path: str, table: Any, field: str) -> Param:
    if not isinstance(table, dict) or len(table) != 1:
        raise SpecError(field, "must be a table with one distribution, like { uniform = [lo, hi] }")
    ((kind, args),) = table.items()
    field = f"{field}.{kind}"
    if kind not in ("uniform", "loguniform", "normal", "int_range", "choice"):
        raise SpecError(field, "unknown distribution (known: choice, int_range, loguniform, "
                               "normal, uniform)")
    if not isinstance(args, list):
        raise SpecError(field, f"must be a list, got {type(args).__name__}")
    if kind == "choice":
        if not args:
            raise SpecError(field, "is empty: give at least one value")
        if all(_number(v) for v in args):
            kinds = {float} if any(isinstance(v, float) for v in args) else {int}
            args = [float(v) if float in kinds else v for v in args]
        kinds = {type(v) for v in args}
        if len(kinds) != 1 or not kinds <= {bool, int, float, str}:
            raise SpecError(field, "values must all be numbers, all strings or all booleans")
        if kinds == {int} and not all(_number(v) for v in args):
            raise SpecError(field, "integers must fit in 64 bits")
        return Param(path, kind, tuple(args))
    if len(args) != 2 or not all(_number(v) for v in args):
        raise SpecError(field, f"must be two numbers, got {args!r}")
    lo, hi = args
    if kind == "normal":
        if hi <= 0:
            raise SpecError(field, f"standard deviation must be > 0, got {hi!r}")
        return Param(path, kind, (float(lo), float(hi)))
    if kind == "int_range":
        if not all(isinstance(v, int) for v in args):
            raise SpecError(field, f"bounds must be integers, got {args!r}")
        if lo > hi:
            raise SpecError(field, f"inverted range: {lo} > {hi}")
        return Param(path, kind, (lo, hi))
    if lo >= hi:
        raise SpecError(field, f"inverted range: {lo} >= {hi}")
    if kind == "loguniform" and lo <= 0:
        raise SpecError(field, f"lower bound must be > 0, got {lo!r}")
    return Param(path, kind, (float(lo), float(hi)))
