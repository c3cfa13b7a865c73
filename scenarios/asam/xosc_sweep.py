"""An OpenSCENARIO parameter value distribution as an sdc sweep: its samples
(``scenarios/asam/xosc_distribution.py``) taken as given, each made into its scenario
from the distribution's ``ScenarioFile`` (``scenarios/asam/xosc_spec.py``), its values
the result's ``p.<ParameterName>`` columns. The manifest names both files with their
sha256; the samples' seeds are drawn from the distribution's ``randomSeed`` (0 for a
deterministic one), as a sweep's from its ``seed``.

Where every parameter of a stochastic distribution is one a sweep states (a uniform, a
normal no Range truncates), those are the sweep's ``params`` too: ``sdc search`` and
``sdc estimate`` then draw from them as from a sweep's ``[sweep.params]``
(:func:`check_adaptive` says why not where they cannot).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from scenarios.asam.xodr_places import XodrMap
from scenarios.asam.xosc_distribution import Distribution, read_distribution
from scenarios.asam.xosc_spec import xosc_spec
from scenarios.common.errors import SpecError
from scenarios.common.file_read import file_sha256
from scenarios.spec.controller_ref import controller_label
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.spec.sweep_params import Param
from scenarios.spec.sweep_spec import GivenSamples, SweepSpec, check_runs

SAMPLER = "given"


class _ScenarioOf:
    """A sample's values made into its scenario (each road's map read once; a
    pickled copy reads it again)."""

    def __init__(self, scenario_file: Path, ego: str | None):
        self.scenario_file, self.ego = scenario_file, ego
        self.maps: dict[Path, XodrMap] = {}

    def __call__(self, values: dict[str, Any]) -> ScenarioSpec:
        return xosc_spec(self.scenario_file, values, self.ego, maps=self.maps).spec

    def __getstate__(self) -> dict:
        return {"scenario_file": self.scenario_file, "ego": self.ego, "maps": {}}


def distribution_sweep(path: str | Path, controllers: tuple[str, ...],
                       ego: str | None = None, adaptive: bool = False) -> SweepSpec:
    """The sweep of the distribution file ``path`` under ``controllers`` (names as
    resolved by the caller), its scenario's ego the entity ``ego``; ``adaptive``: for
    ``sdc search`` or ``sdc estimate``, which refuse what they cannot draw from
    (:func:`check_adaptive`)."""
    path = Path(path)
    distribution = read_distribution(path)
    if adaptive:
        check_adaptive(distribution)
    scenario_file = distribution.scenario_file.resolve()
    scenario_of = _ScenarioOf(scenario_file, ego)
    # the scenario's own declared values: what every sample changes
    nominal = xosc_spec(scenario_file, {}, ego, maps=scenario_of.maps)
    labels = [controller_label(name) for name in controllers]
    if len(set(labels)) != len(labels):
        raise SpecError("--controllers", "names a controller twice")
    check_runs("--controllers", f"{len(distribution.samples)} samples",
               len(distribution.samples), len(controllers), "fewer test runs")
    files = {role: {"path": str(file), "sha256": file_sha256(file)}
             for role, file in (("distribution", path.resolve()),
                                ("scenario", scenario_file))}
    params = (() if None in distribution.laws.values() else
              tuple(Param(name, kind, args) for name, (kind, args) in distribution.laws.items()))
    return SweepSpec(path.stem, scenario_file, nominal.spec, len(distribution.samples),
                     SAMPLER, distribution.seed or 0, 5, tuple(controllers), params,
                     given=GivenSamples(distribution.samples, scenario_of, files,
                                        nominal.notes))


def check_adaptive(distribution: Distribution) -> None:
    """Refuse, naming the parameter and its element, a distribution ``sdc search`` and
    ``sdc estimate`` cannot draw from themselves."""
    path = distribution.path
    if distribution.kind != "stochastic":
        raise SpecError("ParameterValueDistribution/Deterministic", "search and estimate draw "
                        "their own runs from a Stochastic distribution; a deterministic one is "
                        "its runs: sweep it with `sdc sweep`", path)
    for name, law in distribution.laws.items():
        if law is None:
            raise SpecError(f"ParameterValueDistribution/Stochastic/StochasticDistribution"
                            f"[{name}]", "search and estimate draw from uniform and untruncated "
                            "normal distributions only (a sweep's); sweep this one with "
                            "`sdc sweep`", path)
