"""What every sdc command shares: exit codes, the bad-input exit, option checks, the
executor options and the exit-code rule of a batch of runs."""

from __future__ import annotations

import contextlib
import math
import os
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import NoReturn

import click

from scenarios.common.errors import SdcError, SpecError
from scenarios.spec.scenario_spec import ScenarioSpec

EXIT_OK, EXIT_RUN_ERROR, EXIT_BAD_INPUT, EXIT_INTERRUPTED = 0, 1, 2, 130


def bad_input(message: str) -> NoReturn:
    click.echo(f"error: {message}", err=True)
    sys.exit(EXIT_BAD_INPUT)


@contextlib.contextmanager
def progress_bar(description: str, total: float | None = None
                 ) -> Iterator[Callable[[float, float | None], None]]:
    """A transient progress bar on stderr; yields ``update(completed, total=None)``."""
    from rich.console import Console
    from rich.progress import Progress

    with Progress(console=Console(stderr=True), transient=True) as bar:
        task = bar.add_task(description, total=total)

        def update(completed: float, total: float | None = None) -> None:
            bar.update(task, completed=completed, total=total)

        yield update


def a_number(ctx, param, value: float | None) -> float | None:
    """A number option's value, NaN refused (a range check lets it through)."""
    if value is not None and math.isnan(value):
        raise click.BadParameter("not a number (nan)", ctx, param)
    return value


def a_finite_number(ctx, param, value: float | None) -> float | None:
    """A number option's value, NaN and infinities refused."""
    if value is not None and not math.isfinite(value):
        raise click.BadParameter(f"not a finite number ({value})", ctx, param)
    return value


def check_at(at_s: float | None, end_s: float) -> None:
    """``--at`` within the run drawn (``end_s``: its last step's time)."""
    if at_s is not None and at_s > end_s + 1e-9:
        bad_input(f"--at: {at_s:g} s is past the run's end at {end_s:.3f} s")


def warm_up_first(spec: ScenarioSpec) -> None:
    """Warm the run's traffic up before the run when its warm state is not cached yet
    (minutes, once), saying so on stderr and how far SUMO's clock got as it goes."""
    from scenarios.world_backends import warm_state_file, warm_state_path, warm_up_span_s

    path = warm_state_path(spec)
    if path is None or path.is_file():
        return
    begin_s, end_s = warm_up_span_s(spec)
    click.echo(f"warming the traffic up: SUMO from {begin_s:,.0f} s to {end_s:,.0f} s, once "
               f"(the warm state is cached in {path.parent})", err=True)
    # a warm-up that fails here fails again in the run, which tells how (an error row)
    with contextlib.suppress(SdcError):
        warm_state_file(spec, on_sample=WarmUpProgress(end_s))


class WarmUpProgress:
    """SUMO's clock during a warm-up, on stderr: in place on a terminal, else a line
    every :data:`~sdc.batch.sweeps.progress.LINE_EVERY_S` of wall time."""

    def __init__(self, end_s: float):
        from sdc.batch.sweeps.progress import LINE_EVERY_S

        self.end_s, self.shown_at = end_s, -math.inf
        self.terminal = sys.stderr.isatty()
        self.every_s = 0.2 if self.terminal else LINE_EVERY_S

    def __call__(self, t_s: float) -> None:
        now = time.monotonic()
        last = t_s >= self.end_s
        if now - self.shown_at < self.every_s and not last:
            return
        self.shown_at = now
        text = f"warm-up: SUMO at {t_s:,.0f} s of {self.end_s:,.0f} s"
        if self.terminal:
            click.echo(f"\r{text}", err=True, nl=last)
        else:
            click.echo(text, err=True)


#: ``--set``'s help: what its paths address in a scenario file, and in a sweep file
SET_HELP = {
    "scenario": "Change a field of the scenario file, checked as if the file said so: "
                "PATH as a sweep parameter's (ego.speed_mps, obstacles[0].lane), VALUE a "
                "TOML value (9, true, \"curve\"; other text is a string). Repeatable.",
    "sweep": "Change a field, checked as if the file said so: sweep.KEY of the sweep "
             "file (sweep.samples=50, sweep.params.ego.speed_mps='{uniform = [2.0, "
             "9.0]}'), any other PATH of its base scenario (scenario.duration_s=20). VALUE "
             "a TOML value (other text is a string). Repeatable; recorded in the manifest, "
             "and --resume needs the same.",
}


def set_option(kind: str):
    """``--set PATH=VALUE`` (repeatable) of a command reading a ``kind`` file
    (``scenario`` or ``sweep``): the command's ``overrides``."""
    return click.option("--set", "overrides", multiple=True, metavar="PATH=VALUE",
                        help=SET_HELP[kind])


def check_spec_inputs(spec: ScenarioSpec, spec_file: Path,
                      overrides: Sequence[str] = ()) -> None:
    """Read what a run of ``spec`` reads besides it (a network file), so a bad one is
    bad input before anything runs, naming ``spec_file`` (which ``spec`` was loaded
    from, changed by ``overrides``) or the override, the field, and the network as the
    file writes it."""
    from scenarios.spec.overrides import Override, blame
    from scenarios.spec.toml_io import as_written
    from scenarios.world_backends import check_inputs

    try:
        check_inputs(spec)
    except SpecError as e:
        raise blame(as_written(e, spec, spec_file), [Override.parse(text) for text in overrides],
                    spec_file) from None


def check_sweep_inputs(sweep, sweep_file: Path) -> None:
    """:func:`check_spec_inputs` of the sweep's base scenario, named as the sweep file
    names it, and each of its controllers built once: bad input, before any run."""
    from scenarios.spec.overrides import Override
    from scenarios.spec.sweep_spec import base_error
    from scenarios.spec.toml_io import written_path

    base_overrides = [text for text in sweep.overrides if Override.parse(text).table != "sweep"]
    try:
        check_spec_inputs(sweep.base, sweep.base_path, base_overrides)
    except SpecError as e:
        shown = written_path(sweep.base_path, Path(sweep_file).parent)
        raise base_error(e, shown).in_file(sweep_file) from None
    _check_controllers(sweep, sweep_file)


def _check_controllers(sweep, sweep_file: Path) -> None:
    """Build each of the sweep's controllers once on its base scenario: one that
    cannot be found or built is bad input, before any run."""
    from sdc.car.controller_plugins import make_controller

    for i, name in enumerate(sweep.controllers):
        try:
            make_controller(sweep.base.with_controller(name).controller,
                            f"sweep.controllers[{i}]")
        except SpecError as e:
            raise e.in_file(sweep_file) from None


def _options(command, options: list):
    for option in reversed(options):
        command = option(command)
    return command


def executor_options(command):
    """How a command that runs batches of runs runs them: the options ``sdc sweep``,
    ``sdc search`` and ``sdc estimate`` share (:func:`make_executor`,
    :func:`make_reporter` read them)."""
    return _options(command, [
        click.option("--workers", type=click.IntRange(1, 1024), default=os.cpu_count() or 1,
                     show_default="all cores",
                     help="Worker processes (local) or CPUs of a local Ray."),
        click.option("--executor", type=click.Choice(["local", "ray"]), default="local",
                     show_default=True, help="Local process pool, or Ray."),
        click.option("--ray-address", metavar="ADDR",
                     help="Join this Ray cluster (default: start and stop a local one)."),
        click.option("--run-timeout", type=click.FloatRange(min=0, min_open=True), metavar="S",
                     help="Stop a run after S wall seconds; it becomes a timeout row."),
        click.option("--traces", type=click.Choice(["none", "failures", "all"]),
                     default="failures", show_default=True,
                     help="Write DIR/traces/<run_id>.parquet for no run, runs that did not "
                          "complete (collided, stuck, unfinished), or all."),
        click.option("--quiet", is_flag=True, help="No progress bar; only the final summary."),
    ])


def adaptive_options(command):
    """The options ``sdc search`` and ``sdc estimate`` add to :func:`executor_options`."""
    return _options(executor_options(command), [
        set_option("sweep"),
        click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path),
                     metavar="DIR", required=True, help="Its directory (a sweep directory)."),
        click.option("--resume", is_flag=True,
                     help="Continue the one in DIR (same file and options): it draws the "
                          "same batches again and runs only the runs without a row."),
        click.option("--controller", metavar="NAME",
                     help="The controller judged, one of the sweep's  [default: its only "
                          "one]."),
        click.option("--score", type=click.Choice(["gap", "ttc"]), default="gap",
                     show_default=True,
                     help="What guides the sampling: the closest approach to an obstacle or "
                          "road edge [m], or the run's min_ttc_s, the smallest time to "
                          "collision measured along the road [s]."),
    ])


def make_executor(options: dict, batch_runs: int | None = None):
    """The executor :func:`executor_options` asked for (``--batch``: Ray's runs per task)."""
    from sdc.batch.executors.local_executor import LocalExecutor
    from sdc.batch.executors.ray_executor import RayExecutor

    if options["executor"] == "ray":
        return RayExecutor(options["workers"], options["run_timeout"], options["ray_address"],
                           batch_runs=batch_runs)
    return LocalExecutor(options["workers"], options["run_timeout"])


def check_executor_options(options: dict) -> None:
    """Exit 2 when a Ray-only option is given without ``--executor ray``."""
    if options["ray_address"] and options["executor"] != "ray":
        bad_input("--ray-address: only applies with --executor ray")


def make_reporter(options: dict, label: str = "sweep"):
    """A progress bar labelled ``label`` (whole lines off a terminal), or none with
    ``--quiet``."""
    from sdc.batch.sweeps.progress import QuietReporter, progress_reporter

    return QuietReporter() if options["quiet"] else progress_reporter(label)


def exit_after_runs(counts: dict) -> NoReturn:
    """The exit code of a batch of runs that finished: 1 when any run errored or timed
    out, else 0 (a collision is an outcome, not an error)."""
    sys.exit(EXIT_RUN_ERROR if counts["error"] or counts["timeout"] else EXIT_OK)


def exit_interrupted(message: str) -> NoReturn:
    click.echo(message, err=True)
    sys.exit(EXIT_INTERRUPTED)
