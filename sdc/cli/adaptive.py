"""What ``sdc search`` and ``sdc estimate`` share: running one from the options."""

from __future__ import annotations

from pathlib import Path

import click

from analysis.measures.commands import report_command
from scenarios.common.errors import SdcError, SpecError
from scenarios.spec.controller_ref import resolve_file
from sdc.cli.common import (
    bad_input,
    check_executor_options,
    check_sweep_inputs,
    exit_after_runs,
    exit_interrupted,
    make_executor,
    make_reporter,
)


def adaptive_outcome(mode: str, sweep_file: Path, options: dict, max_runs: int,
                     batch_size: int, target_rhw: float | None = None,
                     stop_after: int | None = None):
    """Run a search or an estimate from the CLI's options; its outcome, or exit 2."""
    from sdc.batch.sweeps.adaptive_runner import AdaptiveSettings, run_adaptive

    check_executor_options(options)
    try:
        spec = _adaptive_sweep(sweep_file, options)
        check_sweep_inputs(spec, sweep_file)
        controller = options["controller"]
        if controller is None:
            if len(spec.controllers) > 1:
                raise SpecError("--controller", f"the sweep lists {len(spec.controllers)} "
                                f"controllers ({', '.join(spec.controllers)}); {mode} judges "
                                "one: name it")
            controller = spec.controllers[0]
        settings = AdaptiveSettings(mode, resolve_file(controller, Path.cwd(), "--controller")
                                    if controller not in spec.controllers else controller,
                                    max_runs, batch_size, target_rhw, options["score"],
                                    stop_after=stop_after)
        return run_adaptive(spec, options["out_dir"], make_executor(options),
                            make_reporter(options, mode), settings,
                            traces=options["traces"], resume=options["resume"])
    except SdcError as e:
        bad_input(str(e))


def _adaptive_sweep(sweep_file: Path, options: dict):
    """The sweep a search or an estimate draws from: a TOML sweep's ``[sweep.params]``,
    or a stochastic OpenSCENARIO distribution's (``.xosc``; its controller is
    ``--controller``)."""
    from scenarios.spec.sweep_spec import load_sweep

    if sweep_file.suffix.lower() != ".xosc":
        return load_sweep(sweep_file, options["overrides"])
    from scenarios.asam.xosc_sweep import distribution_sweep

    if options["overrides"]:
        raise SpecError("--set", "changes a TOML sweep's fields; a distribution's runs are "
                        "its scenario file's")
    if options["controller"] is None:
        raise SpecError("--controller", "a distribution names no controller: name the one "
                        "to judge")
    return distribution_sweep(sweep_file, (resolve_file(options["controller"], Path.cwd(),
                                                        "--controller"),), adaptive=True)


def adaptive_exit(outcome, mode: str, out_dir: Path) -> None:
    """The counts and where the summary is, then the exit code of a batch of runs."""
    from analysis.measures.run_outcome import outcomes_text
    from analysis.rare.adaptive_summary import summary_path

    counts = outcome.counts
    click.echo(f"{outcome.runs} runs: {counts['ok']} ok, {counts['error']} error, "
               f"{counts['timeout']} timeout; {outcomes_text(outcome.outcomes)} "
               f"({outcome.wall_time_s:.1f} s)")
    click.echo(f"{mode}: {summary_path(out_dir, mode)}  report: {report_command(out_dir)}")
    if outcome.interrupted:
        exit_interrupted("interrupted; to finish, run the same command with --resume")
    exit_after_runs(counts)
