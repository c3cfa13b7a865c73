"""``sdc report``: a sweep directory turned into its report, the one entry callers use.

:func:`write_report` reads the directory's rows and manifest and writes, into it,
``summary.json`` and ``report.md``, one self-contained HTML page (figures embedded as
PNG data, no external resources) and, on request, a JUnit XML file with one test case
per run: a sweep's collision statistics (:mod:`analysis.report.sweep_page`), or a
search's or estimate's failures (:mod:`analysis.report.rare_page`), as its manifest
says. The modules behind it: :mod:`~analysis.report.report_files` (reading, the
files), :mod:`~analysis.report.sweep_summary` (a sweep's numbers),
:mod:`~analysis.report.sweep_words` and :mod:`~analysis.report.sweep_world` (its
tables and sentences, the terminal's lines), :mod:`~analysis.report.page_parts` (what
both pages are made of).
"""

from __future__ import annotations

from pathlib import Path

from analysis.report.report_files import HTML_FILE, Report, ReportError, load_results
from analysis.report.sweep_page import write_sweep_report
from analysis.report.sweep_summary import by_column
from analysis.stats.rates import Method


def write_report(sweep_dir: Path, *, html_path: Path | None = None, by: list[str] = (),
                 junit_path: Path | None = None, method: Method = "wilson",
                 fail_above: float | None = None, min_completed: float | None = None,
                 max_pedestrian_rate: float | None = None) -> Report:
    """Write the report of ``sweep_dir``; with ``fail_above``, ``min_completed`` or
    ``max_pedestrian_rate`` the
    summary holds the gate (:func:`analysis.stats.gate.gate`), and ``Report.gate_failed``
    lists the controllers that fail it."""
    sweep_dir = Path(sweep_dir)
    for option, path in (("--out", html_path), ("--junit", junit_path)):
        if path is not None and not Path(path).parent.is_dir():
            raise ReportError(option, f"directory {Path(path).parent} does not exist")
    results, manifest = load_results(sweep_dir)
    html_path = Path(html_path) if html_path else sweep_dir / HTML_FILE
    if manifest.adaptive is None:
        return write_sweep_report(sweep_dir, results, manifest, html_path,
                                  [by_column(results, column) for column in by], junit_path,
                                  method, fail_above, min_completed, max_pedestrian_rate)
    if by:
        raise ReportError("--by", "a search or estimate has no rates by parameter (its "
                          "runs were drawn toward failure); see its failure modes")
    gated = [name for name, value in (("--fail-above", fail_above),
                                      ("--min-completed", min_completed),
                                      ("--max-pedestrian-rate", max_pedestrian_rate))
             if value is not None]
    if gated:
        raise ReportError(gated[0], "a search or estimate has no rates to "
                          "gate (its runs were drawn toward failure); gate on a sweep")
    from analysis.report.rare_page import write_rare_report  # the rare-event machinery

    return write_rare_report(sweep_dir, results, manifest, html_path, junit_path)
