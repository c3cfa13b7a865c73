"""The ``Deterministic`` part of a parameter value distribution: the cartesian product
of its distributions.

- The product of its ``DeterministicSingleParameterDistribution`` elements (in file
  order, the first varying slowest), then of its
  ``DeterministicMultiParameterDistribution`` elements (in file order: each a list of
  joint assignments, its ``ParameterValueSet`` elements). Singles come first whatever
  the file's order (scenariogeneration writes the multi-parameter ones first).
- ``DistributionSet``: its ``Element`` values. ``DistributionRange stepWidth``:
  ``lower + i * step`` for i = 0, 1, ... while <= upper, computed in decimal arithmetic
  from the file's text (so 0.1 to 0.3 by 0.1 is 0.1, 0.2, 0.3: both ends when on the
  grid); a ``stepWidth`` not > 0 is refused.
- A ``Deterministic`` with no distribution is one run with no parameter set.
- Refused: a parameter given by two distributions, or twice in one value set; value
  sets of one multi-parameter distribution assigning different parameters; a product
  of more than :data:`~scenarios.asam.xosc_element_checks.MAX_SAMPLES` samples.
"""

from __future__ import annotations

import itertools
import math
import xml.etree.ElementTree as ET

from scenarios.asam.xosc_element_checks import (
    MAX_SAMPLES,
    ElementChecks,
    Value,
    find_child,
    typed_value,
)
from scenarios.asam.xosc_file import tag


class DeterministicReader(ElementChecks):
    """The reading of a ``Deterministic`` element (the checks its elements go through
    inherited)."""

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
            if tag(child) == single:
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
        where = f"{where}/{tag(child)}"
        if tag(child) == "DistributionSet":
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
        lower, upper = self.limits(find_child(child, "Range"), f"{where}/Range")
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
        value_sets = find_child(element, "ValueSetDistribution")
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

