"""What both OpenSCENARIO readers (a scenario, ``xosc_scenario.py``, and a parameter
value distribution, ``xosc_distribution.py``) do alike to a ``.xosc`` file: read and
parse it, check that its root is ``OpenSCENARIO`` and its ``FileHeader``'s version one
the reader knows, and read a number attribute.

- The file is read with ``xml.etree.ElementTree`` (not scenariogeneration's
  ``ParseOpenScenario``, which prints, warns rather than raises and keeps numbers as
  strings). A file that cannot be read, is not well-formed XML or whose root element is
  not ``OpenSCENARIO`` (a namespace on it is ignored) is a :class:`FileError` naming it.
- The version is the ``FileHeader``'s ``revMajor`` and ``revMinor``, whole numbers
  (white space around them ignored); the major is :data:`REV_MAJOR`, the minors are the
  reader's.
- A number attribute reads as a finite decimal number (``80``, ``-2.5``, ``1e3``; not
  ``NaN``, ``inf``, a ``$name`` or a value beyond a double's range).

Each reader names an element its own way (a scenario by the element's path in the
file, a distribution by the path it has walked), so the checks here refuse through a
``refuse`` function the reader gives, which makes the :class:`SpecError`.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from collections.abc import Callable, Sequence
from decimal import Decimal
from pathlib import Path

from scenarios.common.errors import FileError, SpecError
from scenarios.common.file_read import read_bytes

#: the OpenSCENARIO major version read (1.x)
REV_MAJOR = 1
#: a decimal number as OpenSCENARIO writes a Double
NUMBER = re.compile(r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?")
#: a whole number
INTEGER = re.compile(r"[+-]?\d+")

#: ``refuse(message, attribute)``: the reader's error for the element being read
#: (``attribute`` the one at fault, or None: the element as a whole)
Refuse = Callable[[str, "str | None"], SpecError]


def tag(element: ET.Element) -> str:
    """The element's name without a namespace."""
    return element.tag.rpartition("}")[2] if isinstance(element.tag, str) else ""


def read_openscenario(path: Path, what: str) -> ET.Element:
    """The root element of the OpenSCENARIO file at ``path`` (``what`` names the file in
    a :class:`FileError`: missing, unreadable, not XML, not OpenSCENARIO)."""
    data = read_bytes(path, what)
    try:
        root = ET.fromstring(data)
    except ET.ParseError as e:
        raise FileError(path, f"{what} is not XML: not well-formed XML ({e})") from None
    if tag(root) != "OpenSCENARIO":
        raise FileError(path, f"{what} is not OpenSCENARIO (its root element is "
                              f"<{tag(root)}>, not <OpenSCENARIO>)")
    return root


def check_version(root: ET.Element, minors: Sequence[int],
                  refuse: Callable[[ET.Element, str], SpecError], purpose: str = "") -> int:
    """The minor version of the file whose root is ``root``, one of ``minors`` (of
    :data:`REV_MAJOR`); else ``refuse(element, message)`` (``purpose``, e.g. " for
    parameter value distributions", says what the versions are read for)."""
    header = next((child for child in root if tag(child) == "FileHeader"), None)
    if header is None:
        raise refuse(root, "OpenSCENARIO has no FileHeader")
    major, minor = header.get("revMajor"), header.get("revMinor")
    if major is None or minor is None:
        raise refuse(header, "the FileHeader lacks revMajor or revMinor (the OpenSCENARIO "
                             "version)")
    if not (INTEGER.fullmatch(major.strip()) and INTEGER.fullmatch(minor.strip())) \
            or int(major) != REV_MAJOR or int(minor) not in minors:
        raise refuse(header, f"OpenSCENARIO {major}.{minor} is not read{purpose}: only "
                             f"{REV_MAJOR}.{minors[0]} to {REV_MAJOR}.{minors[-1]}")
    return int(minor)


def number(element: ET.Element, name: str, refuse: Refuse) -> Decimal:
    """The attribute ``name`` of ``element`` as a finite decimal number, exactly as the
    file writes it; missing or not one: ``refuse``."""
    text = element.get(name)
    if text is None:
        raise refuse(f"{tag(element)} has no {name}", None)
    if not NUMBER.fullmatch(text.strip()):
        raise refuse(f"{tag(element)}'s {name} is {text!r}, not a number", name)
    value = Decimal(text.strip())
    if not math.isfinite(float(value)):
        raise refuse(f"{tag(element)}'s {name} is {text!r}, beyond a double's range", name)
    return value
