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
import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, Literal

from scenarios.common.errors import OptionError, SpecError
from scenarios.common.seeding import SEED_LIMIT, draw_seeds, warm_rng
from scenarios.spec.backends import BACKENDS
from scenarios.spec.controller_ref import controller_label, resolve_file
from scenarios.spec.overrides import Override, blame
from scenarios.spec.scenario_spec import SCENARIO_TABLES, ScenarioSpec
from scenarios.spec.spec_fields import Spec, build, num
from scenarios.spec.sweep_params import Param, check_path, parse_param
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
#: a shared world's runs by default ([sweep] runs_per_world): this many for each of its
#: seats, so a seat a run frees is taken by the next (docs/how-to/shared-worlds.md)
RUNS_PER_SEAT = 2
#: the most runs one world serves: a world task holds one worker for all of them
MAX_RUNS_PER_WORLD = 256


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
    #: ego (scenarios/spec/world_seating.py); 1: every run in a world of its own
    egos_per_world: int = num(1, ge=1, le=MAX_EGOS_PER_WORLD)
    #: runs one world serves, its egos_per_world at a time (None: RUNS_PER_SEAT a seat)
    runs_per_world: int | None = num(None, ge=1, le=MAX_RUNS_PER_WORLD)
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
    #: egos one world holds at a time (scenarios/spec/world_seating.py); 1: none share
    egos_per_world: int = 1
    #: runs one world serves, entering as seats free (1 when none share)
    runs_per_world: int = 1

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
                   meta.egos_per_world, _runs_per_world(meta.egos_per_world,
                                                        meta.runs_per_world))

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
            table["runs_per_world"] = self.runs_per_world
        table["params"] = {p.path: {p.kind: list(p.args)} for p in self.params}
        if self.given is not None:
            table["given"] = self.given.files
        return {"sweep": table}


def _runs_per_world(egos_per_world: int, asked: int | None) -> int:
    """The runs a world serves: ``asked``, else :data:`RUNS_PER_SEAT` for each of its
    ``egos_per_world`` seats; never fewer than its seats, and 1 when none share."""
    if asked is None:
        return 1 if egos_per_world == 1 else RUNS_PER_SEAT * egos_per_world
    if egos_per_world == 1 and asked > 1:
        raise SpecError("sweep.runs_per_world", "runs take turns in a shared world only: "
                        "set sweep.egos_per_world above 1, or leave this out")
    if asked < egos_per_world:
        raise SpecError("sweep.runs_per_world", f"must be at least sweep.egos_per_world "
                        f"({egos_per_world}): a world serves its seats' runs at least")
    return asked


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
