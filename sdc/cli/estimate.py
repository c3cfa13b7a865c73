"""``sdc estimate``: P(collision) under a sweep's distributions, by importance sampling."""

from __future__ import annotations

from pathlib import Path

import click

from sdc.cli.adaptive import adaptive_exit, adaptive_outcome
from sdc.cli.common import adaptive_options, bad_input


@click.command()
@click.argument("sweep_file", metavar="SWEEP.toml|D.xosc", type=click.Path(path_type=Path))
@click.option("--target-rhw", type=float, default=0.3, show_default=True, metavar="R",
              help="Stop when the 95% interval's relative half-width is at most R.")
@click.option("--max-runs", type=click.IntRange(min=1), default=20_000, show_default=True,
              metavar="N", help="Stop after N runs at most, target reached or not.")
@click.option("--batch-size", type=click.IntRange(min=2), default=500, show_default=True,
              metavar="N", help="Runs per iteration of the sampler (its adaptation steps, "
                                "and how often the RHW is judged).")
@adaptive_options
def estimate(sweep_file: Path, target_rhw: float, max_runs: int, batch_size: int,
             **options) -> None:
    """Estimate P(collision) under a sweep's parameter distributions, by importance sampling.

    The [sweep.params] distributions are the nominal distribution (of a D.xosc,
    an OpenSCENARIO distribution: its uniform and untruncated normal
    StochasticDistributions, under --controller). A multilevel
    adaptation moves a sampling distribution (a kernel mixture that keeps every
    failure region it reaches, plus a wide share and the nominal) toward the
    collisions; then runs are drawn from it and each weighted by nominal /
    sampling density (the weight is in its row). P(collision) is split by failure
    mode, each part with its interval. DIR/estimate.json holds p_collision with
    its 95% interval, rhw, ess, the runs and mc_equivalent_runs (the plain Monte
    Carlo runs that would reach the same RHW), and says whether the target RHW or
    the budget stopped it.
    A run with no outcome (error, timeout) counts as a collision.
    """
    if not target_rhw > 0:
        bad_input(f"--target-rhw: must be > 0, got {target_rhw:g}")
    from analysis.report.rare_report import estimate_lines

    outcome = adaptive_outcome("estimate", sweep_file, options, max_runs, batch_size, target_rhw)
    summary = outcome.summary
    estimate = summary if "p_collision" in summary else None
    for line in estimate_lines(estimate, summary["stopped"], target_rhw, summary["judged_from"]):
        click.echo(line)
    adaptive_exit(outcome, "estimate", options["out_dir"])

