"""A search's or estimate's report pages: ``report.md``, the HTML page and the terminal
lines, from its :class:`~analysis.rare.adaptive_summary.RareSummary` in the words of
:mod:`analysis.report.rare_report`; :func:`write_rare_report` writes them with
``summary.json`` and the JUnit XML."""

from __future__ import annotations

import html
import math
from pathlib import Path

import pandas as pd

from analysis.measures.commands import replay_command
from analysis.measures.row_columns import RowCol
from analysis.measures.sweep_manifest import SweepManifest
from analysis.rare.adaptive_summary import RareSummary, adaptive_summary, saved_summary
from analysis.rare.failure_modes import mode_lines
from analysis.report import rare_report
from analysis.report.page_parts import (
    figure_html,
    html_document,
    markdown_table,
    row_outcome,
    table_html,
)
from analysis.report.report_files import MARKDOWN_FILE, Report, write_files

MAX_TERMINAL_MODES = 8  # failure modes printed by `sdc report`; all are in report.md
#: what the stuck table of a search or estimate holds
STUCK_WORDS = ("Runs that did not collide but stood still at the end (the outcome stuck), "
               "grouped into modes the same way; P(collision) does not count them.")


class _Page:
    """What the page, ``report.md`` and the terminal say of a search or estimate."""

    def __init__(self, summary: RareSummary, results: pd.DataFrame, sweep_dir: Path):
        self.summary, self.sweep_dir = summary, sweep_dir
        self.title = f"{summary.mode.capitalize()} report: {summary.sweep}"
        self.lines = rare_report.headline(summary)
        self.terms = [rare_report.ESTIMATE_TERMS] if summary.estimate else []
        self.modes = rare_report.mode_rows(summary.failure_modes)
        self.stuck = rare_report.mode_rows(summary.stuck_modes)
        self.bad = rare_report.runs_to_look_at(results, estimate=summary.estimate is not None)
        self.listed = self.bad.head(rare_report.MAX_LISTED).to_dict("records")
        self.more = (f"... {len(self.bad) - len(self.listed)} more in results.parquet"
                     if len(self.bad) > len(self.listed) else None)

    def replay(self, row: dict) -> str:
        return replay_command(self.sweep_dir, row[RowCol.run_id])

    def markdown(self) -> str:
        md = [f"# {self.title}", "", *self.lines, "", *self.terms, "", "## Failure modes", "",
              *markdown_table(self.modes), "",
              rare_report.mode_columns(self.summary.failure_modes), "", "## Stuck runs", "",
              STUCK_WORDS, "",
              *(markdown_table(self.stuck) if len(self.stuck) > 1 else ["No run was stuck."]),
              "", "## Runs to look at", "", rare_report.LOOK_AT, ""]
        md += [f"- `{row[RowCol.run_id]}` (batch {row[RowCol.batch]}): {row_outcome(row)} — "
               f"`{self.replay(row)}`" for row in self.listed]
        md += [f"- {self.more}"] if self.more else []
        return "\n".join(md) + "\n"

    def html(self, images: list[tuple[str, bytes]]) -> str:
        parts = [f"<h1>{html.escape(self.title)}</h1>",
                 "".join(f"<p>{html.escape(line)}</p>" for line in [*self.lines, *self.terms]),
                 "<h2>Failure modes</h2>", table_html(self.modes),
                 f"<p>{html.escape(rare_report.mode_columns(self.summary.failure_modes))}</p>",
                 "<h2>Stuck runs</h2>", f"<p>{STUCK_WORDS}</p>",
                 table_html(self.stuck) if len(self.stuck) > 1 else "<p>No run was stuck.</p>"]
        parts += [figure_html(t, png) for t, png in images]
        table = [["run", "batch", "outcome", "replay"]]
        table += [[row[RowCol.run_id], str(row[RowCol.batch]), row_outcome(row), self.replay(row)]
                  for row in self.listed]
        parts += [f"<h2>Runs to look at ({len(self.bad)})</h2>",
                  f"<p>{html.escape(rare_report.LOOK_AT)}</p>", table_html(table),
                  f"<p>{html.escape(self.more)}</p>" if self.more else ""]
        return html_document(f"sdc {self.title}", "".join(parts))

    def terminal(self) -> list[str]:
        """The headline, then the failure modes and the stuck runs' (the rest: report.md)."""
        rest = str(self.sweep_dir / MARKDOWN_FILE)
        summary = self.summary
        lines = [*self.lines, "failure modes:",
                 *(mode_lines(summary.failure_modes, MAX_TERMINAL_MODES, rest) or ["  none"])]
        if summary.stuck_modes:
            lines += ["stuck runs:", *mode_lines(summary.stuck_modes, MAX_TERMINAL_MODES, rest)]
        return lines


def write_rare_report(sweep_dir: Path, results: pd.DataFrame, manifest: SweepManifest,
                      html_path: Path, junit_path: Path | None) -> Report:
    """Write the report of a search or estimate directory."""
    saved = saved_summary(sweep_dir, manifest.adaptive.mode)
    summary = adaptive_summary(results, manifest, saved, sweep_dir)
    page = _Page(summary, results, sweep_dir)
    images = rare_report.adaptive_figures(results, summary, saved.get("max_weight") or math.inf)
    return write_files(sweep_dir, html_path, page.html(images), summary.to_plain(),
                       page.markdown(), junit_path, results, summary.sweep, page.terminal())
