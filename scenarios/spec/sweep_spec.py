"""Sweep specs: one scenario family, sampled into a deterministic plan of runs.

A sweep file names a base scenario, the parameters to vary (each addressed by
its path in the scenario, ``obstacles[0].kind``, with a distribution) and a
sampler. Every sampler draws points of the unit cube, one coordinate per
parameter; each parameter maps its coordinate through its inverse CDF. So
``random``, ``sobol`` and ``lhs`` differ only in how they cover the cube, and
``grid`` takes every combination of each parameter's grid values instead.

The plan is a pure function of the file: the same file gives the same runs,
specs and seeds in any process.
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import json
import math
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from statistics import NormalDist
from typing import Any, Literal

import numpy as np

from scenarios.common.errors import OptionError, SpecError
from scenarios.common.seeding import (
    POINTS_STREAM,
    RUN_SEEDS_STREAM,
    SEED_LIMIT,
    draw_seeds,
    stream_rng,
    warm_rng,
)
from scenarios.spec.backends import BACKENDS
from scenarios.spec.controller_params import CONTROLLER_PARAMS
from scenarios.spec.controller_ref import controller_label, resolve_file
from scenarios.spec.overrides import Override, blame
from scenarios.spec.scenario_spec import SCENARIO_TABLES, ControllerSpec, ScenarioSpec
from scenarios.spec.shared_worlds import WorldSeat, group_worlds
from scenarios.spec.spec_fields import Spec, build, num, parse_path
from scenarios.spec.toml_io import load_spec, read_toml

#: a swept parameter's result column: p.<path>, e.g. p.ego.speed_mps
PARAM_PREFIX = "p."
#: runs of one sweep (samples x controllers): its plan holds every run's scenario in
#: memory (5-14 KB a run) and is built (1-2 ms a run) and written to plan.parquet
#: before the first run starts; 100,000 runs are hours of runs on a few cores
MAX_RUNS = 100_000
#: the most egos one world holds ([sweep] egos_per_world): the largest K whose
#: verdicts were measured to agree with one ego a world (docs/how-to/shared-worlds.md)
MAX_EGOS_PER_WORLD = 16
#: how often planning says how far it got [runs]
PLAN_PROGRESS_RUNS = 1000


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


@dataclasses.dataclass(frozen=True, kw_only=True)
class _SweepTable(Spec):
    name: str
    base: str
    samples: int | None = num(None, gt=0)
    sampler: Literal["grid", "random", "sobol", "lhs"] = "random"
    seed: int = num(0, ge=0, lt=SEED_LIMIT)
    levels: int | None = num(None, ge=2, le=1000)
    warm_states: int | None = num(None, ge=1, le=MAX_RUNS)
    #: runs that share one SUMO world (its traffic simulated once), each with its own
    #: ego (scenarios/spec/shared_worlds.py); 1: every run in a world of its own
    egos_per_world: int = num(1, ge=1, le=MAX_EGOS_PER_WORLD)
    controllers: tuple = ("seed",)
    params: tuple = ()


@dataclasses.dataclass(frozen=True)
class GivenSamples:
    """Samples a sweep takes as they are given (an OpenSCENARIO parameter value
    distribution's: ``scenarios/asam/xosc_sweep.py``), not drawn from
    ``[sweep.params]``: each a dict of named values, made into its scenario by
    ``scenario_of`` (a :class:`SpecError` there is that sample's error row). ``files``
    is what the manifest records of where they came from (each file's path and sha256);
    ``notes`` what sdc holds differently from them, in sentences."""

    values: tuple[dict[str, Any], ...]
    scenario_of: Callable[[dict[str, Any]], ScenarioSpec]
    files: dict[str, dict[str, str]]
    notes: tuple[str, ...] = ()

    def value_types(self) -> dict[str, type]:
        """Each named value's column type: text where any sample's value is text."""
        names = dict.fromkeys(name for values in self.values for name in values)
        return {name: str if any(isinstance(v.get(name), str) for v in self.values) else float
                for name in names}


@dataclasses.dataclass(frozen=True)
class SweepSpec:
    """A validated sweep: the base scenario, its parameters and the sampling (or its
    samples as given)."""

    name: str
    base_path: Path
    base: ScenarioSpec
    samples: int | None  # None for the grid sampler, whose size follows from the params
    sampler: str
    seed: int
    levels: int  # grid points per continuous parameter (grid only)
    controllers: tuple[str, ...]
    params: tuple[Param, ...]
    #: how many distinct warm states of the traffic the samples draw from (None: each
    #: sample warms up its own, from its seed)
    warm_states: int | None = None
    #: runs that share one world (scenarios/spec/shared_worlds.py); 1: none share
    egos_per_world: int = 1

    #: the ``--set`` options it was read with (``PATH=VALUE``, as given), its
    #: manifest's ``overrides``
    overrides: tuple[str, ...] = ()
    #: its samples as given (sampler ``given``; None: drawn from ``params``)
    given: GivenSamples | None = None

    @classmethod
    def from_plain(cls, data: Any, base_dir: Path,
                   base_overrides: Sequence[str] = ()) -> SweepSpec:
        """The sweep in a file's plain ``data``, its base scenario (relative to
        ``base_dir``) changed by ``base_overrides`` (``toml_io.load_spec``)."""
        if isinstance(data, dict) and "sweep" not in data and SCENARIO_TABLES & set(data):
            raise SpecError("", "this is a scenario file, not a sweep: use `sdc run FILE`; "
                            "to sweep it, write a sweep file whose [sweep] base names it "
                            "(docs/how-to/sweeps.md)")
        if not isinstance(data, dict) or set(data) != {"sweep"}:
            extra = sorted(set(data) - {"sweep"}) if isinstance(data, dict) else []
            raise SpecError(extra[0] if extra else "sweep",
                            "a sweep file holds one [sweep] table (and [sweep.params])")
        table = data["sweep"]
        if not isinstance(table, dict):
            raise SpecError("sweep", "must be a table")
        controllers = table.get("controllers", ["seed"])
        if not isinstance(controllers, list) or not controllers:
            raise SpecError("sweep.controllers", "must be a non-empty list of controller names")
        controllers = [resolve_file(name, base_dir, f"sweep.controllers[{i}]")
                       for i, name in enumerate(controllers)]
        labels: dict[str, str] = {}
        for i, name in enumerate(controllers):
            label = controller_label(name)
            if label in labels:
                what = ("lists a controller twice" if labels[label] == name else
                        f"names two controllers that go by {label!r} in run IDs "
                        f"({labels[label]} and {name}): rename a class")
                raise SpecError(f"sweep.controllers[{i}]", what)
            labels[label] = name
        params = table.get("params", {})
        if not isinstance(params, dict):
            raise SpecError("sweep.params", "must be a table of path = { distribution = [...] }")
        meta = build(_SweepTable, {**table, "controllers": (), "params": ()}, "sweep")

        try:
            base_path = (Path(base_dir) / meta.base).resolve()
        except (OSError, ValueError, RuntimeError) as e:  # a NUL byte, a symlink loop
            raise SpecError("sweep.base", f"is not a usable path ({e})") from None
        try:
            base = load_spec(base_path, base_overrides)
        except SpecError as e:
            raise base_error(e, meta.base) from None
        parsed = []
        for path, dist in params.items():
            field = f'sweep.params."{path}"'
            try:
                base_value = check_path(base, path)
            except ValueError as e:
                raise SpecError(field, f"unknown parameter path: {e}") from None
            name = path.removeprefix("controller.")
            if path.startswith("controller.") and name != "name" and not any(
                    base.controller.takes(c, name) for c in controllers):
                raise SpecError(field, f"none of the sweep's controllers takes {name!r} "
                                f"(a plug-in takes parameters when the base scenario names it)")
            param = parse_param(path, dist, field)
            if (param.continuous and isinstance(base_value, int)
                    and not isinstance(base_value, bool)):
                raise SpecError(field, f"{path} is a whole number (the base has "
                                f"{base_value!r}) and {param.kind} draws fractions: "
                                "use int_range or choice")
            parsed.append(param)

        if meta.sampler == "grid":
            if meta.samples is not None:
                raise SpecError("sweep.samples", "the grid sampler takes its size from the "
                                "parameters (set sweep.levels for continuous ones)")
            for p in parsed:
                if p.kind == "normal":
                    raise SpecError(f'sweep.params."{p.path}".normal',
                                    "has no grid: use uniform or choice with the grid sampler")
            size = math.prod(p.grid_size(meta.levels or 5) for p in parsed)
            check_runs("sweep.params", f"the grid has {size} points", size, len(controllers),
                       "fewer levels or values")
        else:
            if meta.samples is None:
                raise SpecError("sweep.samples", f"is required for the {meta.sampler} sampler")
            if meta.levels is not None:
                raise SpecError("sweep.levels", "only applies to the grid sampler")
            check_runs("sweep.samples", f"{meta.samples} samples", meta.samples,
                       len(controllers), "fewer samples")
        _check_warm_states(meta.warm_states, base, parsed)
        if meta.egos_per_world > 1 and not base.scenario.world_backend.holds_several_egos:
            raise SpecError("sweep.egos_per_world", "only the sumo backend holds several "
                            f"egos in one world; the base scenario runs on "
                            f"{base.scenario.backend!r}")
        if meta.egos_per_world > 1 and not base.road.on_network:
            raise SpecError("sweep.egos_per_world", "egos share a world on a network road "
                            "only (road.net_file, road.config_file): a built road starts "
                            "every ego at ego.start_m of the same lane, so no two can be "
                            "placed apart; leave it 1")
        return cls(meta.name, base_path, base, meta.samples, meta.sampler, meta.seed,
                   meta.levels or 5, tuple(controllers), tuple(parsed), meta.warm_states,
                   meta.egos_per_world)

    @property
    def param_types(self) -> dict[str, type]:
        """Each swept path and the type of the values it takes."""
        if self.given is not None:
            return self.given.value_types()
        return {p.path: p.value_type for p in self.params}

    def with_samples(self, samples: int) -> SweepSpec:
        if self.given is not None:
            raise SpecError("--samples", "the samples are the distribution's (its "
                            "numberOfTestRuns, or its deterministic product)")
        if self.sampler == "grid":
            raise SpecError("--samples", "the grid sampler takes its size from the parameters")
        if samples <= 0:
            raise SpecError("--samples", f"must be > 0, got {samples}")
        check_runs("--samples", f"{samples} samples", samples, len(self.controllers),
                   "fewer samples")
        return dataclasses.replace(self, samples=samples)

    def to_plain(self) -> dict:
        """The sweep as written in a file (``base`` absolute), for the manifest."""
        table: dict[str, Any] = {"name": self.name, "base": str(self.base_path),
                                 "sampler": self.sampler, "seed": self.seed,
                                 "controllers": list(self.controllers)}
        if self.samples is not None:
            table["samples"] = self.samples
        else:
            table["levels"] = self.levels
        if self.warm_states is not None:
            table["warm_states"] = self.warm_states
        if self.egos_per_world > 1:
            table["egos_per_world"] = self.egos_per_world
        table["params"] = {p.path: {p.kind: list(p.args)} for p in self.params}
        if self.given is not None:
            table["given"] = self.given.files
        return {"sweep": table}


def base_error(error: SpecError, base: str) -> SpecError:
    """An error of the base scenario as the sweep file shows it: under ``sweep.base``,
    the base file as the sweep names it (``base``), then the field (an option's error
    is left as it is)."""
    if isinstance(error, OptionError):
        return error
    text = f"{error.field}: {error.message}" if error.field else error.message
    return SpecError("sweep.base", f"{base}: {text}")


def check_runs(field: str, what: str, samples: int, controllers: int, fewer: str) -> None:
    """Refuse a sweep of more than :data:`MAX_RUNS` runs, before anything is planned,
    saying why and what to do instead."""
    runs = samples * controllers
    if runs > MAX_RUNS:
        each = f"{controllers} controller" + ("s" if controllers != 1 else "")
        raise SpecError(field, f"{what} x {each} = {runs:,} runs, more than "
                        f"the {MAX_RUNS:,} a sweep plans: its plan holds every run's scenario "
                        "in memory (5-14 KB a run) and is built (1-2 ms a run) before the "
                        f"first run; use {fewer}, several sweeps with other sweep.seed "
                        "values, or sdc estimate or sdc search, which draw their runs in "
                        "batches")


def _check_warm_states(warm_states: int | None, base: ScenarioSpec,
                       params: list[Param]) -> None:
    if warm_states is None:
        return
    swept = {p.path: p for p in params}
    backend = swept.get("scenario.backend")
    backends = set(backend.args) if backend is not None else {base.scenario.backend}
    if not any(BACKENDS[name].warm_states for name in backends):
        raise SpecError("sweep.warm_states", "warm states are SUMO's saved traffic; the "
                        f"sweep runs on the {' and '.join(sorted(backends))} backend only, "
                        "which has none to share")
    if "traffic.warm_seed" in swept:
        raise SpecError("sweep.warm_states", "and a swept traffic.warm_seed both choose the "
                        "warm-ups' seeds: keep one")
    # a configuration's demand up to traffic.enter_s is its warm-up
    if (base.traffic.warm_up_s == 0 and "traffic.warm_up_s" not in swept
            and not base.road.own_demand):
        raise SpecError("sweep.warm_states", "the base scenario has no traffic warm-up "
                        "(traffic.warm_up_s = 0), so there is no warm state to share")


def warm_seeds(sweep: SweepSpec) -> list[int] | None:
    """The seeds of the sweep's ``warm_states`` warm-ups, drawn from its seed (None:
    each sample warms up from its own seed)."""
    if sweep.warm_states is None:
        return None
    return draw_seeds(warm_rng(sweep.seed), sweep.warm_states)


def load_sweep(path: str | Path, overrides: Sequence[str] = ()) -> SweepSpec:
    """The sweep in a TOML file, changed by ``overrides`` (``PATH=VALUE``): a path
    under ``sweep.`` changes the sweep file's own table, any other its base scenario
    (``scenarios/spec/overrides.py``). Every error names the file, or the override
    it is about."""
    data = read_toml(path, "the sweep file")
    parsed = [Override.parse(text) for text in overrides]
    own = [o for o in parsed if o.table == "sweep"]
    base = [o for o in parsed if o.table != "sweep"]
    try:
        for override in own:
            override.apply(data)
        sweep = SweepSpec.from_plain(data, Path(path).resolve().parent, [o.text for o in base])
    except SpecError as e:  # the base's errors name the overrides they were read with
        of_base = e.field == "sweep.base"
        raise blame(e, [o for o in parsed if not of_base or o.path == "sweep.base"],
                    path) from None
    _check_base_overrides(sweep, base)
    return dataclasses.replace(sweep, overrides=tuple(overrides))


#: base scenario fields a sweep's plan sets itself, and where to change them instead
_PLANNED = {"scenario.seed": "each sample's seed is drawn from sweep.seed",
            "controller.name": "the runs' controllers are sweep.controllers"}


def _check_base_overrides(sweep: SweepSpec, overrides: list[Override]) -> None:
    """Refuse an override of a base field the plan sets itself (it would be lost),
    saying where to change it."""
    for override in overrides:
        why = _PLANNED.get(override.path)
        if override.path in sweep.param_types:
            value = override.text.partition("=")[2].strip()
            why = (f"it is swept; set its distribution instead, e.g. --set "
                   f"'sweep.params.{override.path}={{ choice = [{value}] }}'")
        elif override.path == "traffic.warm_seed" and sweep.warm_states is not None:
            why = "the warm-ups' seeds are drawn from sweep.seed (sweep.warm_states)"
        if why is not None:
            raise override.error(f"the sweep's plan sets {override.path}: {why}")


@dataclasses.dataclass(frozen=True)
class PlannedRun:
    """One run of a sweep. ``spec`` is None when the sample makes an invalid scenario;
    ``error`` then says why, with the sample's values."""

    index: int  # position in the plan
    run_id: str
    sample: int
    controller: str  # its label (scenarios.spec.controller_ref.controller_label)
    seed: int
    backend: str
    params: dict[str, Any]
    spec: ScenarioSpec | None
    error: str | None
    world: WorldSeat | None = None  # its seat in a shared world ([sweep] egos_per_world)


def _unit_points(sweep: SweepSpec, rng: np.random.Generator) -> np.ndarray:
    n, d = sweep.samples, len(sweep.params)
    if d == 0:
        return np.zeros((n, 0))
    if sweep.sampler == "random":
        return rng.random((n, d))
    from scipy.stats import qmc  # only the quasi-random samplers need scipy

    if sweep.sampler == "sobol":
        with warnings.catch_warnings():  # balance properties want 2**k points; any n works
            warnings.simplefilter("ignore", UserWarning)
            return qmc.Sobol(d, scramble=True, rng=rng).random(n)
    return qmc.LatinHypercube(d, rng=rng).random(n)


def sample_values(sweep: SweepSpec) -> list[dict[str, Any]]:
    """Each sample's parameter values, in plan order."""
    if sweep.given is not None:
        return [dict(values) for values in sweep.given.values]
    point_rng = stream_rng(sweep.seed, POINTS_STREAM)
    if sweep.sampler == "grid":
        axes = [p.grid(sweep.levels) for p in sweep.params]
        return [{p.path: v for p, v in zip(sweep.params, combo, strict=True)}
                for combo in itertools.product(*axes)]
    return [{p.path: p.at(float(u)) for p, u in zip(sweep.params, row, strict=True)}
            for row in _unit_points(sweep, point_rng)]


def expand(sweep: SweepSpec, progress: Callable[[int, int], None] | None = None
           ) -> list[PlannedRun]:
    """The plan: every sample under every controller, each sample with its own seed;
    ``progress(runs planned, runs in all)`` is called as it goes (every
    :data:`PLAN_PROGRESS_RUNS` runs, and at the end).

    A sample's seed is ``scenario.seed`` for all its controllers (a paired
    comparison), unless ``scenario.seed`` is itself a swept parameter.
    """
    samples = sample_values(sweep)
    return plan_samples(sweep, samples,
                        draw_seeds(stream_rng(sweep.seed, RUN_SEEDS_STREAM), len(samples)),
                        progress=progress)


def plan_samples(sweep: SweepSpec, samples: list[dict[str, Any]], seeds: list[int], *,
                 first_sample: int = 0, index_width: int | None = None,
                 controllers: tuple[str, ...] | None = None,
                 progress: Callable[[int, int], None] | None = None) -> list[PlannedRun]:
    """The runs of ``samples`` (parameter values, one dict each) under ``controllers``
    (default: the sweep's), sample ``i`` numbered ``first_sample + i`` and seeded
    ``seeds[i]``. Run IDs are ``<sample, zero-padded to index_width>-<controller>``;
    ``progress``: as for :func:`expand`."""
    controllers = sweep.controllers if controllers is None else controllers
    last = first_sample + len(samples) - 1
    width = index_width or max(5, len(str(last)))
    base_plain = sweep.base.to_plain()
    warm = warm_seeds(sweep)
    plan = []
    total = len(samples) * len(controllers)
    for i, (values, seed) in enumerate(zip(samples, seeds, strict=True), start=first_sample):
        if progress is not None and len(plan) % PLAN_PROGRESS_RUNS < len(controllers):
            progress(len(plan), total)
        shown = ", ".join(f"{k}={v!r}" for k, v in values.items())
        spec, error = None, None
        if sweep.given is not None:
            try:
                plain = sweep.given.scenario_of(values).to_plain()
            except SpecError as e:
                plain, error = json.loads(json.dumps(base_plain)), (
                    f"invalid scenario from sample {i} ({shown}): {e}")
        else:
            plain = json.loads(json.dumps(base_plain))  # a deep copy of plain data
        set_path(plain, "scenario.seed", int(seed))
        if warm is not None:  # the sample's warm state: one of the sweep's, by its seed
            set_path(plain, "traffic.warm_seed", warm[int(values.get("scenario.seed", seed))
                                                      % len(warm)])
        controller_values = {}  # each controller takes those it has (ControllerSpec.renamed)
        for path, value in values.items() if sweep.given is None else ():
            if path.startswith("controller.") and path != "controller.name":
                controller_values[path.removeprefix("controller.")] = value
            else:
                set_path(plain, path, value)
        try:
            spec = None if error else ScenarioSpec.from_plain(plain)
        except SpecError as e:
            error = f"invalid scenario from sample {i} ({shown}): {e}"
        for controller in controllers:
            label = controller_label(controller)
            run_spec, run_error = None, error
            if spec is not None:
                try:
                    run_spec = dataclasses.replace(
                        spec, controller=spec.controller.renamed(controller, controller_values))
                except SpecError as e:
                    run_error = f"invalid scenario from sample {i} ({shown}): {e}"
            plan.append(PlannedRun(
                index=first_sample * len(controllers) + len(plan),
                run_id=f"{i:0{width}d}-{label}", sample=i, controller=label,
                seed=int(plain["scenario"]["seed"]),
                backend=str(plain["scenario"].get("backend", "sumo")), params=values,
                spec=run_spec, error=run_error,
            ))
    if progress is not None:
        progress(len(plan), total)
    return _seated(plan, sweep.egos_per_world, width)


def _seated(plan: list[PlannedRun], egos_per_world: int, width: int) -> list[PlannedRun]:
    """``plan`` with its runs seated in shared worlds (:func:`group_worlds`), each
    run's spec taking its world's traffic seed; unchanged for one ego a world. Only
    SUMO holds several egos, and only a network road places them apart: a run swept
    onto another backend or a built road keeps a world of its own."""
    if egos_per_world == 1:
        return plan
    grouped = group_worlds([(k, f"{run.sample:0{width}d}", run.controller, run.spec)
                            for k, run in enumerate(plan)
                            if run.spec is not None
                            and run.spec.scenario.world_backend.holds_several_egos
                            and run.spec.road.on_network],
                           egos_per_world)
    return [run if k not in grouped else
            dataclasses.replace(run, spec=grouped[k][1], world=grouped[k][0])
            for k, run in enumerate(plan)]


def plan_sha256(plan: list[PlannedRun]) -> str:
    """A digest of everything that decides the runs' results."""
    digest = hashlib.sha256()
    for run in plan:
        body = run.spec.to_plain() if run.spec else run.error
        seat = [] if run.world is None else [run.world.world_id, run.world.slot]
        digest.update(json.dumps([run.run_id, run.params, body, *seat], sort_keys=True).encode())
    return digest.hexdigest()
