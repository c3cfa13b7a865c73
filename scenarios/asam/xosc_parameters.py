"""The parameter layer of an OpenSCENARIO scenario (and of its catalog entries):
``ParameterDeclarations`` read and typed, a caller's overrides applied, each value
checked against its ``ConstraintGroup``s, and every ``$name`` attribute replaced by
its value.

- Typing by ``parameterType``: ``integer``/``int``/``unsignedInt``/``unsignedShort``
  an int (the unsigned ones in their range), ``double`` a finite float, ``boolean`` a
  bool (``true``/``1``, ``false``/``0``), ``string``/``dateTime`` a str.
- Overrides: the ``parameters`` given to ``read_scenario`` (names with or without
  ``$``; an undeclared name, or one given twice, is an error) or a catalog
  reference's ``ParameterAssignments``. A Python number given for a string parameter
  becomes its ``str``.
- Constraints: a value must satisfy its declaration's ``ConstraintGroup``s (1.1+: any
  group whose every ``ValueConstraint`` holds); a string or boolean only by
  ``equalTo``/``notEqualTo``.
- Substitution: every attribute that is a ``$name`` (but ``parameterRef`` and
  ``variableRef``, which name one) is replaced by its value, with the nested
  declarations of a Story, Maneuver or catalog entry in scope inside it; the
  FileHeader's free text is left alone.
- Refused: a declaration whose value is itself a reference, 1.2's ``${...}``
  expressions, a ``$name`` no declaration in scope names, a parameter declared twice,
  a ``parameterType`` not above, and a value not of its type.
"""

from __future__ import annotations

import dataclasses
import math
import xml.etree.ElementTree as ET
from collections.abc import Callable, Mapping

from scenarios.asam.xosc_document import Doc, attr_text
from scenarios.asam.xosc_file import INTEGER, NUMBER
from scenarios.common.errors import SpecError

ParameterValue = bool | int | float | str

_INT_TYPES = {"integer": None, "int": None, "unsignedInt": 2**32, "unsignedShort": 2**16}
_TYPES = (*_INT_TYPES, "double", "boolean", "string", "dateTime")
_NAME_ATTRIBUTES = ("parameterRef", "variableRef")  # they name a parameter, not use one
_RULES: dict[str, Callable[[object, object], bool]] = {
    "equalTo": lambda a, b: a == b, "notEqualTo": lambda a, b: a != b,
    "greaterThan": lambda a, b: a > b, "lessThan": lambda a, b: a < b,
    "greaterOrEqual": lambda a, b: a >= b, "lessOrEqual": lambda a, b: a <= b,
}


def _typed(text: str, kind: str) -> ParameterValue | None:
    """``text`` as a value of parameterType ``kind`` (None: not one)."""
    if kind in _INT_TYPES:
        if not INTEGER.fullmatch(text.strip()):
            return None
        value = int(text)
        bound = _INT_TYPES[kind]
        return value if bound is None or 0 <= value < bound else None
    if kind == "double":
        return float(text) if NUMBER.fullmatch(text.strip()) else None
    if kind == "boolean":
        return {"true": True, "1": True, "false": False, "0": False}.get(text.strip())
    return text


def _given(value: object, kind: str) -> ParameterValue | None:
    """A caller's override ``value`` as parameterType ``kind`` (None: not one)."""
    if isinstance(value, str):
        return _typed(value, kind)
    if isinstance(value, bool):
        return value if kind == "boolean" else None
    if isinstance(value, int | float) and math.isfinite(value):
        if kind in _INT_TYPES:
            return _typed(str(int(value)), kind) if float(value).is_integer() else None
        if kind == "double":
            return float(value)
        if kind in ("string", "dateTime"):
            return str(value)
    return None


def _as_text(value: ParameterValue) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(value) if isinstance(value, float) else str(value)


@dataclasses.dataclass
class Declared:
    element: ET.Element
    kind: str
    value: ParameterValue


def declared_parameters(doc: Doc, declarations: ET.Element | None) -> dict[str, Declared]:
    found: dict[str, Declared] = {}
    for declaration in [] if declarations is None else declarations:
        if declaration.tag != "ParameterDeclaration":
            raise doc.outside(declaration)
        name = attr_text(doc, declaration, "name")
        kind = attr_text(doc, declaration, "parameterType")
        text = attr_text(doc, declaration, "value")
        if name in found:
            raise doc.error(declaration, f"parameter {name} is declared twice")
        if kind not in _TYPES:
            raise doc.error(declaration, f"parameterType {kind!r} is not one of "
                                         f"{', '.join(_TYPES)}", "parameterType")
        if text.startswith("$"):
            raise doc.error(declaration, f"a ParameterDeclaration's value given as {text!r} "
                                         f"(a reference or expression) is outside the subset "
                                         f"sdc runs", "value")
        value = _typed(text, kind)
        if value is None or isinstance(value, float) and not math.isfinite(value):
            raise doc.error(declaration, f"value {text!r} is not of parameterType {kind}",
                            "value")
        found[name] = Declared(declaration, kind, value)
    return found


def override(doc: Doc, declared: dict[str, Declared], parameters: Mapping[str, object],
              field: Callable[[str], str], owner: str) -> None:
    seen: dict[str, str] = {}
    for given, value in parameters.items():
        name = given[1:] if given.startswith("$") else given
        if name in seen:
            raise SpecError(field(given), f"parameter {name} is given twice (as {seen[name]} "
                                          f"and {given})", doc.path)
        seen[name] = given
        if name not in declared:
            names = ", ".join(declared) or "none"
            raise SpecError(field(given), f"{owner} declares no parameter {name} (it "
                                          f"declares: {names})", doc.path)
        typed = _given(value, declared[name].kind)
        if typed is None or isinstance(typed, float) and not math.isfinite(typed):
            raise SpecError(field(given), f"{value!r} is not of parameterType "
                                          f"{declared[name].kind}, parameter {name}'s",
                            doc.path)
        declared[name].value = typed


def check_constraints(doc: Doc, declared: dict[str, Declared]) -> None:
    for name, parameter in declared.items():
        groups = parameter.element.findall("ConstraintGroup")
        if not groups:
            continue
        passed = False
        for group in groups:
            holds = True
            for constraint in group:
                rule = attr_text(doc, constraint, "rule")
                bound = _typed(attr_text(doc, constraint, "value"), parameter.kind)
                numeric = parameter.kind in _INT_TYPES or parameter.kind == "double"
                if constraint.tag != "ValueConstraint" or rule not in _RULES or bound is None \
                        or not numeric and rule not in ("equalTo", "notEqualTo"):
                    raise doc.outside(constraint, f"rule {rule} on {bound!r}")
                holds = holds and _RULES[rule](parameter.value, bound)
            passed = passed or holds
        if not passed:
            raise doc.error(parameter.element, f"parameter {name} = {parameter.value!r} "
                                               f"breaks its ConstraintGroup")


def substitute(doc: Doc, element: ET.Element, scope: Mapping[str, ParameterValue]) -> None:
    """Replace every ``$name`` attribute value under ``element`` (its own too)."""
    for attribute, text in element.attrib.items():
        if not text.startswith("$") or attribute in _NAME_ATTRIBUTES:
            continue
        if text.startswith("${"):
            raise doc.error(element, f"the expression {text} (OpenSCENARIO 1.2's) is "
                                     f"outside the subset sdc runs", attribute)
        name = text[1:]
        if name not in scope:
            names = ", ".join(scope) or "none"
            raise doc.error(element, f"{text} names no declared parameter (declared: "
                                     f"{names})", attribute)
        element.set(attribute, _as_text(scope[name]))
    for child in element:
        if child.tag in ("ParameterDeclarations", "FileHeader"):
            continue
        inner = scope
        local = child.find("ParameterDeclarations")
        if local is not None:
            declared = declared_parameters(doc, local)
            check_constraints(doc, declared)
            inner = {**scope, **{name: d.value for name, d in declared.items()}}
        substitute(doc, child, inner)

