"""An OpenSCENARIO parameter value distribution (a ``.xosc`` file holding a
``ParameterValueDistribution``, OpenSCENARIO 1.1 to 1.3) read into its samples: one
dict of parameter values per test run.

What a file means here (the standard's elements, read as its model defines them), each
part in the module that reads it:

- ``Stochastic`` (``xosc_stochastic.py``): ``numberOfTestRuns`` runs drawn from
  ``np.random.default_rng(randomSeed)`` (:data:`DEFAULT_SEED` without one), run by
  run and parameter by parameter in file order; Normal (mean and VARIANCE),
  LogNormal (the underlying normal's mean and variance), Poisson, Uniform, Histogram
  and ProbabilityDistributionSet draws; a ``Range`` under a Normal, LogNormal or
  Poisson truncates it (drawn again, at most :data:`MAX_TRIES` times in a row).
- ``Deterministic`` (``xosc_deterministic.py``): the cartesian product of its single-
  parameter distributions (sets and ranges stepped in decimal arithmetic), then of its
  multi-parameter ones (joint value sets); singles first whatever the file's order.
- Every element (``xosc_element_checks.py``): only the attributes and children the
  standard puts there; values typed (a finite decimal number a float, anything else a
  str, :func:`typed_value`); a parameter's leading ``$`` dropped (``$Ego_Speed`` and
  ``Ego_Speed`` name the same parameter).
- The ``ScenarioFile filepath`` is relative to the distribution file's folder and must
  name a file.

Anything else is refused with a :class:`SpecError` naming the element and the file:
malformed XML, a file that holds no ``ParameterValueDistribution`` (a scenario, a
catalog), an OpenSCENARIO version other than 1.1 to 1.3 (``xosc_file.py``), an
element or attribute the standard does not put there, a missing one, a number that is
not one (parameter references and expressions are not resolved in a distribution
file), a Range whose lower limit is above its upper, a negative variance or weight, a
Poisson lambda outside [0, :data:`POISSON_MAX`], ``numberOfTestRuns`` not a whole
number >= 1, a parameter given twice, value sets of one multi-parameter distribution
assigning different parameters, a ``UserDefinedDistribution`` (its meaning is the
tool's own), or more than :data:`MAX_SAMPLES` samples.

The file is read with ``xml.etree.ElementTree``, not ``scenariogeneration``'s
``ParseOpenScenario``: that one prints, validates against the schema only to warn,
keeps numbers as strings, keeps a dict per parameter (a parameter given twice would
vanish) and loses the file's order of single- and multi-parameter distributions.
"""

from __future__ import annotations

import dataclasses
import xml.etree.ElementTree as ET
from pathlib import Path

from scenarios.asam.xosc_deterministic import DeterministicReader
from scenarios.asam.xosc_element_checks import MAX_SAMPLES, Value, find_child, typed_value
from scenarios.asam.xosc_file import check_version, read_openscenario, tag
from scenarios.asam.xosc_stochastic import (
    DEFAULT_SEED,
    MAX_TRIES,
    POISSON_MAX,
    Law,
    StochasticReader,
)

__all__ = ["DEFAULT_SEED", "KNOWN_MINOR_VERSIONS", "MAX_SAMPLES", "MAX_TRIES", "POISSON_MAX",
           "Distribution", "Value", "read_distribution", "typed_value"]

#: the OpenSCENARIO minor versions (of 1.x) that hold parameter value distributions
KNOWN_MINOR_VERSIONS = (1, 2, 3)


@dataclasses.dataclass(frozen=True)
class Distribution:
    """A parameter value distribution file and the samples it gives."""

    path: Path  # the distribution file (.xosc)
    scenario_file: Path  # its ScenarioFile, resolved relative to the distribution's folder
    parameters: tuple[str, ...]  # parameter names, leading "$" dropped, in file order
    samples: tuple[dict[str, Value], ...]  # one dict per test run, values typed
    kind: str  # "stochastic" | "deterministic"
    seed: int | None  # the Stochastic randomSeed (None: deterministic / absent)
    #: each stochastic parameter's distribution as a sweep states one (kind, arguments),
    #: None where it is none of a sweep's (empty: a deterministic distribution)
    laws: dict[str, Law | None] = dataclasses.field(default_factory=dict)


def read_distribution(path: str | Path) -> Distribution:
    """The distribution file at ``path`` read into its samples (the module's docstring
    says how each element is read)."""
    path = Path(path)
    return _Reader(path).read()


class _Reader(StochasticReader, DeterministicReader):
    """One file's reading: the file and its ScenarioFile here, its Stochastic or
    Deterministic part by the reader of each."""

    def read(self) -> Distribution:
        root = read_openscenario(self.path, "the parameter distribution file")
        children = {tag(child): child for child in root}
        if "ParameterValueDistribution" not in children:
            raise self.error("OpenSCENARIO", "not a parameter value distribution: it holds no "
                             f"ParameterValueDistribution ({_what_it_is(children)})")
        self.check_children(root, "OpenSCENARIO", {"FileHeader": (1, 1),
                                                   "ParameterValueDistribution": (1, 1)})
        check_version(root, KNOWN_MINOR_VERSIONS,
                      lambda _, message: self.error("OpenSCENARIO/FileHeader", message),
                      " for parameter value distributions")
        pvd = children["ParameterValueDistribution"]
        where = "ParameterValueDistribution"
        self.check_attributes(pvd, where, ())
        if not any(tag(child) in ("Deterministic", "Stochastic") for child in pvd):
            raise self.error(where, "holds neither a Deterministic nor a Stochastic "
                                    "distribution")
        self.check_children(pvd, where, {"ScenarioFile": (1, 1), "Deterministic": (0, 1),
                                         "Stochastic": (0, 1)})
        if sum(tag(child) in ("Deterministic", "Stochastic") for child in pvd) != 1:
            raise self.error(where, "holds both a Deterministic and a Stochastic distribution "
                                    "(the standard allows one)")
        scenario_file = self.scenario_file(find_child(pvd, "ScenarioFile"))
        if (element := find_child(pvd, "Stochastic")) is not None:
            parameters, samples, seed, laws = self.stochastic(element, f"{where}/Stochastic")
            kind = "stochastic"
        else:
            element = find_child(pvd, "Deterministic")
            parameters, samples = self.deterministic(element, f"{where}/Deterministic")
            kind, seed, laws = "deterministic", None, {}
        return Distribution(self.path, scenario_file, parameters, samples, kind, seed, laws)

    def scenario_file(self, element: ET.Element) -> Path:
        where = "ParameterValueDistribution/ScenarioFile"
        self.check_attributes(element, where, ("filepath",))
        self.check_children(element, where, {})
        filepath = element.get("filepath", "")
        if not filepath.strip():
            raise self.error(where, "its filepath is empty")
        resolved = self.path.parent / filepath
        if not resolved.is_file():
            raise self.error(where, f"filepath {filepath!r} names no file ({resolved}; a "
                                    "ScenarioFile is relative to the distribution's folder)")
        return resolved


def _what_it_is(children: dict[str, ET.Element]) -> str:
    if "Catalog" in children:
        return "it is a catalog"
    if "Storyboard" in children or "Entities" in children:
        return "it is a scenario"
    return f"it holds {', '.join(f'<{name}>' for name in children) or 'nothing'}"
