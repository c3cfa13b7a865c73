"""``sdc sweep``: every sample of a scenario family under each of its controllers."""

from __future__ import annotations

from pathlib import Path

import click

from analysis.measures.commands import resume_command
from analysis.measures.row_columns import RowCol
from analysis.measures.sweep_manifest import SweepDir
from scenarios.common.errors import SdcError
from scenarios.sumo.warm_state import uses_warm_state
from sdc.cli.common import (
    bad_input,
    check_executor_options,
    check_sweep_inputs,
    executor_options,
    exit_after_runs,
    exit_interrupted,
    make_executor,
    make_reporter,
    set_option,
)


def _plan_lines(sweep, plan) -> list[str]:
    invalid = sum(run.spec is None for run in plan)
    samples = len({run.sample for run in plan})
    lines = [f"sweep {sweep.name}: {samples} samples x {len(sweep.controllers)} controllers = "
             f"{len(plan)} runs ({sweep.sampler} sampler, seed {sweep.seed}); "
             f"{invalid} runs with an invalid scenario"]
    warm = {(repr(run.spec.road), run.spec.traffic.warm_seed) for run in plan
            if run.spec is not None and uses_warm_state(run.spec)}
    if sweep.warm_states is not None:
        lines.append(f"the samples draw their traffic from {len(warm)} warm states "
                     f"(sweep.warm_states = {sweep.warm_states})")
    worlds = {run.world.world_id for run in plan if run.world is not None}
    if worlds:
        lines.append(f"the runs share {len(worlds)} worlds of up to {sweep.runs_per_world} "
                     f"runs (sweep.runs_per_world), {sweep.egos_per_world} at a time "
                     "(sweep.egos_per_world): a run enters as a seat frees and the "
                     "placement rule lets it")
    paths = list(sweep.param_types)
    lines.append("  ".join([RowCol.run_id, RowCol.seed] + paths))
    for run in plan:
        values = [f"{v:.6g}" if isinstance(v, float) else str(v) for v in run.params.values()]
        line = "  ".join([run.run_id, str(run.seed)] + values)
        lines.append(line + (f"  INVALID: {run.error}" if run.error else ""))
    return lines


def load_sweep_file(sweep_file: Path, overrides: tuple[str, ...], controllers: str | None,
                    ego: str | None):
    """The sweep in ``sweep_file``: a TOML sweep, or an OpenSCENARIO parameter value
    distribution (``.xosc``) under ``controllers`` (comma-separated; default: seed)."""
    from scenarios.spec.controller_ref import resolve_file
    from scenarios.spec.sweep_spec import load_sweep

    if sweep_file.suffix.lower() != ".xosc":
        for option, value in (("--controllers", controllers), ("--ego", ego)):
            if value is not None:
                bad_input(f"{option}: applies to a distribution file (.xosc); a TOML sweep "
                          "names them in its file (sweep.controllers)")
        return load_sweep(sweep_file, overrides)
    if overrides:
        bad_input("--set: changes a TOML sweep's fields; a distribution's runs are its "
                  "scenario file's, with the distribution's values")
    from scenarios.asam.xosc_sweep import distribution_sweep

    names = tuple(resolve_file(name.strip(), Path.cwd(), "--controllers")
                  for name in (controllers or "seed").split(",") if name.strip())
    if not names:
        bad_input("--controllers: names no controller")
    sweep = distribution_sweep(sweep_file, names, ego)
    for note in sweep.given.notes:
        click.echo(f"note: {note}", err=True)
    return sweep


@click.command()
@click.argument("sweep_file", metavar="SWEEP.toml|D.xosc", type=click.Path(path_type=Path))
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path),
              metavar="DIR", help="Sweep directory (required unless --dry-run).")
@executor_options
@click.option("--batch", "batch_runs", type=click.IntRange(min=1), metavar="N",
              help="Ray only: runs per Ray task, at most (default: about 0.3 s of runs, "
                   "from the run times measured so far). Each run keeps its own row and "
                   "timeout; a task never takes more than 1/(2 x CPUs) of the runs left.")
@click.option("--resume", is_flag=True,
              help="Continue the sweep in DIR: run only the runs that have no row yet.")
@click.option("--samples", type=click.IntRange(min=1), metavar="N",
              help="Override the sweep's sample count (not for the grid sampler).")
@click.option("--dry-run", is_flag=True, help="Print the plan (one line per run) and stop.")
@click.option("--controllers", metavar="NAME[,NAME...]",
              help="A distribution's controllers (default: seed), as --controller of sdc "
                   "run names one.")
@click.option("--ego", metavar="NAME",
              help="A distribution's ego: the entity of this name in its scenario (default: "
                   "the one named Ego, ego or hero).")
@set_option("sweep")
def sweep(sweep_file: Path, out_dir: Path | None, batch_runs: int | None, resume: bool,
          samples: int | None, dry_run: bool, controllers: str | None, ego: str | None,
          overrides: tuple[str, ...], **options) -> None:
    """Run every sample of a scenario family under each of its controllers.

    SWEEP.toml is an sdc sweep; D.xosc an OpenSCENARIO parameter value distribution
    (1.1-1.3): its test runs (stochastic draws from its randomSeed, or the
    deterministic product) over its ScenarioFile, one p.<ParameterName> column each.

    Results stream into DIR/parts/ as runs finish and end in DIR/results.parquet
    (one row per run, one p.<path> column per swept parameter); DIR/manifest.json
    records the sweep, the versions and the counts. A run that raises, hangs past
    --run-timeout or kills its worker becomes an error or timeout row. After a
    kill or Ctrl-C, the same command with --resume finishes the sweep.

    What a run reads besides its spec (network files, plug-in controller files)
    travels with the job, identified by sha256 (recorded in the manifest):
    workers, local or on any Ray node, never open the driver's paths.
    """
    from analysis.measures.run_outcome import outcomes_text
    from scenarios.spec.sweep_plan import expand
    from sdc.batch.sweeps.sweep_runner import run_sweep

    check_executor_options(options)
    if batch_runs and options["executor"] != "ray":
        bad_input("--batch: only applies with --executor ray (local workers take one run "
                  "at a time)")
    try:
        spec = load_sweep_file(sweep_file, overrides, controllers, ego)
        if samples is not None:
            spec = spec.with_samples(samples)
        check_sweep_inputs(spec, sweep_file)
        if dry_run:
            for line in _plan_lines(spec, expand(spec, make_reporter(options).planning)):
                click.echo(line)
            return
        if out_dir is None:
            bad_input("--out: a sweep directory is required")
        outcome = run_sweep(spec, out_dir, make_executor(options, batch_runs),
                            make_reporter(options), traces=options["traces"], resume=resume)
    except SdcError as e:
        bad_input(str(e))
    counts = outcome.counts
    click.echo(f"{outcome.runs} runs: {counts['ok']} ok, {counts['error']} error, "
               f"{counts['timeout']} timeout, {counts['missing']} not run; "
               f"{outcomes_text(outcome.outcomes)} ({outcome.wall_time_s:.1f} s)")
    click.echo(f"results: {outcome.out_dir / SweepDir.results}")
    if outcome.interrupted or counts["missing"]:
        hint = resume_command(sweep_file, out_dir, samples=samples, overrides=overrides,
                              controllers=controllers, ego=ego, traces=options["traces"],
                              executor=options["executor"], workers=options["workers"],
                              ray_address=options["ray_address"],
                              run_timeout=options["run_timeout"], batch_runs=batch_runs)
        exit_interrupted(f"interrupted; to finish: {hint}")
    exit_after_runs(counts)

