"""docs/architecture.md's map lists every module under its folder, and nothing else."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FOLDERS = ("scenarios", "sdc", "analysis", "truths", "benchmarks")
SOURCE = ("*.py", "*.c", "*.h", "*.html")


def mapped_files() -> set[Path]:
    """The files the map's tables name: each relative to its heading's first folder, or
    from the root when it starts with a top-level folder (a glob names several)."""
    text = (ROOT / "docs" / "architecture.md").read_text()
    section = text.split("## Every module, one line each", 1)[1].split("\n## ", 1)[0]
    files: set[Path] = set()
    base = ROOT
    for line in section.splitlines():
        heading = re.match(r"### `?([\w/]+/)", line)
        if heading:
            base = ROOT / heading.group(1)
        elif line.startswith("| `"):
            for name in re.findall(r"`([^`]+)`", line.split(" | ")[0]):
                start = ROOT if name.split("/")[0] in FOLDERS else base
                found = sorted(start.glob(name))
                assert found, f"the map names {name!r}, which does not exist"
                files.update(p for p in found if p.is_file())
    return files


def source_files() -> set[Path]:
    return {p for folder in FOLDERS for pattern in SOURCE for p in (ROOT / folder).rglob(pattern)
            if p.name != "__init__.py" or p.parent.name == "cli"
            if "__pycache__" not in p.parts and "catalog" not in p.parts}


def test_the_map_names_every_module_and_only_modules_that_exist():
    mapped = mapped_files()
    missing = sorted(str(p.relative_to(ROOT)) for p in source_files() - mapped)
    assert not missing, f"modules missing from docs/architecture.md's map: {missing}"


def import_cycles() -> list[list[str]]:
    """The groups of modules that import each other round a circle, imports inside
    functions included (Tarjan's strongly connected components of grimp's graph)."""
    import grimp

    graph = grimp.build_graph("scenarios", "sdc", "analysis")
    edges = {m: sorted(graph.find_modules_directly_imported_by(m)) for m in sorted(graph.modules)}
    order: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    groups: list[list[str]] = []

    def visit(module: str) -> None:
        order[module] = low[module] = len(order)
        stack.append(module)
        for other in edges[module]:
            if other not in order:
                visit(other)
                low[module] = min(low[module], low[other])
            elif other in stack:
                low[module] = min(low[module], order[other])
        if low[module] == order[module]:
            group = stack[stack.index(module):]
            del stack[stack.index(module):]
            if len(group) > 1:
                groups.append(sorted(group))

    for module in edges:
        if module not in order:
            visit(module)
    return groups


def test_no_modules_import_each_other_round_a_circle():
    assert import_cycles() == []
