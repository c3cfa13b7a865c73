"""``sdc report``: a sweep directory's verdicts, statistics and pages."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from scenarios.common.errors import SdcError
from sdc.cli.common import EXIT_RUN_ERROR, a_number, bad_input


def write_sweep_report(sweep_dir: Path, html_path: Path | None = None, by: tuple[str, ...] = (),
            junit: Path | None = None, interval: str = "wilson",
            fail_above: float | None = None, min_completed: float | None = None,
            max_pedestrian_rate: float | None = None):
    from analysis.report.sweep_report import write_report

    try:
        return write_report(sweep_dir, html_path=html_path, by=list(by), junit_path=junit,
                            method=interval, fail_above=fail_above,
                            min_completed=min_completed,
                            max_pedestrian_rate=max_pedestrian_rate)
    except SdcError as e:  # a ReportError too
        bad_input(str(e))


@click.command()
@click.argument("sweep_dir", metavar="DIR", type=click.Path(file_okay=False, path_type=Path))
@click.option("--out", "html_path", type=click.Path(dir_okay=False, path_type=Path),
              metavar="FILE.html", help="The HTML page  [default: DIR/report.html].")
@click.option("--by", multiple=True, metavar="PARAM",
              help="Group rates by this parameter, e.g. ego.speed_mps or p.ego.speed_mps "
                   "(repeatable; continuous ones in bins)  [default: every swept parameter "
                   "that varies].")
@click.option("--junit", type=click.Path(dir_okay=False, path_type=Path), metavar="FILE.xml",
              help="Also write JUnit XML: one test case per run, a collision a failure.")
@click.option("--interval", type=click.Choice(["wilson", "clopper-pearson"]),
              default="wilson", show_default=True, help="95% interval for the rates.")
@click.option("--fail-above", type=click.FloatRange(0.0, 1.0), metavar="RATE",
              callback=a_number,
              help="Exit 1 when any controller's collision rate may exceed RATE: the upper "
                   "end of its 95% interval, error and timeout runs counted as collisions "
                   "(a gate for CI, e.g. 0.05).")
@click.option("--min-completed", type=click.FloatRange(0.0, 1.0), metavar="RATE",
              callback=a_number,
              help="Exit 1 when any controller's rate of runs completed without a collision "
                   "may fall short of RATE: the lower end of its 95% interval, error and "
                   "timeout runs counted as not completed (a gate for CI, e.g. 0.9).")
@click.option("--max-pedestrian-rate", type=click.FloatRange(0.0, 1.0), metavar="RATE",
              callback=a_number,
              help="Exit 1 when any controller's rate of collisions with people may exceed "
                   "RATE: the upper end of its 95% interval, error and timeout runs counted "
                   "as such collisions (people held to a stricter bound than --fail-above, "
                   "e.g. 0.001).")
def report(sweep_dir: Path, html_path: Path | None, by: tuple[str, ...], junit: Path | None,
           interval: str, fail_above: float | None, min_completed: float | None,
           max_pedestrian_rate: float | None) -> None:
    """How the runs of a sweep directory ended, and its collision statistics.

    Leads with the verdicts: per controller the runs that completed without a
    collision, collided, got stuck or were unfinished, with 95% intervals and
    paired comparisons. Writes a self-contained HTML page (tables, plots, the runs
    to look at with their replay commands), DIR/summary.json and DIR/report.md,
    and prints the tables. Error and timeout runs never count as safe; a partial
    sweep says so and controllers are compared on the samples they all ran.
    """
    result = write_sweep_report(sweep_dir, html_path, by, junit, interval, fail_above,
                                min_completed, max_pedestrian_rate)
    for line in result.terminal:
        click.echo(line)
    click.echo(f"report: {result.html_path}")
    if result.gate is not None:  # the last line: the gate's verdict
        from analysis.stats.gate import gate_verdict_line

        click.echo(gate_verdict_line(result.gate))
    if result.gate_failed:
        sys.exit(EXIT_RUN_ERROR)
