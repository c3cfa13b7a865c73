"""``sdc estimate``: P(collision) under a sweep's distributions, by importance sampling."""

from __future__ import annotations

from pathlib import Path

import click

from sdc.cli.adaptive import adaptive_exit, adaptive_outcome
from sdc.cli.common import adaptive_options, bad_input


@click.command()
@click.argument("sweep_file", metavar="SWEEP.toml", type=click.Path(path_type=Path))
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

    The [sweep.params] distributions are the nominal distribution. A multilevel
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
    outcome = adaptive_outcome("estimate", sweep_file, options, max_runs, batch_size, target_rhw)
    click.echo(_estimate_line(outcome.summary))
    adaptive_exit(outcome, "estimate", options["out_dir"])


def _estimate_line(summary: dict) -> str:
    if summary.get("p_collision") is None:
        return "no estimate: the budget ended before the estimation phase"
    stopped = {"target_rhw": "target RHW reached", "budget": "budget spent, target RHW not "
               "reached"}.get(summary.get("stopped"), "interrupted")
    if not summary["failures"]:
        return (f"P(collision) <= {summary['ci_high']:.3g} (95%): no collision in "
                f"{summary['estimation_runs']} weighted runs; {stopped}")
    return (f"P(collision) = {summary['p_collision']:.3g}  95% [{summary['ci_low']:.3g}, "
            f"{summary['ci_high']:.3g}]  rhw {summary['rhw']:.2f}  ({summary['runs']} runs; "
            f"plain Monte Carlo: {summary['mc_equivalent_runs']:,.0f}); {stopped}")
