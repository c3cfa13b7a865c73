"""``sdc search``: failures of a sweep's parameter space with few runs."""

from __future__ import annotations

from pathlib import Path

import click

from analysis.measures.commands import report_command
from sdc.cli.adaptive import adaptive_exit, adaptive_outcome
from sdc.cli.common import adaptive_options

SHOWN_MODES = 8  # failure modes a search prints; all are in DIR/search.json


@click.command()
@click.argument("sweep_file", metavar="SWEEP.toml|D.xosc", type=click.Path(path_type=Path))
@click.option("--budget", type=click.IntRange(min=1), required=True, metavar="N",
              help="Runs to spend.")
@click.option("--batch-size", type=click.IntRange(min=2), default=20, show_default=True,
              metavar="N", help="Runs per iteration of the search: each iteration is drawn "
                                "from the scores of those before it.")
@click.option("--stop-after", type=click.IntRange(min=1), metavar="K",
              help="End after the batch in which K collisions (or runs without an outcome) "
                   "have been found  [default: spend the budget].")
@adaptive_options
def search(sweep_file: Path, budget: int, batch_size: int, stop_after: int | None,
           **options) -> None:
    """Search a sweep's parameter space for collisions with few runs.

    The sweep's [sweep.params] distributions are where it starts (of a D.xosc, an
    OpenSCENARIO distribution: its uniform and untruncated normal
    StochasticDistributions, under --controller). Each batch then
    descends toward the runs with the lowest score (closest approach), so near
    misses lead it to collisions; once a collision is found, its direction is
    set aside and the descent heads elsewhere, part of each batch revisits every
    mode found, and a wide share keeps landing runs in regions no near miss warns
    of, so a scenario that fails in several ways shows each of them. Every run is
    a row of DIR (with its batch), replayable with sdc replay. DIR/search.json
    lists the failure modes, one per connected region of one outcome kind (what
    was hit, parameter region, runs, an example run and its replay command; modes
    under 1% of the weight folded into "other"), and the stuck runs' modes beside
    them. A search finds failures; how often it fails is not a
    probability (sdc estimate).
    """
    from analysis.rare.failure_modes import mode_lines
    from analysis.report.rare_report import first_failure_words

    outcome = adaptive_outcome("search", sweep_file, options, budget, batch_size,
                               stop_after=stop_after)
    summary = outcome.summary
    click.echo(f"failures: {summary.get('failures', 0)} of {outcome.runs} runs"
               + first_failure_words(summary.get("first_failure_run"),
                                     summary.get("first_failure_run_id")))
    rest = report_command(options["out_dir"])
    for line in mode_lines(summary.get("failure_modes") or [], SHOWN_MODES, rest):
        click.echo(line)
    stuck = summary.get("stuck_modes") or []
    click.echo(f"stuck (no collision, standing still at the end): "
               f"{sum(m['runs'] for m in stuck)} of {outcome.runs} runs")
    for line in mode_lines(stuck, SHOWN_MODES, rest):
        click.echo(line)
    adaptive_exit(outcome, "search", options["out_dir"])
