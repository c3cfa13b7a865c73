"""An OpenSCENARIO parameter value distribution (a ``.xosc`` file holding a
``ParameterValueDistribution``, OpenSCENARIO 1.1 to 1.3) read into its samples: one
dict of parameter values per test run.

What a file means here (the standard's elements, read as its model defines them):

- ``Stochastic numberOfTestRuns randomSeed``: ``numberOfTestRuns`` runs, each drawing
  every ``StochasticDistribution`` once from ``np.random.default_rng(randomSeed)``.
  The draws are made run by run and, inside a run, parameter by parameter in file
  order, all from that one generator; so the first runs of a file are the same
  whatever its ``numberOfTestRuns``, and the same file gives the same samples in any
  process. Without a ``randomSeed`` the seed is :data:`DEFAULT_SEED` (0), never a
  fresh one; ``Distribution.seed`` is then ``None``. A seed is a whole number >= 0
  (``randomSeed`` is a Double in the schema: ``"42.0"`` is 42, ``"42.5"`` is refused).
- ``NormalDistribution expectedValue variance``: mean and VARIANCE (the standard: "the
  square of the standard deviation"), so the draw is ``rng.normal(mean, sqrt(variance))``.
- ``LogNormalDistribution expectedValue variance``: the mean mu and the variance
  sigma^2 of the underlying normal ln X, so X = exp(N(mu, sigma^2)) (``rng.lognormal(mu,
  sigma)``) and E[X] = exp(mu + sigma^2 / 2). The standard's model allows any
  ``expectedValue`` in ]-inf, inf[, which the mean of a log-normal variable (always > 0)
  could not be; TIER IV's scenario_simulator_v2 reads it so too.
- ``PoissonDistribution expectedValue``: lambda; a draw is a whole number (as a float).
- ``UniformDistribution``: uniform in its ``Range`` (``rng.uniform(lower, upper)``).
- A ``Range`` under a Normal, LogNormal or Poisson truncates it: a draw outside it
  (ends included) is drawn again, from the same generator, until one lies inside; a
  Range in which :data:`MAX_TRIES` draws in a row all fall outside holds (almost) none
  of the distribution and is refused rather than approximated.
- ``Histogram``: a bin picked by weight (one uniform draw), then a value uniform inside
  the bin's ``Range`` (a second draw).
- ``ProbabilityDistributionSet``: an ``Element`` value picked by weight (one draw).
- ``Deterministic``: the cartesian product of its ``DeterministicSingleParameterDistribution``
  elements (in file order, the first varying slowest), then of its
  ``DeterministicMultiParameterDistribution`` elements (in file order: each a list of
  joint assignments, its ``ParameterValueSet`` elements). Singles come first whatever
  the file's order (scenariogeneration writes the multi-parameter ones first).
  ``DistributionSet``: its ``Element`` values. ``DistributionRange stepWidth``:
  ``lower + i * step`` for i = 0, 1, ... while <= upper, computed in decimal arithmetic
  from the file's text (so 0.1 to 0.3 by 0.1 is 0.1, 0.2, 0.3: both ends when on the
  grid). A ``Deterministic`` with no distribution is one run with no parameter set.

Values are typed: a value that reads as a finite decimal number (``80``, ``-2.5``,
``1e3``) is a float, anything else (``true``, ``car``, ``NaN``) stays a str. A
parameter's leading ``$`` is dropped (``$Ego_Speed`` and ``Ego_Speed`` name the same
parameter). The ``ScenarioFile filepath`` is relative to the distribution file's folder
and must name a file.

Anything else is refused with a :class:`SpecError` naming the element and the file:
malformed XML, a file that holds no ``ParameterValueDistribution`` (a scenario, a
catalog), an OpenSCENARIO version other than 1.1 to 1.3, an element or attribute the
standard does not put there, a missing one, a number that is not one (parameter
references and expressions are not resolved in a distribution file), a Range whose
lower limit is above its upper, a negative variance or weight, a Poisson lambda
outside [0, :data:`POISSON_MAX`],
``numberOfTestRuns`` not a whole number >= 1, a parameter given twice, value sets of
one multi-parameter distribution assigning different parameters, a
``UserDefinedDistribution`` (its meaning is the tool's own), or more than
:data:`MAX_SAMPLES` samples.

The file is read with ``xml.etree.ElementTree``, not ``scenariogeneration``'s
``ParseOpenScenario``: that one prints, validates against the schema only to warn,
keeps numbers as strings, keeps a dict per parameter (a parameter given twice would
vanish) and loses the file's order of single- and multi-parameter distributions.
"""

from __future__ import annotations

import bisect
import dataclasses
import itertools
import math
import re
import xml.etree.ElementTree as ET
from collections.abc import Callable
from decimal import Decimal
from pathlib import Path

import numpy as np

from scenarios.common.errors import FileError, SpecError
from scenarios.common.file_read import read_bytes

#: the seed of a ``Stochastic`` distribution without a ``randomSeed``
DEFAULT_SEED = 0
#: the most samples a file may give (numberOfTestRuns, or a deterministic product)
MAX_SAMPLES = 1_000_000
#: draws in a row outside a truncating Range before the Range is refused
MAX_TRIES = 10_000
#: the largest Poisson expectedValue (numpy's Poisson draws stop near 9.2e18)
POISSON_MAX = 1e15
#: the OpenSCENARIO minor versions (of 1.x) that hold parameter value distributions
KNOWN_MINOR_VERSIONS = (1, 2, 3)

_NUMBER = re.compile(r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?")
_WHOLE = re.compile(r"\+?\d+")

Value = float | str
Draw = Callable[[np.random.Generator], Value]


@dataclasses.dataclass(frozen=True)
class Distribution:
    """A parameter value distribution file and the samples it gives."""

    path: Path  # the distribution file (.xosc)
    scenario_file: Path  # its ScenarioFile, resolved relative to the distribution's folder
    parameters: tuple[str, ...]  # parameter names, leading "$" dropped, in file order
    samples: tuple[dict[str, Value], ...]  # one dict per test run, values typed
    kind: str  # "stochastic" | "deterministic"
    seed: int | None  # the Stochastic randomSeed (None: deterministic / absent)


def read_distribution(path: str | Path) -> Distribution:
    """The distribution file at ``path`` read into its samples (the module's docstring
    says how each element is read)."""
    path = Path(path)
    return _Reader(path).read()


def typed_value(text: str) -> Value:
    """``text`` as a float when it reads as a finite decimal number, else unchanged."""
    stripped = text.strip()
    return float(stripped) if _NUMBER.fullmatch(stripped) else text


def _find(element: ET.Element, name: str) -> ET.Element | None:
    """The first child of ``element`` named ``name`` (whatever its namespace)."""
    return next((child for child in element if _tag(child) == name), None)


def _tag(element: ET.Element) -> str:
    """The element's name without a namespace."""
    return element.tag.rpartition("}")[2] if isinstance(element.tag, str) else ""


class _Reader:
    """One file's reading: where an error is, and the checks every element goes through."""

    def __init__(self, path: Path):
        self.path = path

    def error(self, where: str, message: str) -> SpecError:
        return SpecError(where, message, self.path)

    # ---- the file ----

    def read(self) -> Distribution:
        data = read_bytes(self.path, "the parameter distribution file")
        try:
            root = ET.fromstring(data)
        except ET.ParseError as e:
            raise FileError(self.path, f"the parameter distribution file is not well-formed "
                                       f"XML ({e})") from None
        if _tag(root) != "OpenSCENARIO":
            raise self.error(_tag(root), "not an OpenSCENARIO file: its root element is "
                                         f"<{_tag(root)}>, not <OpenSCENARIO>")
        children = {_tag(child): child for child in root}
        if "ParameterValueDistribution" not in children:
            raise self.error("OpenSCENARIO", "not a parameter value distribution: it holds no "
                             f"ParameterValueDistribution ({_what_it_is(children)})")
        self.check_children(root, "OpenSCENARIO", {"FileHeader": (1, 1),
                                                   "ParameterValueDistribution": (1, 1)})
        self.check_version(children["FileHeader"])
        pvd = children["ParameterValueDistribution"]
        where = "ParameterValueDistribution"
        self.check_attributes(pvd, where, ())
        if not any(_tag(child) in ("Deterministic", "Stochastic") for child in pvd):
            raise self.error(where, "holds neither a Deterministic nor a Stochastic "
                                    "distribution")
        self.check_children(pvd, where, {"ScenarioFile": (1, 1), "Deterministic": (0, 1),
                                         "Stochastic": (0, 1)})
        if sum(_tag(child) in ("Deterministic", "Stochastic") for child in pvd) != 1:
            raise self.error(where, "holds both a Deterministic and a Stochastic distribution "
                                    "(the standard allows one)")
        scenario_file = self.scenario_file(_find(pvd, "ScenarioFile"))
        if (element := _find(pvd, "Stochastic")) is not None:
            parameters, samples, seed = self.stochastic(element, f"{where}/Stochastic")
            kind = "stochastic"
        else:
            element = _find(pvd, "Deterministic")
            parameters, samples = self.deterministic(element, f"{where}/Deterministic")
            kind, seed = "deterministic", None
        return Distribution(self.path, scenario_file, parameters, samples, kind, seed)

    def check_version(self, header: ET.Element) -> None:
        where = "OpenSCENARIO/FileHeader"
        major, minor = header.get("revMajor"), header.get("revMinor")
        if major is None or minor is None:
            raise self.error(where, "lacks revMajor or revMinor (the OpenSCENARIO version)")
        if (major.strip(), minor.strip()) not in {("1", str(m)) for m in KNOWN_MINOR_VERSIONS}:
            known = ", ".join(f"1.{m}" for m in KNOWN_MINOR_VERSIONS)
            raise self.error(where, f"OpenSCENARIO {major}.{minor} is not a version with "
                                    f"parameter value distributions this reader knows ({known})")

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

    # ---- the checks every element goes through ----

    def check_attributes(self, element: ET.Element, where: str, required: tuple[str, ...],
                         optional: tuple[str, ...] = ()) -> None:
        for name in required:
            if name not in element.attrib:
                raise self.error(where, f"lacks its {name} attribute")
        unknown = sorted(set(element.attrib) - set(required) - set(optional))
        if unknown:
            allowed = ", ".join((*required, *optional)) or "none"
            raise self.error(where, f"has no attribute {unknown[0]!r} in OpenSCENARIO "
                                    f"(it has: {allowed})")

    def check_children(self, element: ET.Element, where: str,
                       counts: dict[str, tuple[int, int | None]]) -> None:
        """Each child one of ``counts``, each name there between its least and most."""
        seen: dict[str, int] = {}
        for child in element:
            name = _tag(child)
            if name not in counts:
                allowed = ", ".join(counts) or "no element"
                raise self.error(where, f"holds <{name}>, which OpenSCENARIO does not put "
                                        f"there (it holds {allowed})")
            seen[name] = seen.get(name, 0) + 1
        for name, (least, most) in counts.items():
            count = seen.get(name, 0)
            if count < least:
                raise self.error(where, f"lacks its <{name}>")
            if most is not None and count > most:
                raise self.error(where, f"holds {count} <{name}> elements (at most {most})")

    def only_child(self, element: ET.Element, where: str, names: tuple[str, ...]) -> ET.Element:
        """The one child of ``element``, which is named one of ``names``."""
        children = list(element)
        if len(children) != 1 or _tag(children[0]) not in names:
            found = ", ".join(f"<{_tag(c)}>" for c in children) or "nothing"
            raise self.error(where, f"must hold exactly one of {', '.join(names)}; it holds "
                                    f"{found}")
        child = children[0]
        if _tag(child) == "UserDefinedDistribution":
            raise self.error(f"{where}/UserDefinedDistribution",
                             f"a UserDefinedDistribution (type {child.get('type')!r}) means what "
                             "its tool makes of it; this reader cannot sample it")
        return child

    def number(self, element: ET.Element, where: str, name: str) -> Decimal:
        text = element.get(name)
        if text is None:
            raise self.error(where, f"lacks its {name} attribute")
        if not _NUMBER.fullmatch(text.strip()):
            why = (" (parameter references and expressions are not resolved in a "
                   "distribution file)" if text.strip().startswith("$") else "")
            raise self.error(where, f"its {name} {text!r} is not a finite number{why}")
        value = Decimal(text.strip())
        if not math.isfinite(float(value)):
            raise self.error(where, f"its {name} {text!r} is beyond a double's range")
        return value

    def limits(self, element: ET.Element, where: str) -> tuple[Decimal, Decimal]:
        """A Range's lower and upper limits."""
        self.check_attributes(element, where, ("lowerLimit", "upperLimit"))
        self.check_children(element, where, {})
        lower = self.number(element, where, "lowerLimit")
        upper = self.number(element, where, "upperLimit")
        if lower > upper:
            raise self.error(where, f"its lowerLimit {lower} is above its upperLimit {upper}")
        return lower, upper

    def parameter_name(self, element: ET.Element, where: str, attribute: str) -> str:
        name = element.get(attribute, "")
        bare = name[1:] if name.startswith("$") else name
        if not bare.strip():
            raise self.error(where, f"its {attribute} {name!r} names no parameter")
        return bare

    def weight(self, element: ET.Element, where: str) -> float:
        weight = self.number(element, where, "weight")
        if weight < 0:
            raise self.error(where, f"its weight {weight} is negative")
        return float(weight)

    def check_count(self, where: str, count: int, what: str) -> None:
        if count > MAX_SAMPLES:
            raise self.error(where, f"gives {count} {what}, more than the {MAX_SAMPLES} this "
                                    "reader takes")

    # ---- Stochastic ----

    def stochastic(self, element: ET.Element, where: str
                   ) -> tuple[tuple[str, ...], tuple[dict[str, Value], ...], int | None]:
        self.check_attributes(element, where, ("numberOfTestRuns",), ("randomSeed",))
        self.check_children(element, where, {"StochasticDistribution": (1, None)})
        runs_text = element.get("numberOfTestRuns", "").strip()
        if not _WHOLE.fullmatch(runs_text) or int(runs_text) < 1:
            raise self.error(where, f"its numberOfTestRuns {element.get('numberOfTestRuns')!r} "
                                    "is not a whole number >= 1")
        runs = int(runs_text)
        self.check_count(where, runs, "test runs")
        seed = None
        if "randomSeed" in element.attrib:
            value = self.number(element, where, "randomSeed")
            if value < 0 or value != value.to_integral_value():
                raise self.error(where, f"its randomSeed {element.get('randomSeed')!r} is not "
                                        "a whole number >= 0")
            seed = int(value)
        draws: dict[str, Draw] = {}
        for child in element:
            name = self.parameter_name(child, f"{where}/StochasticDistribution",
                                       "parameterName")
            here = f"{where}/StochasticDistribution[{child.get('parameterName')}]"
            self.check_attributes(child, here, ("parameterName",))
            if name in draws:
                raise self.error(here, f"parameter {name!r} has a second StochasticDistribution")
            draws[name] = self.stochastic_draw(child, here)
        rng = np.random.default_rng(DEFAULT_SEED if seed is None else seed)
        samples = tuple({name: draw(rng) for name, draw in draws.items()} for _ in range(runs))
        return tuple(draws), samples, seed

    def stochastic_draw(self, element: ET.Element, where: str) -> Draw:
        kinds = ("ProbabilityDistributionSet", "NormalDistribution", "LogNormalDistribution",
                 "UniformDistribution", "PoissonDistribution", "Histogram",
                 "UserDefinedDistribution")
        child = self.only_child(element, where, kinds)
        where = f"{where}/{_tag(child)}"
        reader = {"ProbabilityDistributionSet": self.probability_set,
                  "NormalDistribution": self.normal, "LogNormalDistribution": self.lognormal,
                  "UniformDistribution": self.uniform, "PoissonDistribution": self.poisson,
                  "Histogram": self.histogram}[_tag(child)]
        return reader(child, where)

    def truncating_range(self, element: ET.Element, where: str
                         ) -> tuple[float, float] | None:
        self.check_children(element, where, {"Range": (0, 1)})
        found = _find(element, "Range")
        if found is None:
            return None
        lower, upper = self.limits(found, f"{where}/Range")
        return float(lower), float(upper)

    def truncated(self, draw: Callable[[np.random.Generator], float],
                  limits: tuple[float, float] | None, where: str) -> Draw:
        """``draw``, drawn again until inside ``limits`` (ends included)."""
        if limits is None:
            return draw
        lower, upper = limits

        def inside(rng: np.random.Generator) -> float:
            for _ in range(MAX_TRIES):
                value = draw(rng)
                if lower <= value <= upper:
                    return value
            raise self.error(f"{where}/Range", f"no draw in {MAX_TRIES} fell inside "
                             f"[{lower}, {upper}]: the Range holds (almost) none of the "
                             "distribution")
        return inside

    def normal(self, element: ET.Element, where: str) -> Draw:
        self.check_attributes(element, where, ("expectedValue", "variance"))
        mean = float(self.number(element, where, "expectedValue"))
        variance = self.number(element, where, "variance")
        if variance < 0:
            raise self.error(where, f"its variance {variance} is negative")
        sd = math.sqrt(float(variance))
        limits = self.truncating_range(element, where)
        return self.truncated(lambda rng: float(rng.normal(mean, sd)), limits, where)

    def lognormal(self, element: ET.Element, where: str) -> Draw:
        self.check_attributes(element, where, ("expectedValue", "variance"))
        mu = float(self.number(element, where, "expectedValue"))
        variance = self.number(element, where, "variance")
        if variance < 0:
            raise self.error(where, f"its variance {variance} is negative")
        sigma = math.sqrt(float(variance))
        limits = self.truncating_range(element, where)
        if limits is not None and limits[0] < 0:
            raise self.error(f"{where}/Range", f"its lowerLimit {limits[0]} is negative (a "
                                               "log-normal value is > 0)")
        return self.truncated(lambda rng: float(rng.lognormal(mu, sigma)), limits, where)

    def poisson(self, element: ET.Element, where: str) -> Draw:
        self.check_attributes(element, where, ("expectedValue",))
        lam = self.number(element, where, "expectedValue")
        if lam < 0 or lam > POISSON_MAX:
            raise self.error(where, f"its expectedValue {lam} is not in [0, {POISSON_MAX:g}]")
        limits = self.truncating_range(element, where)
        if limits is not None and math.floor(limits[1]) < max(0, math.ceil(limits[0])):
            raise self.error(f"{where}/Range", f"[{limits[0]}, {limits[1]}] holds no whole "
                                               "number >= 0, which a Poisson value is")
        rate = float(lam)
        return self.truncated(lambda rng: float(rng.poisson(rate)), limits, where)

    def uniform(self, element: ET.Element, where: str) -> Draw:
        self.check_attributes(element, where, ())
        self.check_children(element, where, {"Range": (1, 1)})
        lower, upper = (float(x) for x in self.limits(_find(element, "Range"), f"{where}/Range"))
        return lambda rng: float(rng.uniform(lower, upper))

    def weighted_pick(self, weights: list[float], where: str
                      ) -> Callable[[np.random.Generator], int]:
        """The index of one of ``weights``, picked by weight with one uniform draw."""
        cumulative = list(itertools.accumulate(weights))
        if cumulative[-1] <= 0:
            raise self.error(where, "its weights are all zero")
        total = cumulative[-1]
        last = len(weights) - 1

        def pick(rng: np.random.Generator) -> int:
            return min(bisect.bisect_right(cumulative, rng.random() * total), last)
        return pick

    def histogram(self, element: ET.Element, where: str) -> Draw:
        self.check_attributes(element, where, ())
        self.check_children(element, where, {"Bin": (1, None)})
        bins: list[tuple[float, float]] = []
        weights: list[float] = []
        for index, child in enumerate(element):
            here = f"{where}/Bin[{index}]"
            self.check_attributes(child, here, ("weight",))
            self.check_children(child, here, {"Range": (1, 1)})
            weights.append(self.weight(child, here))
            lower, upper = self.limits(_find(child, "Range"), f"{here}/Range")
            bins.append((float(lower), float(upper)))
        pick = self.weighted_pick(weights, where)

        def draw(rng: np.random.Generator) -> float:
            lower, upper = bins[pick(rng)]
            return float(rng.uniform(lower, upper))
        return draw

    def probability_set(self, element: ET.Element, where: str) -> Draw:
        self.check_attributes(element, where, ())
        self.check_children(element, where, {"Element": (1, None)})
        values: list[Value] = []
        weights: list[float] = []
        for index, child in enumerate(element):
            here = f"{where}/Element[{index}]"
            self.check_attributes(child, here, ("value", "weight"))
            self.check_children(child, here, {})
            values.append(typed_value(child.get("value", "")))
            weights.append(self.weight(child, here))
        pick = self.weighted_pick(weights, where)
        return lambda rng: values[pick(rng)]

    # ---- Deterministic ----

    def deterministic(self, element: ET.Element, where: str
                      ) -> tuple[tuple[str, ...], tuple[dict[str, Value], ...]]:
        self.check_attributes(element, where, ())
        single = "DeterministicSingleParameterDistribution"
        multi = "DeterministicMultiParameterDistribution"
        self.check_children(element, where, {single: (0, None), multi: (0, None)})
        singles: list[tuple[list[str], list[dict[str, Value]]]] = []
        multis: list[tuple[list[str], list[dict[str, Value]]]] = []
        owner: dict[str, str] = {}
        for index, child in enumerate(element):
            if _tag(child) == single:
                name = self.parameter_name(child, f"{where}/{single}", "parameterName")
                here = f"{where}/{single}[{child.get('parameterName')}]"
                factor = ([name], [{name: v} for v in self.single_values(child, here)])
                singles.append(factor)
            else:
                here = f"{where}/{multi}[{index}]"
                factor = self.value_sets(child, here)
                multis.append(factor)
            for name in factor[0]:
                if name in owner:
                    raise self.error(here, f"parameter {name!r} is also given by {owner[name]}")
                owner[name] = here
        factors = [*singles, *multis]
        count = math.prod(len(rows) for _, rows in factors)
        self.check_count(where, count, "combinations")
        samples = tuple({name: value for row in combination for name, value in row.items()}
                        for combination in itertools.product(*(rows for _, rows in factors)))
        return tuple(name for names, _ in factors for name in names), samples

    def single_values(self, element: ET.Element, where: str) -> list[Value]:
        self.check_attributes(element, where, ("parameterName",))
        child = self.only_child(element, where, ("DistributionSet", "DistributionRange",
                                                 "UserDefinedDistribution"))
        where = f"{where}/{_tag(child)}"
        if _tag(child) == "DistributionSet":
            self.check_attributes(child, where, ())
            self.check_children(child, where, {"Element": (1, None)})
            values = []
            for index, item in enumerate(child):
                here = f"{where}/Element[{index}]"
                self.check_attributes(item, here, ("value",))
                self.check_children(item, here, {})
                values.append(typed_value(item.get("value", "")))
            return values
        self.check_attributes(child, where, ("stepWidth",))
        self.check_children(child, where, {"Range": (1, 1)})
        step = self.number(child, where, "stepWidth")
        if step <= 0:
            raise self.error(where, f"its stepWidth {step} is not > 0")
        lower, upper = self.limits(_find(child, "Range"), f"{where}/Range")
        if (upper - lower) / step >= MAX_SAMPLES:
            raise self.error(where, f"gives more than the {MAX_SAMPLES} values this reader "
                                    "takes")
        steps = int((upper - lower) // step)
        return [float(lower + i * step) for i in range(steps + 1)]

    def value_sets(self, element: ET.Element, where: str
                   ) -> tuple[list[str], list[dict[str, Value]]]:
        """A multi-parameter distribution's parameters and its joint assignments."""
        self.check_attributes(element, where, ())
        self.check_children(element, where, {"ValueSetDistribution": (1, 1)})
        where = f"{where}/ValueSetDistribution"
        value_sets = _find(element, "ValueSetDistribution")
        self.check_attributes(value_sets, where, ())
        self.check_children(value_sets, where, {"ParameterValueSet": (1, None)})
        names: list[str] = []
        rows: list[dict[str, Value]] = []
        for index, value_set in enumerate(value_sets):
            here = f"{where}/ParameterValueSet[{index}]"
            self.check_attributes(value_set, here, ())
            self.check_children(value_set, here, {"ParameterAssignment": (1, None)})
            row: dict[str, Value] = {}
            for assignment in value_set:
                at = f"{here}/ParameterAssignment[{assignment.get('parameterRef')}]"
                self.check_attributes(assignment, at, ("parameterRef", "value"))
                self.check_children(assignment, at, {})
                name = self.parameter_name(assignment, at, "parameterRef")
                if name in row:
                    raise self.error(at, f"parameter {name!r} is assigned twice in one set")
                row[name] = typed_value(assignment.get("value", ""))
            if index == 0:
                names = list(row)
            elif set(row) != set(names):
                raise self.error(here, f"assigns {sorted(row)}, the first set {sorted(names)}: "
                                       "every set of one distribution assigns the same "
                                       "parameters")
            rows.append(row)
        return names, rows


def _what_it_is(children: dict[str, ET.Element]) -> str:
    if "Catalog" in children:
        return "it is a catalog"
    if "Storyboard" in children or "Entities" in children:
        return "it is a scenario"
    return f"it holds {', '.join(f'<{name}>' for name in children) or 'nothing'}"
