"""The entity catalogs of an OpenSCENARIO scenario: a ``CatalogReference`` entity
resolved to its catalog entry.

The entry is looked up in the ``*.xosc`` files of the ``CatalogLocations``
``VehicleCatalog``, ``PedestrianCatalog`` and ``MiscObjectCatalog`` directories
(relative to the scenario's folder) by ``catalogName`` and ``entryName``; each
catalog file is read afresh (its version checked like the scenario's), and the
reference's ``ParameterAssignments`` override the entry's own declarations
(``xosc_parameters.py``) before its ``$name`` attributes are replaced. A directory
that does not exist is skipped; a catalog found in none is an error naming it and
the directories, an entry the catalog lacks one naming the entries it has.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

from scenarios.asam.xosc_document import Doc, attr_text, parse, version
from scenarios.asam.xosc_parameters import (
    check_constraints,
    declared_parameters,
    override,
    substitute,
)

#: the catalogs entities are looked up in
ENTITY_CATALOGS = ("VehicleCatalog", "PedestrianCatalog", "MiscObjectCatalog")


class Catalogs:
    """The entity catalogs a scenario's CatalogLocations name."""

    def __init__(self, doc: Doc):
        self.doc = doc
        self.directories: list[tuple[ET.Element, Path]] = []
        for kind in ENTITY_CATALOGS:
            for directory in doc.root.findall(f"CatalogLocations/{kind}/Directory"):
                path = Path(attr_text(doc, directory, "path"))
                self.directories.append((directory, doc.path.parent / path))

    def entry(self, reference: ET.Element) -> tuple[Doc, ET.Element]:
        doc = self.doc
        catalog = attr_text(doc, reference, "catalogName")
        name = attr_text(doc, reference, "entryName")
        for _, folder in self.directories:
            for file in sorted(folder.glob("*.xosc")) if folder.is_dir() else ():
                cdoc = parse(file, "the catalog file")  # afresh: its parameters differ
                found = cdoc.root.find("Catalog")
                if found is None or found.get("name") != catalog:
                    continue
                version(cdoc)
                entries = {e.get("name"): e for e in found}
                if name not in entries:
                    raise doc.error(reference, f"catalog {catalog} ({file}) has no entry "
                                               f"{name} (it has: {', '.join(map(str, entries))})")
                return cdoc, self._resolved(cdoc, entries[name], reference)
        looked = ", ".join(f"{folder}" + ("" if folder.is_dir() else " (no such directory)")
                           for _, folder in self.directories) or \
            "no entity catalog in CatalogLocations"
        raise doc.error(reference, f"cannot find catalog {catalog} (looked in: {looked})",
                        "catalogName")

    def _resolved(self, cdoc: Doc, entry: ET.Element, reference: ET.Element) -> ET.Element:
        declared = declared_parameters(cdoc, entry.find("ParameterDeclarations"))
        assignments = {}
        for assignment in reference.findall("ParameterAssignments/ParameterAssignment"):
            assignments[attr_text(self.doc, assignment, "parameterRef")] = \
                attr_text(self.doc, assignment, "value")
        where = self.doc.where(reference)
        override(self.doc, declared, assignments,
                  lambda given: f"{where}/ParameterAssignments/ParameterAssignment"
                                f"[parameterRef={given}]",
                  f"catalog entry {entry.get('name')} ({cdoc.path})")
        check_constraints(cdoc, declared)
        substitute(cdoc, entry, {name: d.value for name, d in declared.items()})
        return entry
