"""One OpenSCENARIO scenario or catalog file as the scenario reader holds it
(:class:`Doc`): parsed, each of its elements named by its path in the file, and the
reads of an attribute (text, float, whole number) that refuse naming that path.

An element's path is its tags from the root (the root's own left out), each step
named by its ``name`` or ``entityRef`` where it has one, else by its place among
siblings of its tag where there are several:
``Storyboard/Story[name=s]/Act[name=a]/ManeuverGroup[name=g]/Maneuver[name=m]``, and
``…@attribute`` for an attribute at fault. A :class:`SpecError` raised here has that
path as its field and the file as its file.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

from scenarios.asam.xosc_file import check_version, number, read_openscenario
from scenarios.common.errors import SpecError

#: the OpenSCENARIO minor versions (of 1.x) a scenario or catalog is read in: 1.0 to 1.3
REV_MINORS = (0, 1, 2, 3)
_REQUIRED = object()


class Doc:
    """One parsed file: names its elements by path, and refuses them."""

    def __init__(self, path: Path, root: ET.Element):
        self.path = path
        self.root = root
        self.parents = {child: parent for parent in root.iter() for child in parent}

    def where(self, element: ET.Element) -> str:
        steps = []
        while element is not self.root:
            parent = self.parents[element]
            steps.append(_step(element, parent))
            element = parent
        return "/".join(reversed(steps)) or self.root.tag

    def error(self, element: ET.Element, message: str, attribute: str | None = None
              ) -> SpecError:
        where = self.where(element) + (f"@{attribute}" if attribute else "")
        return SpecError(where, message, self.path)

    def outside(self, element: ET.Element, what: str = "") -> SpecError:
        return self.error(element, f"{element.tag} is outside the subset sdc runs"
                                   + (f" ({what})" if what else ""))


def _step(element: ET.Element, parent: ET.Element) -> str:
    for key in ("name", "entityRef"):
        if element.get(key) is not None:
            return f"{element.tag}[{key}={element.get(key)}]"
    same = [child for child in parent if child.tag == element.tag]
    if len(same) > 1:
        return f"{element.tag}[{same.index(element) + 1}]"
    return element.tag


def parse(path: Path, what: str) -> Doc:
    """The OpenSCENARIO file at ``path`` (``what`` names it in a FileError)."""
    return Doc(path, read_openscenario(path, what))


def version(doc: Doc) -> int:
    """The file's minor version (of 1.x), one of :data:`REV_MINORS`."""
    return check_version(doc.root, REV_MINORS, doc.error)


def attr_text(doc: Doc, element: ET.Element, name: str, default=_REQUIRED):
    """The attribute ``name`` of ``element``; missing, ``default`` (none: refused)."""
    value = element.get(name)
    if value is None:
        if default is _REQUIRED:
            raise doc.error(element, f"{element.tag} has no {name}")
        return default
    return value


def attr_float(doc: Doc, element: ET.Element, name: str, default=_REQUIRED) -> float:
    """The attribute ``name`` of ``element`` as a float; missing, ``default`` (none:
    refused)."""
    if element.get(name) is None and default is not _REQUIRED:
        return default
    return float(number(element, name,
                        lambda message, attribute: doc.error(element, message, attribute)))


def attr_int(doc: Doc, element: ET.Element, name: str) -> int:
    """The attribute ``name`` of ``element`` as a whole number."""
    value = attr_float(doc, element, name)
    if not value.is_integer():
        raise doc.error(element, f"{element.tag}'s {name} is {element.get(name)!r}, not a "
                                 f"whole number", name)
    return int(value)
