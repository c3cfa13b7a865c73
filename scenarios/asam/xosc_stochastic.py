"""The ``Stochastic`` part of a parameter value distribution: each
``StochasticDistribution`` made into a draw, and the runs drawn.

- ``Stochastic numberOfTestRuns randomSeed``: ``numberOfTestRuns`` runs, each drawing
  every ``StochasticDistribution`` once from ``np.random.default_rng(randomSeed)``.
  The draws are made run by run and, inside a run, parameter by parameter in file
  order, all from that one generator; so the first runs of a file are the same
  whatever its ``numberOfTestRuns``, and the same file gives the same samples in any
  process. Without a ``randomSeed`` the seed is :data:`DEFAULT_SEED` (0), never a
  fresh one; ``Distribution.seed`` is then ``None``. A seed is a whole number >= 0
  (``randomSeed`` is a Double in the schema: ``"42.0"`` is 42, ``"42.5"`` is refused).
  ``numberOfTestRuns`` must be a whole number >= 1; a parameter given twice is refused.
- ``NormalDistribution expectedValue variance``: mean and VARIANCE (the standard: "the
  square of the standard deviation"), so the draw is ``rng.normal(mean, sqrt(variance))``.
- ``LogNormalDistribution expectedValue variance``: the mean mu and the variance
  sigma^2 of the underlying normal ln X, so X = exp(N(mu, sigma^2)) (``rng.lognormal(mu,
  sigma)``) and E[X] = exp(mu + sigma^2 / 2). The standard's model allows any
  ``expectedValue`` in ]-inf, inf[, which the mean of a log-normal variable (always > 0)
  could not be; TIER IV's scenario_simulator_v2 reads it so too. A negative variance
  (of either) is refused.
- ``PoissonDistribution expectedValue``: lambda, in [0, :data:`POISSON_MAX`]; a draw is
  a whole number (as a float).
- ``UniformDistribution``: uniform in its ``Range`` (``rng.uniform(lower, upper)``).
- A ``Range`` under a Normal, LogNormal or Poisson truncates it: a draw outside it
  (ends included) is drawn again, from the same generator, until one lies inside; a
  Range in which :data:`MAX_TRIES` draws in a row all fall outside holds (almost) none
  of the distribution and is refused rather than approximated. A LogNormal's Range
  with a negative lowerLimit, and a Poisson's holding no whole number >= 0, are
  refused outright.
- ``Histogram``: a bin picked by weight (one uniform draw), then a value uniform inside
  the bin's ``Range`` (a second draw).
- ``ProbabilityDistributionSet``: an ``Element`` value picked by weight (one draw).
  Weights that are all zero are refused.

Each parameter's distribution is also kept as a sweep's ``[sweep.params]`` would state
it where it is one of them (a uniform; a normal that no Range truncates), so that
``sdc search`` and ``sdc estimate`` can draw from it themselves.
"""

from __future__ import annotations

import bisect
import itertools
import math
import re
import xml.etree.ElementTree as ET
from collections.abc import Callable

import numpy as np

from scenarios.asam.xosc_element_checks import ElementChecks, Value, find_child, typed_value
from scenarios.asam.xosc_file import tag

#: the seed of a ``Stochastic`` distribution without a ``randomSeed``
DEFAULT_SEED = 0
#: draws in a row outside a truncating Range before the Range is refused
MAX_TRIES = 10_000
#: the largest Poisson expectedValue (numpy's Poisson draws stop near 9.2e18)
POISSON_MAX = 1e15

_WHOLE = re.compile(r"\+?\d+")

Draw = Callable[[np.random.Generator], Value]
#: a parameter's distribution as a sweep's ``[sweep.params]`` states one (its kind and
#: arguments: ``scenarios/spec/sweep_spec.py``'s ``Param``), where it is one of them
Law = tuple[str, tuple]


class StochasticReader(ElementChecks):
    """The reading of a ``Stochastic`` element (the checks its elements go through
    inherited)."""

    def stochastic(self, element: ET.Element, where: str
                   ) -> tuple[tuple[str, ...], tuple[dict[str, Value], ...], int | None,
                              dict[str, Law | None]]:
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
        laws: dict[str, Law | None] = {}
        for child in element:
            name = self.parameter_name(child, f"{where}/StochasticDistribution",
                                       "parameterName")
            here = f"{where}/StochasticDistribution[{child.get('parameterName')}]"
            self.check_attributes(child, here, ("parameterName",))
            if name in draws:
                raise self.error(here, f"parameter {name!r} has a second StochasticDistribution")
            draws[name] = self.stochastic_draw(child, here)
            laws[name] = _law(child[0])
        rng = np.random.default_rng(DEFAULT_SEED if seed is None else seed)
        samples = tuple({name: draw(rng) for name, draw in draws.items()} for _ in range(runs))
        return tuple(draws), samples, seed, laws

    def stochastic_draw(self, element: ET.Element, where: str) -> Draw:
        kinds = ("ProbabilityDistributionSet", "NormalDistribution", "LogNormalDistribution",
                 "UniformDistribution", "PoissonDistribution", "Histogram",
                 "UserDefinedDistribution")
        child = self.only_child(element, where, kinds)
        where = f"{where}/{tag(child)}"
        reader = {"ProbabilityDistributionSet": self.probability_set,
                  "NormalDistribution": self.normal, "LogNormalDistribution": self.lognormal,
                  "UniformDistribution": self.uniform, "PoissonDistribution": self.poisson,
                  "Histogram": self.histogram}[tag(child)]
        return reader(child, where)

    def truncating_range(self, element: ET.Element, where: str
                         ) -> tuple[float, float] | None:
        self.check_children(element, where, {"Range": (0, 1)})
        found = find_child(element, "Range")
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

    def centre_and_spread(self, element: ET.Element, where: str) -> tuple[float, float]:
        """A Normal's or LogNormal's expectedValue and standard deviation (the square
        root of its variance)."""
        self.check_attributes(element, where, ("expectedValue", "variance"))
        centre = float(self.number(element, where, "expectedValue"))
        variance = self.number(element, where, "variance")
        if variance < 0:
            raise self.error(where, f"its variance {variance} is negative")
        return centre, math.sqrt(float(variance))

    def normal(self, element: ET.Element, where: str) -> Draw:
        mean, sd = self.centre_and_spread(element, where)
        limits = self.truncating_range(element, where)
        return self.truncated(lambda rng: float(rng.normal(mean, sd)), limits, where)

    def lognormal(self, element: ET.Element, where: str) -> Draw:
        mu, sigma = self.centre_and_spread(element, where)
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
        range_ = find_child(element, "Range")
        lower, upper = (float(x) for x in self.limits(range_, f"{where}/Range"))
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
            lower, upper = self.limits(find_child(child, "Range"), f"{here}/Range")
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


def _law(element: ET.Element) -> Law | None:
    """The distribution of an element already read (so its numbers are checked) as a
    sweep states one: a uniform, or a normal that no Range truncates (its standard
    deviation the square root of its variance); None for any other."""
    if tag(element) == "UniformDistribution":
        limits = find_child(element, "Range")
        return ("uniform", (float(limits.get("lowerLimit")), float(limits.get("upperLimit"))))
    if tag(element) == "NormalDistribution" and find_child(element, "Range") is None:
        return ("normal", (float(element.get("expectedValue")),
                           math.sqrt(float(element.get("variance")))))
    return None
