"""``sdc demo``: the catalog's seed-envelope swept on all cores, and its report."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import click

from scenarios import CATALOG_DIR
from scenarios.common.errors import SdcError
from sdc.cli.common import bad_input, exit_after_runs, exit_interrupted
from sdc.cli.report import write_sweep_report


@click.command()
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path),
              default=Path("sdc-demo"), show_default=True, metavar="DIR",
              help="Sweep directory; an existing demo there is resumed, not rerun.")
@click.option("--samples", type=click.IntRange(min=1), metavar="N",
              help="Samples of the seed-envelope sweep, each run under seed, lane-keep and avoid  "
                   "[default: the catalog's 500, about 25 s on 2 cores].")
@click.option("--workers", type=click.IntRange(1, 1024), default=os.cpu_count() or 1,
              show_default="all cores", help="Worker processes.")
def demo(out_dir: Path, samples: int | None, workers: int) -> None:
    """Sweep the catalog's seed-envelope on all cores and write its collision report."""
    from scenarios.spec.sweep_spec import load_sweep
    from sdc.batch.executors.local_executor import LocalExecutor
    from sdc.batch.sweeps.progress import progress_reporter
    from sdc.batch.sweeps.sweep_runner import run_sweep

    try:
        spec = load_sweep(CATALOG_DIR / "sweeps" / "seed-envelope.toml")
        if samples is not None:
            spec = spec.with_samples(samples)
        if _other_demo(out_dir, spec):
            click.echo(f"{out_dir} holds a demo of another plan (another --samples or sdc "
                       "version); starting anew", err=True)
            shutil.rmtree(out_dir)
        outcome = run_sweep(spec, out_dir, LocalExecutor(workers), progress_reporter(),
                            resume=True)
    except SdcError as e:
        bad_input(str(e))
    if outcome.interrupted:
        exit_interrupted("interrupted; run it again to finish")
    result = write_sweep_report(out_dir)
    click.echo(f"seed-envelope, {spec.samples} samples (ego speed 2-30 m/s, obstacle kind and "
               f"offset, traffic) in {out_dir}")
    for line in result.terminal:
        click.echo(line)
    click.echo(f"report: {result.html_path}")
    exit_after_runs(outcome.counts)


def _other_demo(out_dir: Path, spec) -> bool:
    """Does ``out_dir`` hold a demo sweep (ours to replace) with another plan than
    ``spec``'s? A half-done demo of the same plan is resumed instead."""
    from scenarios.spec.sweep_plan import expand, plan_sha256
    from sdc.batch.sweeps.manifest import read_manifest

    manifest = read_manifest(out_dir) if out_dir.is_dir() else None
    if manifest is None:
        return False
    return manifest.sweep_name == spec.name and manifest.plan_sha256 != plan_sha256(expand(spec))
