"""The checks every element of a parameter value distribution file goes through
(:class:`ElementChecks`, which the stochastic and deterministic readers build on),
and how a distribution's values are typed.

- An element may hold only the attributes and children the standard puts there, each
  child as many times as it allows; a missing one, an unknown one, or one too many is
  refused, naming the element's path as the reader walked it
  (``ParameterValueDistribution/Stochastic/StochasticDistribution[x]/...``).
- Where one of several distributions goes, exactly one must stand; a
  ``UserDefinedDistribution`` (its meaning is the tool's own) is refused.
- A number is a finite decimal number (``xosc_file.py``), kept exactly as written (a
  :class:`~decimal.Decimal`); a parameter reference or expression is not resolved in a
  distribution file. A ``Range``'s lower limit must not be above its upper, a weight
  must not be negative.
- A parameter's leading ``$`` is dropped (``$Ego_Speed`` and ``Ego_Speed`` name the
  same parameter); an empty name is refused.
- Values are typed (:func:`typed_value`): a value that reads as a finite decimal
  number (``80``, ``-2.5``, ``1e3``) is a float, anything else (``true``, ``car``,
  ``NaN``) stays a str.
- No file gives more than :data:`MAX_SAMPLES` samples.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from decimal import Decimal
from pathlib import Path

from scenarios.asam.xosc_file import NUMBER, number, tag
from scenarios.common.errors import SpecError

#: the most samples a file may give (numberOfTestRuns, or a deterministic product)
MAX_SAMPLES = 1_000_000

Value = float | str


def typed_value(text: str) -> Value:
    """``text`` as a float when it reads as a finite decimal number, else unchanged."""
    stripped = text.strip()
    return float(stripped) if NUMBER.fullmatch(stripped) else text


def find_child(element: ET.Element, name: str) -> ET.Element | None:
    """The first child of ``element`` named ``name`` (whatever its namespace)."""
    return next((child for child in element if tag(child) == name), None)


class ElementChecks:
    """One file's reading: where an error is, and the checks every element goes through."""

    def __init__(self, path: Path):
        self.path = path

    def error(self, where: str, message: str) -> SpecError:
        return SpecError(where, message, self.path)

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
            name = tag(child)
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
        if len(children) != 1 or tag(children[0]) not in names:
            found = ", ".join(f"<{tag(c)}>" for c in children) or "nothing"
            raise self.error(where, f"must hold exactly one of {', '.join(names)}; it holds "
                                    f"{found}")
        child = children[0]
        if tag(child) == "UserDefinedDistribution":
            raise self.error(f"{where}/UserDefinedDistribution",
                             f"a UserDefinedDistribution (type {child.get('type')!r}) means what "
                             "its tool makes of it; this reader cannot sample it")
        return child

    def number(self, element: ET.Element, where: str, name: str) -> Decimal:
        """The attribute ``name`` of the element at ``where``, a finite number."""
        text = element.get(name, "")
        if text.strip().startswith("$"):
            raise self.error(where, f"its {name} {text!r} is a parameter reference or "
                                    "expression, which a distribution file does not resolve")
        return number(element, name, lambda message, _: self.error(where, message))

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
