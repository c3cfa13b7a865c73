"""What every report of a sweep directory reads and writes: its rows and manifest in,
the HTML page, ``summary.json``, ``report.md`` and the JUnit XML out (the pages
themselves: :mod:`analysis.report.sweep_page`, :mod:`analysis.report.rare_page`)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from xml.etree import ElementTree

import pandas as pd

from analysis.measures.row_columns import RowCol
from analysis.measures.sweep_manifest import MANIFEST_FILE, READ_KEYS, SweepDir, SweepManifest
from analysis.report.page_parts import row_outcome
from analysis.stats.gate import Gate
from scenarios.common.errors import SpecError
from scenarios.common.file_read import read_json, read_parquet, require_keys
from scenarios.common.plain_json import json_plain, json_scalar

#: the result columns the report reads (a results file without one is another version's)
RESULT_COLUMNS = (RowCol.run_id, RowCol.run_index, RowCol.sample, RowCol.controller,
                  RowCol.backend, RowCol.status, RowCol.error, RowCol.collision,
                  RowCol.collision_with, RowCol.collision_time_s, RowCol.min_gap_obstacle_m,
                  RowCol.min_ttc_s, RowCol.wall_time_s)
#: a report's files in the sweep directory (the page's is the default, --out moves it)
HTML_FILE, SUMMARY_FILE, MARKDOWN_FILE = "report.html", "summary.json", "report.md"


class ReportError(SpecError):
    """A sweep directory or an option the report cannot use; ``field`` names which."""


@dataclasses.dataclass(frozen=True)
class Report:
    summary: dict
    html_path: Path
    summary_path: Path
    markdown_path: Path
    junit_path: Path | None
    terminal: list[str]
    gate: Gate | None = None  # with --fail-above or --min-completed

    @property
    def gate_failed(self) -> list[str]:
        """The controllers that fail the gate."""
        return self.gate.failed if self.gate else []


def load_results(sweep_dir: Path) -> tuple[pd.DataFrame, SweepManifest]:
    """The result rows (consolidated and any parts not yet consolidated) and the manifest."""
    sweep_dir = Path(sweep_dir)
    manifest_path = sweep_dir / MANIFEST_FILE
    if not manifest_path.exists():
        raise ReportError("DIR", f"{sweep_dir} is not a sweep directory (no manifest.json)")
    manifest = require_keys(read_json(manifest_path, "the sweep manifest"), READ_KEYS,
                            manifest_path, "the sweep manifest")
    files = [sweep_dir / SweepDir.results] + sorted((sweep_dir / SweepDir.parts).glob("*.parquet"))
    frames = [read_parquet(f, "the results file", required=RESULT_COLUMNS).to_pandas()
              for f in files if f.exists()]
    if not frames:
        raise ReportError("DIR", f"{sweep_dir} has no results yet")
    results = (pd.concat(frames, ignore_index=True).drop_duplicates(RowCol.run_id)
               .sort_values(RowCol.run_index).reset_index(drop=True))
    return results, SweepManifest.from_dict(manifest)


def junit_xml(results: pd.DataFrame, name: str) -> str:
    """One test case per run: a collision is a failure, an error or timeout an error."""
    suite = ElementTree.Element("testsuite", name=name, tests=str(len(results)))
    n_failures = n_errors = 0
    for row in results.to_dict("records"):
        case = ElementTree.SubElement(suite, "testcase",
                                      classname=f"{name}.{row[RowCol.controller]}",
                                      name=row[RowCol.run_id],
                                      time=f"{json_scalar(row[RowCol.wall_time_s]) or 0:.3f}")
        if row[RowCol.status] != "ok":
            n_errors += 1
            ElementTree.SubElement(case, "error", message=row_outcome(row),
                                   type=row[RowCol.status])
        elif row[RowCol.collision]:
            n_failures += 1
            ElementTree.SubElement(case, "failure", message=row_outcome(row), type="collision")
    suite.set("failures", str(n_failures))
    suite.set("errors", str(n_errors))
    return ElementTree.tostring(suite, encoding="unicode", xml_declaration=True) + "\n"


def write_files(sweep_dir: Path, html_path: Path, page: str, plain: dict, markdown: str,
                junit_path: Path | None, results: pd.DataFrame, name: str,
                terminal: list[str], gate: Gate | None = None) -> Report:
    """Write a report's files: the page at ``html_path``, ``plain`` as
    ``DIR/summary.json``, ``markdown`` as ``DIR/report.md`` and, with ``junit_path``,
    the runs as JUnit XML (the suite ``name``); the :class:`Report` that says so, with
    the ``terminal`` lines ``sdc report`` prints."""
    html_path.write_text(page)
    summary_path = sweep_dir / SUMMARY_FILE
    summary_path.write_text(json.dumps(json_plain(plain), indent=2) + "\n")
    markdown_path = sweep_dir / MARKDOWN_FILE
    markdown_path.write_text(markdown)
    if junit_path is not None:
        Path(junit_path).write_text(junit_xml(results, name))
    return Report(plain, html_path, summary_path, markdown_path, junit_path, terminal, gate)
