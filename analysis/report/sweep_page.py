"""A sweep's report pages: ``report.md`` and the HTML page (its sections under a table
of contents, figures embedded as PNG data, no external resources), the runs to look at
with their decisive moments, and :func:`write_sweep_report`, which writes them with
``summary.json``, the list of runs to look at and the JUnit XML."""

from __future__ import annotations

import base64
import dataclasses
import html
import os
from pathlib import Path

import pandas as pd

from analysis.measures.commands import replay_command, run_commands
from analysis.measures.numbers import params_text
from analysis.measures.row_columns import RowCol
from analysis.measures.sweep_manifest import SweepManifest
from analysis.report import plots
from analysis.report.look_at import (
    LIST_FILE,
    RANKING,
    SHOWN_PER_CLASS,
    classes_shown,
    look_at_list,
    ranked_runs,
    thumbnail,
)
from analysis.report.page_parts import (
    bullets,
    figure_html,
    html_document,
    markdown_table,
    paragraphs,
    table_html,
)
from analysis.report.report_files import Report, write_files
from analysis.report.settling_report import read_settling, settling_image, settling_summary
from analysis.report.sweep_summary import SweepSummary, build_summary, varying_parameters
from analysis.report.sweep_words import (
    COLLISION_TITLE,
    COMPARISONS_TITLE,
    DEFF_HEAD,
    NOT_RECORDED,
    VERDICT_NOTES,
    VERDICT_TITLE,
    collision_notes,
    comparison_groups,
    comparison_lines,
    coverage_lines,
    deff_text,
    envelope_lines,
    headline_rows,
    lead_lines,
    not_warnings,
    shares_traffic,
    stop_rows,
    stop_title,
    summary_world_lines,
    terminal_table,
    verdict_rows,
    warm_state_lines,
    warning_lines,
)
from analysis.stats.rates import Method
from analysis.stats.verdicts import outcomes_recorded, percent, shared_samples
from scenarios.common.plain_json import json_scalar

#: what the runs-to-look-at tables hold
SHOWN_WORDS = (f"Of each controller's runs of a class the first {SHOWN_PER_CLASS} are "
               "shown; the rest are counted, and listed in full beside the report.")


def _look_at_tables(bad: pd.DataFrame, sweep_dir: Path, params: list[str],
                    list_href: str) -> str:
    """The ranked runs, a table per controller: of each class its first
    :data:`SHOWN_PER_CLASS`, each with the decisive moment where its trace was kept and
    its replay command, then how many more the list at ``list_href`` holds."""
    head = ["#", "run", "class", "what happened", "parameters", "decisive moment"]
    header = "".join(f"<th>{html.escape(c)}</th>" for c in head)
    parts = []
    for controller, rows in bad.groupby(RowCol.controller, sort=False):
        body = []
        for rank_class, shown, more in classes_shown(rows):
            for row in shown:
                run_id = row[RowCol.run_id]
                png = thumbnail(sweep_dir, run_id)
                picture = ("" if png is None else
                           f'<img class="thumb" alt="run {html.escape(run_id)}" '
                           f'src="data:image/png;base64,{base64.b64encode(png).decode()}">')
                cells = [str(row["rank"]), run_id, row["rank_class"], row["why"],
                         params_text(row, params)]
                body.append("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in cells)
                            + f"<td>{picture}</td></tr>")
                body += [f'<tr><td></td><td colspan="{len(head) - 1}">{what}: <code '
                         f'class="command">{html.escape(command)}</code></td></tr>'
                         for what, command in run_commands(sweep_dir, run_id)]
            if more:
                body.append(f'<tr class="more"><td></td><td colspan="{len(head) - 1}">'
                            f"{more} more {html.escape(str(rank_class))} in "
                            f'<a href="{html.escape(list_href)}">{LIST_FILE}</a></td></tr>')
        parts.append(f"<h3>{html.escape(str(controller))} ({len(rows)})</h3>"
                     f'<table class="look-at" id="look-at-{html.escape(str(controller))}">'
                     f'<tr>{header}</tr>{"".join(body)}</table>')
    return "".join(parts)


def _count_line(summary: SweepSummary) -> str:
    counts = summary.counts
    return (f"{summary.runs} runs ({counts['ok']} ok, {counts['error']} error, "
            f"{counts['timeout']} timeout); intervals: {summary.interval} 95%.")


#: the report's sections in their fixed order, (anchor, title); the table of contents
#: at the top names those a report has
SECTIONS = (("verdicts", "Verdicts"), ("warnings", "Warnings"), ("collisions", "Collisions"),
            ("world", "World"), ("comparisons", "Comparisons"),
            ("traffic", "Traffic and warm-up"), ("figures", "Figures"),
            ("by-parameter", "By parameter"), ("look-at", "Runs to look at"))


def _contents(present: list[str]) -> list[tuple[str, str]]:
    """The :data:`SECTIONS` among ``present`` anchors, in their order."""
    return [(anchor, title) for anchor, title in SECTIONS if anchor in present]


def markdown(summary: SweepSummary, results: pd.DataFrame, sweep_dir: Path,
             bad: pd.DataFrame) -> str:
    """``report.md``, its sections in :data:`SECTIONS` order; ``bad``: the runs to look
    at (:func:`ranked_runs` of ``results``)."""
    rows, verdicts = headline_rows(summary), verdict_rows(summary)
    sections = {"verdicts": ([VERDICT_TITLE, "", *markdown_table(verdicts), ""] if verdicts
                             else [NOT_RECORDED, ""])
                + [*(f"- {line}" for line in lead_lines(summary)), ""]
                + ([VERDICT_NOTES, ""] if verdicts else [])
                + [f"{line}\n" for line in not_warnings(coverage_lines(summary))],
                "warnings": [f"**{line}**\n" for line in warning_lines(summary)]}
    sections["collisions"] = [
        COLLISION_TITLE, "", *markdown_table(rows), "", collision_notes(summary), "",
        f"Collision rates {stop_title(summary)}", "",
        *([*markdown_table([rows[0], *stop_rows(summary)]), ""]
          if summary.stop_possible is not None else []),
        *(f"- {line}" for line in envelope_lines(summary))]
    sections["world"] = [f"{line}\n" for line in not_warnings(summary_world_lines(summary))]
    groups = comparison_groups(summary)
    sections["comparisons"] = [COMPARISONS_TITLE] if groups else []
    for title, sentences in groups:
        sections["comparisons"] += ["", f"### {title}", "", *(f"- {s}" for s in sentences)]
    sections["traffic"] = [f"{line}\n" for line in not_warnings(warm_state_lines(summary))]
    look_at = [f"{RANKING} {SHOWN_WORDS}", ""]
    params = varying_parameters(results)
    for controller, rows in bad.groupby(RowCol.controller, sort=False):
        look_at += ["", f"### {controller} ({len(rows)})", ""]
        for rank_class, shown, more in classes_shown(rows):
            look_at += [f"{row['rank']}. `{row[RowCol.run_id]}`: {row['why']}; "
                        f"{params_text(row, params)} — "
                        + "; ".join(f"`{command}`" if what == "replay" else f"{what}: `{command}`"
                                    for what, command in run_commands(sweep_dir,
                                                                      row[RowCol.run_id]))
                        for row in shown]
            if more:
                look_at.append(f"- {more} more {rank_class} in [{LIST_FILE}]({LIST_FILE})")
    sections["look-at"] = look_at
    contents = _contents([anchor for anchor, lines in sections.items() if lines])
    lines = [f"# Collision report: {summary.sweep}", "", _count_line(summary), "",
             "Contents: " + " · ".join(f"[{title}](#{anchor})" for anchor, title in contents),
             ""]
    for anchor, title in contents:
        lines += [f'<a id="{anchor}"></a>', "", f"## {title}", "", *sections[anchor], ""]
    return "\n".join(lines) + "\n"


def figures(results: pd.DataFrame, by: list[str], method: Method) -> list[tuple[str, bytes]]:
    """The report's figures, each counting every run (a stuck run, an error and a
    timeout are failures in each)."""
    out = []
    if outcomes_recorded(results):
        out.append(("How the runs ended", plots.outcome_bars(results)))
        pair = plots.separating_parameters(results, varying_parameters(results))
        if pair:
            y = pair[1] if len(pair) > 1 else None
            out.append((f"Failure map over {' and '.join(p.removeprefix('p.') for p in pair)}",
                        plots.failure_map(results, pair[0], y)))
    out += [(f"How the runs failed by {c.removeprefix('p.')}",
             plots.failures_by_parameter(results, c, method)) for c in by]
    numeric = [c for c in by if pd.api.types.is_numeric_dtype(results[c])]
    if len(numeric) >= 2:
        for controller in dict.fromkeys(results[RowCol.controller]):
            out.append((f"Collided over {numeric[0]} and {numeric[1]}, {controller}",
                        plots.collided_heatmap(results, numeric[0], numeric[1], controller)))
    out.append(("Safety margins: minimum gap, minimum TTC, maximum DRAC",
                plots.distributions(results)))
    out.append(("How the runs failed", plots.collision_breakdown(results)))
    return out


def html_page(summary: SweepSummary, results: pd.DataFrame, sweep_dir: Path,
              bad: pd.DataFrame, images: list[tuple[str, bytes]],
              warm_up_images: list[tuple[str, bytes]] = (), list_href: str = LIST_FILE) -> str:
    """The report page, its sections in :data:`SECTIONS` order under a table of
    contents; ``bad``: the runs to look at (:func:`ranked_runs` of ``results``);
    ``warm_up_images`` beside the warm-state lines they show; ``list_href``: where the
    page finds the whole list of them."""
    verdicts, groups = verdict_rows(summary), comparison_groups(summary)
    sections = {
        "verdicts": (f"<p>{html.escape(VERDICT_TITLE if verdicts else NOT_RECORDED)}</p>"
                     + (table_html(verdicts, "verdicts") if verdicts else "")
                     + bullets(lead_lines(summary))
                     + (f"<p>{html.escape(VERDICT_NOTES)}</p>" if verdicts else "")
                     + paragraphs(not_warnings(coverage_lines(summary)))),
        "warnings": paragraphs(warning_lines(summary)),
        "collisions": (f"<p>{html.escape(COLLISION_TITLE)}</p>"
                       + table_html(headline_rows(summary))
                       + f"<p>{html.escape(collision_notes(summary))}</p>"
                       + f"<p>Collision rates {html.escape(stop_title(summary))}</p>"
                       + (table_html([headline_rows(summary)[0], *stop_rows(summary)])
                          if summary.stop_possible is not None else "")
                       + bullets(envelope_lines(summary))),
        "world": paragraphs(not_warnings(summary_world_lines(summary))),
        "comparisons": "".join(
            [f"<p>{html.escape(COMPARISONS_TITLE)}</p>"]
            + [f"<h3>{html.escape(title)}</h3>{bullets(sentences)}"
               for title, sentences in groups] if groups else []),
        "traffic": (paragraphs(not_warnings(warm_state_lines(summary)))
                    + "".join(figure_html(title, png) for title, png in warm_up_images)),
        "figures": "".join(figure_html(title, png) for title, png in images),
        "by-parameter": "".join(f"<details><summary>By {html.escape(column)}</summary>"
                                f"{table_html(_by_rows(summary, rows))}</details>"
                                for column, rows in summary.by.items()),
        "look-at": (f"<p>{html.escape(RANKING)} {html.escape(SHOWN_WORDS)} The pictures "
                    "show the moment that decided each run whose trace was kept (top-down; "
                    f'lidar returns in orange). All of them: <a href="{html.escape(list_href)}"'
                    f">{LIST_FILE}</a>.</p>"
                    + _look_at_tables(bad, sweep_dir, varying_parameters(results), list_href)),
    }
    contents = _contents([anchor for anchor, body in sections.items() if body])
    titles = {**dict(contents), "look-at": f"Runs to look at ({len(bad)})"}
    parts = [f"<h1>Collision report: {html.escape(summary.sweep)}</h1>",
             f"<p>{html.escape(_count_line(summary))} Errors and timeouts are never counted "
             "as safe.</p>",
             '<nav class="contents">Contents: ' + " · ".join(
                 f'<a href="#{anchor}">{html.escape(title)}</a>' for anchor, title in contents)
             + "</nav>"]
    parts += [f'<h2 id="{anchor}">{html.escape(titles[anchor])}</h2>{sections[anchor]}'
              for anchor, _ in contents]
    return html_document(f"sdc report: {summary.sweep}", "".join(parts))


def _by_rows(summary: SweepSummary, rows: list[dict]) -> list[list[str]]:
    """A by-parameter table: a row per group and controller."""
    deff = shares_traffic(summary)
    table = [["group", "controller", "ok runs", "collisions", "rate", "95% interval",
              "failed", *([DEFF_HEAD] if deff else [])]]
    return table + [[r["group"], r[RowCol.controller], str(r["n_ok"]), str(r["collisions"]),
                     percent(json_scalar(r["collision_rate"])),
                     f"{percent(r['low'])} - {percent(r['high'])}", str(r["n_failed"]),
                     *([deff_text(r["deff"])] if deff else [])]
                    for r in rows]


def write_sweep_report(sweep_dir: Path, results: pd.DataFrame, manifest: SweepManifest,
                       html_path: Path, by: list[str], junit_path: Path | None,
                       method: Method, fail_above: float | None = None,
                       min_completed: float | None = None,
                       max_pedestrian_rate: float | None = None) -> Report:
    """Write the report of a sweep (``by``: the columns of its rates by parameter, checked
    by :func:`~analysis.report.sweep_summary.by_column`; default those that vary); with
    ``fail_above``, ``min_completed`` or ``max_pedestrian_rate`` the summary holds the
    gate (:func:`analysis.stats.gate.gate`)."""
    by = by or varying_parameters(results)
    shared = shared_samples(results)
    summary = build_summary(results, manifest, by, method, shared, fail_above, min_completed,
                            max_pedestrian_rate)
    warm_ups = read_settling(sweep_dir)
    summary = dataclasses.replace(summary, settling=settling_summary(
        warm_ups, on_config_clock=bool(summary.sumo_config)), sweep_dir=str(sweep_dir))
    counted = results[results[RowCol.sample].isin(shared)]
    images = figures(counted, by, method)
    list_path, bad = sweep_dir / LIST_FILE, ranked_runs(results)
    look_at_list(bad, varying_parameters(results),
                 lambda run_id: replay_command(sweep_dir, run_id)).to_csv(list_path, index=False)
    page = html_page(summary, results, sweep_dir, bad, images,
                     settling_image(warm_ups, summary.settling),
                     os.path.relpath(list_path, html_path.parent))
    return write_files(sweep_dir, html_path, page, summary.to_plain(),
                       markdown(summary, results, sweep_dir, bad), junit_path, results,
                       summary.sweep, terminal_table(summary) + comparison_lines(summary),
                       summary.gate)
