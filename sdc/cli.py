"""The ``sdc`` command line.

Exit codes: 0 done (a collision is an outcome, not an error); 1 a run errored;
2 bad input (the message names the field or the file); 130 interrupted.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import shlex
import shutil
import sys
from pathlib import Path

import click

from analysis.world_audit import ROLE_TEXT
from scenarios import CATALOG_DIR
from scenarios.compiled_kernels import kernel_choice
from scenarios.controller_ref import resolve_file
from scenarios.errors import SdcError, SpecError
from scenarios.scenario_spec import ScenarioSpec
from scenarios.seeding import SEED_LIMIT
from scenarios.toml_io import load_spec

EXIT_OK, EXIT_RUN_ERROR, EXIT_BAD_INPUT, EXIT_INTERRUPTED = 0, 1, 2, 130
SHOWN_MODES = 8  # failure modes a search prints; all are in DIR/search.json


def _bad_input(message: str) -> None:
    click.echo(f"error: {message}", err=True)
    sys.exit(EXIT_BAD_INPUT)


def _a_number(ctx, param, value: float | None) -> float | None:
    """A number option's value, NaN refused (a range check lets it through)."""
    if value is not None and math.isnan(value):
        raise click.BadParameter("not a number (nan)", ctx, param)
    return value


def _a_finite_number(ctx, param, value: float | None) -> float | None:
    """A number option's value, NaN and infinities refused."""
    if value is not None and not math.isfinite(value):
        raise click.BadParameter(f"not a finite number ({value})", ctx, param)
    return value


def _check_at(at_s: float | None, end_s: float) -> None:
    """``--at`` within the run drawn (``end_s``: its last step's time)."""
    if at_s is not None and at_s > end_s + 1e-9:
        _bad_input(f"--at: {at_s:g} s is past the run's end at {end_s:.3f} s")


def _check_trace_path(trace: Path | None) -> None:
    if trace is None:
        return
    if trace.suffix != ".parquet":
        _bad_input(f"--trace: {trace} must end in .parquet")
    if not trace.parent.is_dir():
        _bad_input(f"--trace: directory {trace.parent} does not exist")


def say_warm_up(spec: ScenarioSpec) -> None:
    """Tell the user (on stderr) when the run first warms its traffic up: minutes, once."""
    from scenarios.world_backends import warm_state_path

    path = warm_state_path(spec)
    if path is not None and not path.is_file():
        click.echo(f"warming the traffic up: {spec.traffic.warm_up_s:g} s of SUMO, once "
                   f"(the warm state is cached in {path.parent})", err=True)


def run_one(spec: ScenarioSpec, trace: Path | None = None) -> dict:
    """Run a spec; a failure inside the run becomes a row with ``status`` error."""
    from sdc.batch.run_task import RunTask, execute
    from sdc.run.episode import default_run_id

    say_warm_up(spec)
    return execute(RunTask(default_run_id(spec), spec, trace_path=trace))


def _fmt(value, unit: str = "", digits: int = 2) -> str:
    return "-" if value is None else f"{value:.{digits}f}{unit}"


def summary_lines(name: str, row: dict) -> list[str]:
    if row["status"] != "ok":
        return [f"{name}: run failed: {row['error']}"]
    what = row["collision_with"]
    if row.get("collision_vclass"):
        what += f" ({row['collision_vclass']})"
    outcome = row["outcome"] + (
        f": COLLISION with {what} at {row['collision_time_s']:.2f} s "
        f"({row['collision_part']}; {ROLE_TEXT.get(row['collision_role'], '?')})"
        if row["collision"] else " (no collision)")
    if row.get("world_overlaps"):
        outcome += (f"; WARNING: bodies other than the ego overlapped in "
                    f"{row['world_overlaps']} steps (world_overlaps)")
    if row.get("red_light_violations"):
        outcome += f"; crossed {row['red_light_violations']} red light(s)"
    maneuver = "not started"
    if row["maneuver_started"]:
        returned = (f"returned to lane after {row['return_time_s']:.2f} s"
                    if row["returned_to_lane"] else "did not return to lane")
        maneuver = f"started at {_fmt(row['detection_range_m'], ' m')}, {returned}"
    return [
        f"{name}  controller={row['controller']}  seed={row['seed']}  backend={row['backend']}",
        f"  outcome:   {outcome}; ended by {row['termination']} after "
        f"{row['sim_time_s']:.2f} s ({row['steps']} steps, {row['wall_time_s']:.2f} s wall, "
        f"{row['network_vehicles']} vehicles in the network"
        + (f", warm state {row['warm_state']}" if row.get("warm_state") else "") + ")",
        f"  progress:  {_fmt(row['progress_m'], ' m', 1)} along the route, time lost "
        f"{_fmt(row['time_lost_s'], ' s', 1)} (against driving on at the start speed)",
        f"  maneuver:  {maneuver}",
        f"  max |lane offset| {_fmt(row['max_abs_lane_offset_m'], ' m')}, "
        f"min gap to obstacle {_fmt(row['min_gap_obstacle_m'], ' m')}, "
        f"min TTC {_fmt(row['min_ttc_s'], ' s')}, "
        f"closest to road edge {_fmt(row['min_road_edge_gap_m'], ' m')}",
        f"  max DRAC {_fmt(row['max_drac_mps2'], ' m/s^2')}, "
        f"min headway {_fmt(row['min_headway_s'], ' s')}",
        f"  trace sha256 {row['trace_sha256']}",
    ]


class _Cli(click.Group):
    """The command group, with one error prefix: click's own usage errors (a missing
    option, a bad choice) print ``error: ...`` as sdc's do, not ``Error: ...``, with the
    same exit codes (2 bad input; 130 interrupted)."""

    def main(self, args=None, prog_name=None, complete_var=None, standalone_mode=True,
             **extra):
        try:
            return super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        except click.Abort:  # Ctrl-C where no command catches it
            click.echo("error: interrupted", err=True)
            sys.exit(EXIT_INTERRUPTED)
        except click.ClickException as e:
            context = getattr(e, "ctx", None)
            if context is not None:
                click.echo(context.get_usage(), err=True)
                click.echo(f"Try '{context.command_path} {context.help_option_names[0]}' "
                           "for help.\n", err=True)
            click.echo(f"error: {e.format_message()}", err=True)
            sys.exit(e.exit_code)


@click.group(cls=_Cli, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="sdc")
def main() -> None:
    """sdc: traffic-scale scenario simulator for a lidar avoid-then-return maneuver.

    Exit codes: 0 done (a collision is an outcome), 1 a run errored,
    2 bad input, 130 interrupted.
    """
    try:
        kernel_choice()  # checked before any command imports the kernels
    except SdcError as e:
        _bad_input(str(e))


@main.command()
@click.argument("spec_file", metavar="SPEC.toml", type=click.Path(path_type=Path))
@click.option("--seed", type=click.IntRange(0, SEED_LIMIT - 1),
              help="Override the spec's scenario.seed (SUMO's and the lidar noise's seed).")
@click.option("--controller", metavar="NAME",
              help="Override the spec's controller: a built-in (seed, lane-keep, avoid), "
                   "FILE.py:Class (from the working directory), package.module:Class, or an "
                   "installed plug-in's name (shared parameters carry over).")
@click.option("--backend", type=click.Choice(["sumo", "highway"]),
              help="Override the spec's scenario.backend (the world simulator).")
@click.option("--trace", type=click.Path(dir_okay=False, path_type=Path), metavar="FILE.parquet",
              help="Write one row per step (pose, steering, lane offset, phase, lidar, traffic).")
@click.option("--json", "as_json", is_flag=True,
              help="Print the result row as one JSON object on the last line.")
def run(spec_file: Path, seed: int | None, controller: str | None, backend: str | None,
        trace: Path | None, as_json: bool) -> None:
    """Run one scenario and print its outcome."""
    _check_trace_path(trace)
    try:
        spec = load_spec(spec_file)
        if seed is not None:
            spec = spec.with_seed(seed)
        if controller is not None:
            spec = spec.with_controller(resolve_file(controller, Path.cwd(), "--controller"))
        if backend is not None:
            spec = spec.with_backend(backend)
        from scenarios.world_backends import check_inputs
        from sdc.car.controller_plugins import make_controller

        check_inputs(spec)
        try:  # a plug-in that cannot be built is bad input, before any run
            make_controller(spec.controller, "--controller" if controller else "controller.name")
        except SpecError as e:
            raise (e if controller else e.in_file(spec_file)) from None
        row = run_one(spec, trace)
    except SdcError as e:
        _bad_input(str(e))
    except KeyboardInterrupt:
        click.echo("interrupted", err=True)
        sys.exit(EXIT_INTERRUPTED)
    if as_json:
        from sdc.run.result_row import JSON_COLUMNS

        click.echo(json.dumps({k: row[k] for k in JSON_COLUMNS}))
    else:
        for line in summary_lines(spec.scenario.name, row):
            click.echo(line)
        if trace is not None and row["status"] == "ok":
            click.echo(f"  trace written to {trace}")
    if row["status"] != "ok":
        from sdc.run.result_row import raised_at

        where = raised_at(row["traceback"])
        click.echo(f"error: {row['error']}" + (f" (raised at {where})" if where else ""),
                   err=True)
        sys.exit(EXIT_RUN_ERROR)


@main.command()
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
    from scenarios.sweep_spec import load_sweep
    from sdc.batch.executors import LocalExecutor
    from sdc.batch.progress import RichReporter
    from sdc.batch.sweep_runner import run_sweep

    try:
        spec = load_sweep(CATALOG_DIR / "sweeps" / "seed-envelope.toml")
        if samples is not None:
            spec = spec.with_samples(samples)
        if _other_demo(out_dir, spec):
            click.echo(f"{out_dir} holds a demo of another plan (another --samples or sdc "
                       "version); starting anew", err=True)
            shutil.rmtree(out_dir)
        outcome = run_sweep(spec, out_dir, LocalExecutor(workers), RichReporter(), resume=True)
    except SdcError as e:
        _bad_input(str(e))
    if outcome.interrupted:
        click.echo("interrupted; run it again to finish", err=True)
        sys.exit(EXIT_INTERRUPTED)
    result = _report(out_dir)
    click.echo(f"seed-envelope, {spec.samples} samples (ego speed 2-30 m/s, obstacle kind and "
               f"offset, traffic) in {out_dir}")
    for line in result.terminal:
        click.echo(line)
    click.echo(f"report: {result.html_path}")
    sys.exit(EXIT_RUN_ERROR if outcome.counts["error"] or outcome.counts["timeout"] else EXIT_OK)



@main.command()
@click.argument("spec_file", metavar="SPEC.toml", type=click.Path(path_type=Path))
@click.option("--for", "watch_s", type=click.FloatRange(20, 3600), default=600.0,
              show_default=True, metavar="SECONDS", callback=_a_number,
              help="How long to watch the traffic warm up [simulated s].")
@click.option("--seed", type=click.IntRange(0, SEED_LIMIT - 1),
              help="The warm-up's seed (default: the spec's traffic.warm_seed, else "
                   "scenario.seed).")
@click.option("--out", type=click.Path(dir_okay=False, path_type=Path), metavar="FILE.png",
              help="The plot [default: <scenario name>-settling.png here]; the series "
                   "beside it as FILE.csv.")
@click.option("--json", "as_json", is_flag=True,
              help="Print the suggestion as one JSON object on the last line.")
def settle(spec_file: Path, watch_s: float, seed: int | None, out: Path | None,
           as_json: bool) -> None:
    """Watch a scenario's traffic warm up and suggest traffic.warm_up_s (on a
    sumo_config road: traffic.enter_s, on the configuration's clock).

    SUMO runs the scenario's background traffic alone (no ego, no obstacles) for
    --for seconds, recording every simulated second the vehicles in the network,
    their mean speed and how many halt. A warm-up truncation rule (MSER on batch
    means of one correlation length, e.g. one signal cycle: analysis/settling.py)
    reads off when each measure settled; the suggestion is the latest, rounded up
    to 10 s. When a measure may still be changing (the rule's cut lands at the end
    of the first half of the watch), no value is suggested, only a lower bound:
    watch longer. A drift that starts late in the watch goes unseen: watch at
    least twice the warm-up you expect.
    """
    import pandas as pd
    from rich.console import Console
    from rich.progress import Progress

    from analysis.settling import settling_figure, suggest_warm_up_s
    from scenarios.world_backends import check_inputs, settling_series

    if out is not None and out.suffix != ".png":
        _bad_input(f"--out: {out} must end in .png (the series goes beside it as .csv)")
    if out is not None and not out.parent.is_dir():
        _bad_input(f"--out: directory {out.parent} does not exist")
    try:
        spec = load_spec(spec_file)
        if spec.scenario.backend != "sumo":
            raise SpecError("scenario.backend", "sdc settle watches SUMO's traffic; "
                            f"the spec's backend is {spec.scenario.backend!r}")
        traffic = spec.traffic
        if (spec.road.kind != "sumo_config" and traffic.flow_vph_per_lane == 0
                and traffic.vehicles == 0):
            raise SpecError("traffic", "the scenario has no background traffic to watch "
                            "(traffic.flow_vph_per_lane and traffic.vehicles are 0)")
        if seed is not None:
            spec = dataclasses.replace(spec, traffic=dataclasses.replace(spec.traffic,
                                                                         warm_seed=seed))
        check_inputs(spec)
        with Progress(console=Console(stderr=True), transient=True) as bar:
            task = bar.add_task("warming up", total=watch_s)
            series = settling_series(spec, watch_s,
                                     on_sample=lambda t_s: bar.update(task, completed=t_s))
    except SdcError as e:
        _bad_input(str(e))
    except KeyboardInterrupt:
        click.echo("interrupted", err=True)
        sys.exit(EXIT_INTERRUPTED)
    frame = pd.DataFrame(series)
    suggestion = suggest_warm_up_s(frame)
    # a configuration's warm-up runs on SUMO's clock to traffic.enter_s
    field = "enter_s" if spec.road.kind == "sumo_config" else "warm_up_s"
    current_s = getattr(spec.traffic, field)
    out = out or Path(f"{spec.scenario.name}-settling.png")
    out.write_bytes(settling_figure(frame, suggestion, f"{spec.scenario.name}: traffic "
                                    "warming up", current_warm_up_s=current_s))
    frame.to_csv(out.with_suffix(".csv"), index=False)
    for line in settle_lines(suggestion, current_s, f"traffic.{field}"):
        click.echo(line)
    click.echo(f"plot: {out}; the series: {out.with_suffix('.csv')}")
    if as_json:
        click.echo(json.dumps(suggestion))


def settle_lines(suggestion: dict, current_s: float,
                 field: str = "traffic.warm_up_s") -> list[str]:
    """What ``sdc settle`` prints: each measure's settling time and the suggestion for
    ``field`` (``traffic.enter_s`` on a configuration's clock)."""
    lines = [f"{name}: settled after {m['truncation_s']:.0f} s"
             if m["settled"] else f"{name}: still changing" for name, m in
             suggestion["measures"].items()]
    if suggestion["settled"]:
        lines.append(f"suggested {field} = {suggestion['warm_up_s']:.0f} "
                     f"({suggestion['rule']}; the spec has {current_s:g})")
    else:
        lines.append(f"not settled within {suggestion['observed_s']:.0f} s: {field} of at "
                     f"least {suggestion['warm_up_at_least_s']:.0f}; watch longer (--for)")
    return lines


def _other_demo(out_dir: Path, spec) -> bool:
    """Does ``out_dir`` hold a demo sweep (ours to replace) with another plan than
    ``spec``'s? A half-done demo of the same plan is resumed instead."""
    from scenarios.sweep_spec import expand, plan_sha256
    from sdc.batch.manifest import read_manifest

    manifest = read_manifest(out_dir) if out_dir.is_dir() else None
    return (manifest is not None
            and manifest.get("sweep", {}).get("sweep", {}).get("name") == spec.name
            and manifest.get("plan_sha256") != plan_sha256(expand(spec)))


def _report(sweep_dir: Path, html_path: Path | None = None, by: tuple[str, ...] = (),
            junit: Path | None = None, interval: str = "wilson",
            fail_above: float | None = None, min_completed: float | None = None):
    from analysis.report import write_report

    try:
        return write_report(sweep_dir, html_path=html_path, by=list(by), junit_path=junit,
                            method=interval, fail_above=fail_above,
                            min_completed=min_completed)
    except SdcError as e:  # a ReportError too
        _bad_input(str(e))


@main.command()
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
              callback=_a_number,
              help="Exit 1 when any controller's collision rate may exceed RATE: the upper "
                   "end of its 95% interval, error and timeout runs counted as collisions "
                   "(a gate for CI, e.g. 0.05).")
@click.option("--min-completed", type=click.FloatRange(0.0, 1.0), metavar="RATE",
              callback=_a_number,
              help="Exit 1 when any controller's rate of runs completed without a collision "
                   "may fall short of RATE: the lower end of its 95% interval, error and "
                   "timeout runs counted as not completed (a gate for CI, e.g. 0.9).")
def report(sweep_dir: Path, html_path: Path | None, by: tuple[str, ...], junit: Path | None,
           interval: str, fail_above: float | None, min_completed: float | None) -> None:
    """How the runs of a sweep directory ended, and its collision statistics.

    Leads with the verdicts: per controller the runs that completed without a
    collision, collided, got stuck or were unfinished, with 95% intervals and
    paired comparisons. Writes a self-contained HTML page (tables, plots, the runs
    to look at with their replay commands), DIR/summary.json and DIR/report.md,
    and prints the tables. Error and timeout runs never count as safe; a partial
    sweep says so and controllers are compared on the samples they all ran.
    """
    result = _report(sweep_dir, html_path, by, junit, interval, fail_above, min_completed)
    for line in result.terminal:
        click.echo(line)
    click.echo(f"report: {result.html_path}")
    if result.summary.get("gate") is not None:  # the last line: the gate's verdict
        from analysis.gate import gate_verdict_line

        click.echo(gate_verdict_line(result.summary["gate"]))
    if result.gate_failed:
        sys.exit(EXIT_RUN_ERROR)

def _plan_lines(sweep, plan) -> list[str]:
    invalid = sum(run.spec is None for run in plan)
    samples = len({run.sample for run in plan})
    lines = [f"sweep {sweep.name}: {samples} samples x {len(sweep.controllers)} controllers = "
             f"{len(plan)} runs ({sweep.sampler} sampler, seed {sweep.seed}); "
             f"{invalid} runs with an invalid scenario"]
    warm = {run.spec.traffic.warm_seed for run in plan if run.spec is not None
            and run.spec.traffic.warm_up_s > 0 and run.spec.scenario.backend == "sumo"}
    if sweep.warm_states is not None:
        lines.append(f"the samples draw their traffic from {len(warm)} warm states "
                     f"(sweep.warm_states = {sweep.warm_states})")
    paths = [p.path for p in sweep.params]
    lines.append("  ".join(["run_id", "seed"] + paths))
    for run in plan:
        values = [f"{v:.6g}" if isinstance(v, float) else str(v) for v in run.params.values()]
        line = "  ".join([run.run_id, str(run.seed)] + values)
        lines.append(line + (f"  INVALID: {run.error}" if run.error else ""))
    return lines


@main.command()
@click.argument("sweep_file", metavar="SWEEP.toml", type=click.Path(path_type=Path))
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path),
              metavar="DIR", help="Sweep directory (required unless --dry-run).")
@click.option("--workers", type=click.IntRange(1, 1024), default=os.cpu_count() or 1,
              show_default="all cores", help="Worker processes (local) or CPUs of a local Ray.")
@click.option("--executor", type=click.Choice(["local", "ray"]), default="local",
              show_default=True, help="Local process pool, or Ray.")
@click.option("--ray-address", metavar="ADDR",
              help="Join this Ray cluster (default: start and stop a local one).")
@click.option("--batch", "batch_runs", type=click.IntRange(min=1), metavar="N",
              help="Ray only: runs per Ray task, at most (default: about 0.3 s of runs, "
                   "from the run times measured so far). Each run keeps its own row and "
                   "timeout; a task never takes more than 1/(2 x CPUs) of the runs left.")
@click.option("--resume", is_flag=True,
              help="Continue the sweep in DIR: run only the runs that have no row yet.")
@click.option("--run-timeout", type=click.FloatRange(min=0, min_open=True), metavar="S",
              help="Stop a run after S wall seconds; it becomes a timeout row.")
@click.option("--traces", type=click.Choice(["none", "failures", "all"]), default="failures",
              show_default=True,
              help="Write DIR/traces/<run_id>.parquet for no run, runs that did not "
                   "complete (collided, stuck, unfinished), or all.")
@click.option("--samples", type=click.IntRange(min=1), metavar="N",
              help="Override the sweep's sample count (not for the grid sampler).")
@click.option("--dry-run", is_flag=True, help="Print the plan (one line per run) and stop.")
@click.option("--quiet", is_flag=True, help="No progress bar; only the final summary.")
def sweep(sweep_file: Path, out_dir: Path | None, workers: int, executor: str,
          ray_address: str | None, batch_runs: int | None, resume: bool,
          run_timeout: float | None, traces: str, samples: int | None, dry_run: bool,
          quiet: bool) -> None:
    """Run every sample of a scenario family under each of its controllers.

    Results stream into DIR/parts/ as runs finish and end in DIR/results.parquet
    (one row per run, one p.<path> column per swept parameter); DIR/manifest.json
    records the sweep, the versions and the counts. A run that raises, hangs past
    --run-timeout or kills its worker becomes an error or timeout row. After a
    kill or Ctrl-C, the same command with --resume finishes the sweep.

    What a run reads besides its spec (network files, plug-in controller files)
    travels with the job, identified by sha256 (recorded in the manifest):
    workers, local or on any Ray node, never open the driver's paths.
    """
    from analysis.run_outcome import outcomes_text
    from scenarios.sweep_spec import expand, load_sweep
    from sdc.batch.executors import LocalExecutor, RayExecutor
    from sdc.batch.progress import QuietReporter, RichReporter
    from sdc.batch.sweep_runner import run_sweep

    if ray_address and executor != "ray":
        _bad_input("--ray-address: only applies with --executor ray")
    if batch_runs and executor != "ray":
        _bad_input("--batch: only applies with --executor ray (local workers take one run "
                   "at a time)")
    try:
        spec = load_sweep(sweep_file)
        if samples is not None:
            spec = spec.with_samples(samples)
        from scenarios.world_backends import check_inputs

        check_inputs(spec.base)
        _check_controllers(spec, sweep_file)
        if dry_run:
            for line in _plan_lines(spec, expand(spec)):
                click.echo(line)
            return
        if out_dir is None:
            _bad_input("--out: a sweep directory is required")
        pool = (RayExecutor(workers, run_timeout, ray_address, batch_runs=batch_runs)
                if executor == "ray"
                else LocalExecutor(workers, run_timeout))
        outcome = run_sweep(spec, out_dir, pool, QuietReporter() if quiet else RichReporter(),
                            traces=traces, resume=resume)
    except SdcError as e:
        _bad_input(str(e))
    counts = outcome.counts
    click.echo(f"{outcome.runs} runs: {counts['ok']} ok, {counts['error']} error, "
               f"{counts['timeout']} timeout, {counts['missing']} not run; "
               f"{outcomes_text(outcome.outcomes)} ({outcome.wall_time_s:.1f} s)")
    click.echo(f"results: {outcome.out_dir / 'results.parquet'}")
    if outcome.interrupted or counts["missing"]:
        hint = resume_command(sweep_file, out_dir, samples=samples, traces=traces,
                              executor=executor, workers=workers, ray_address=ray_address,
                              run_timeout=run_timeout, batch_runs=batch_runs)
        click.echo(f"interrupted; to finish: {hint}", err=True)
        sys.exit(EXIT_INTERRUPTED)
    sys.exit(EXIT_RUN_ERROR if counts["error"] or counts["timeout"] else EXIT_OK)


def resume_command(sweep_file: Path, out_dir: Path, *, samples: int | None, traces: str,
                   executor: str, workers: int, ray_address: str | None,
                   run_timeout: float | None, batch_runs: int | None) -> str:
    """The command that finishes an interrupted sweep: every option that shaped its plan
    (--samples; another plan is refused) and how it ran, then --resume; shell-quoted."""
    words = ["sdc", "sweep", str(sweep_file), "--out", str(out_dir)]
    optional = [("--samples", samples), ("--traces", None if traces == "failures" else traces),
                ("--executor", None if executor == "local" else executor),
                ("--workers", workers), ("--ray-address", ray_address),
                ("--run-timeout", run_timeout), ("--batch", batch_runs)]
    for option, value in optional:
        if value is not None:
            words += [option, str(value)]
    return shlex.join([*words, "--resume"])


def _executor_options(command):
    """The options a command that runs batches of runs shares with ``sdc sweep``."""
    options = [
        click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path),
                     metavar="DIR", required=True, help="Its directory (a sweep directory)."),
        click.option("--workers", type=click.IntRange(1, 1024), default=os.cpu_count() or 1,
                     show_default="all cores",
                     help="Worker processes (local) or CPUs of a local Ray."),
        click.option("--executor", type=click.Choice(["local", "ray"]), default="local",
                     show_default=True, help="Local process pool, or Ray."),
        click.option("--ray-address", metavar="ADDR",
                     help="Join this Ray cluster (default: start and stop a local one)."),
        click.option("--resume", is_flag=True,
                     help="Continue the one in DIR (same file and options): it draws the "
                          "same batches again and runs only the runs without a row."),
        click.option("--run-timeout", type=click.FloatRange(min=0, min_open=True), metavar="S",
                     help="Stop a run after S wall seconds; it becomes a timeout row."),
        click.option("--traces", type=click.Choice(["none", "failures", "all"]),
                     default="failures", show_default=True,
                     help="Write DIR/traces/<run_id>.parquet for no run, runs that did not "
                          "complete (collided, stuck, unfinished), or all."),
        click.option("--controller", metavar="NAME",
                     help="The controller judged, one of the sweep's  [default: its only "
                          "one]."),
        click.option("--score", type=click.Choice(["gap", "ttc"]), default="gap",
                     show_default=True,
                     help="What guides the sampling: the closest approach to an obstacle or "
                          "road edge [m], or the run's min_ttc_s, the smallest time to "
                          "collision measured along the road [s]."),
        click.option("--quiet", is_flag=True, help="No progress bar; only the final summary."),
    ]
    for option in reversed(options):
        command = option(command)
    return command


def _adaptive(mode: str, sweep_file: Path, options: dict, max_runs: int, batch_size: int,
              target_rhw: float | None = None, stop_after: int | None = None):
    """Run a search or an estimate from the CLI's options; its outcome, or exit 2."""
    from scenarios.sweep_spec import load_sweep
    from scenarios.world_backends import check_inputs
    from sdc.batch.adaptive_runner import AdaptiveSettings, run_adaptive
    from sdc.batch.executors import LocalExecutor, RayExecutor
    from sdc.batch.progress import QuietReporter, RichReporter

    if options["ray_address"] and options["executor"] != "ray":
        _bad_input("--ray-address: only applies with --executor ray")
    try:
        spec = load_sweep(sweep_file)
        check_inputs(spec.base)
        _check_controllers(spec, sweep_file)
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
        workers, timeout = options["workers"], options["run_timeout"]
        pool = (RayExecutor(workers, timeout, options["ray_address"])
                if options["executor"] == "ray" else LocalExecutor(workers, timeout))
        reporter = QuietReporter() if options["quiet"] else RichReporter(label=mode)
        return run_adaptive(spec, options["out_dir"], pool, reporter, settings,
                            traces=options["traces"], resume=options["resume"])
    except SdcError as e:
        _bad_input(str(e))


def _adaptive_exit(outcome, mode: str, out_dir: Path) -> None:
    from analysis.run_outcome import outcomes_text

    counts = outcome.counts
    click.echo(f"{outcome.runs} runs: {counts['ok']} ok, {counts['error']} error, "
               f"{counts['timeout']} timeout; {outcomes_text(outcome.outcomes)} "
               f"({outcome.wall_time_s:.1f} s)")
    from analysis.rare_report import summary_path

    click.echo(f"{mode}: {summary_path(out_dir, mode)}  report: sdc report {out_dir}")
    if outcome.interrupted:
        click.echo("interrupted; to finish, run the same command with --resume", err=True)
        sys.exit(EXIT_INTERRUPTED)
    sys.exit(EXIT_RUN_ERROR if counts["error"] or counts["timeout"] else EXIT_OK)


@main.command()
@click.argument("sweep_file", metavar="SWEEP.toml", type=click.Path(path_type=Path))
@click.option("--budget", type=click.IntRange(min=1), required=True, metavar="N",
              help="Runs to spend.")
@click.option("--batch-size", type=click.IntRange(min=2), default=20, show_default=True,
              metavar="N", help="Runs per iteration of the search: each iteration is drawn "
                                "from the scores of those before it.")
@click.option("--stop-after", type=click.IntRange(min=1), metavar="K",
              help="End after the batch in which K collisions (or runs without an outcome) "
                   "have been found  [default: spend the budget].")
@_executor_options
def search(sweep_file: Path, budget: int, batch_size: int, stop_after: int | None,
           **options) -> None:
    """Search a sweep's parameter space for collisions with few runs.

    The sweep's [sweep.params] distributions are where it starts. Each batch then
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
    from analysis.failure_modes import mode_lines
    from analysis.rare_report import first_failure_words

    outcome = _adaptive("search", sweep_file, options, budget, batch_size,
                        stop_after=stop_after)
    summary = outcome.summary
    click.echo(f"failures: {summary.get('failures', 0)} of {outcome.runs} runs"
               + first_failure_words(summary))
    rest = f"sdc report {options['out_dir']}"
    for line in mode_lines(summary.get("failure_modes") or [], SHOWN_MODES, rest):
        click.echo(line)
    stuck = summary.get("stuck_modes") or []
    click.echo(f"stuck (no collision, standing still at the end): "
               f"{sum(m['runs'] for m in stuck)} of {outcome.runs} runs")
    for line in mode_lines(stuck, SHOWN_MODES, rest):
        click.echo(line)
    _adaptive_exit(outcome, "search", options["out_dir"])


@main.command()
@click.argument("sweep_file", metavar="SWEEP.toml", type=click.Path(path_type=Path))
@click.option("--target-rhw", type=float, default=0.3, show_default=True, metavar="R",
              help="Stop when the 95% interval's relative half-width is at most R.")
@click.option("--max-runs", type=click.IntRange(min=1), default=20_000, show_default=True,
              metavar="N", help="Stop after N runs at most, target reached or not.")
@click.option("--batch-size", type=click.IntRange(min=2), default=500, show_default=True,
              metavar="N", help="Runs per iteration of the sampler (its adaptation steps, "
                                "and how often the RHW is judged).")
@_executor_options
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
        _bad_input(f"--target-rhw: must be > 0, got {target_rhw:g}")
    outcome = _adaptive("estimate", sweep_file, options, max_runs, batch_size, target_rhw)
    click.echo(_estimate_line(outcome.summary))
    _adaptive_exit(outcome, "estimate", options["out_dir"])


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


def _has_display() -> bool:
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def _render(trace, metadata, out: Path, every: int, at_s: float | None = None) -> None:
    from rich.console import Console

    from analysis.render import (
        animate,
        decisive_step,
        frame_png,
        scene_from_trace,
        step_at,
        write_html,
    )

    scene = scene_from_trace(trace, metadata)
    if out.suffix == ".png":
        k = (decisive_step(scene, metadata.get("run", {}).get("outcome")) if at_s is None
             else step_at(scene, at_s))
        out.write_bytes(frame_png(scene, k))
        click.echo(f"step {k} (t = {scene.t_s[k]:.3f} s) written to {out}")
        return
    if out.suffix == ".html":
        frames = write_html(scene, out, every)
    else:  # about 0.2 s a frame: show the progress
        from rich.console import Console
        from rich.progress import Progress

        with Progress(console=Console(stderr=True), transient=True) as progress:
            task = progress.add_task(f"drawing {out.name}", total=None)
            frames = animate(scene, out, every,
                             on_frame=lambda i, n: progress.update(task, completed=i + 1,
                                                                   total=n))
    click.echo(f"{frames} frames written to {out}")


@main.command()
@click.argument("target", metavar="DIR|TRACE.parquet", type=click.Path(path_type=Path))
@click.option("--run", "run_id", metavar="ID", help="The run of sweep DIR to re-simulate.")
@click.option("--verify", is_flag=True, help="Exit 1 unless the re-simulation is identical.")
@click.option("--out", type=click.Path(dir_okay=False, path_type=Path),
              metavar="FILE.gif|.mp4|.html|.png",
              help="Draw the run: an animation (mp4 needs ffmpeg), an interactive page, or "
                   "one frame (.png: the decisive moment, or --at).")
@click.option("--at", "at_s", type=click.FloatRange(min=0.0, max_open=False),
              callback=_a_finite_number, metavar="T",
              help="With --out FILE.png: draw the step at simulated time T [s] (default: the "
                   "moment that shows how the run ended: the collision, where it came to "
                   "rest, or the closest approach).")
@click.option("--every", type=click.IntRange(min=1), default=1, show_default=True, metavar="K",
              help="Keep one frame in K.")
@click.option("--gui", is_flag=True, help="Re-simulate in sumo-gui (needs a display).")
def replay(target: Path, run_id: str | None, verify: bool, out: Path | None, every: int,
           at_s: float | None, gui: bool) -> None:
    """Re-simulate one run of a sweep exactly, or draw a recorded trace.

    With a sweep DIR and --run ID, the run is rebuilt from DIR's plan (same spec,
    seed and controller) and its trace compared with the recorded trace_sha256:
    it prints `identical`, or where the run diverged (the first step and field,
    when DIR kept the run's trace). With TRACE.parquet, the recorded run is drawn
    without SUMO (default --out: TRACE.html beside it).
    """
    from analysis.trace_file import read_trace

    if out is not None and out.suffix not in (".gif", ".mp4", ".html", ".png"):
        _bad_input(f"--out: {out} must end in .gif, .mp4, .html or .png")
    if at_s is not None and (out is None or out.suffix != ".png"):
        _bad_input("--at: draws one frame; give --out FILE.png with it")
    if out is not None and not out.parent.is_dir():
        _bad_input(f"--out: directory {out.parent} does not exist")
    if out is not None and out.suffix == ".mp4":
        from matplotlib import animation

        if not animation.writers.is_available("ffmpeg"):
            _bad_input("--out: writing .mp4 needs ffmpeg on PATH; use .gif or .html")
    if gui and not _has_display():
        _bad_input("--gui: no display here (DISPLAY is not set); draw the run with "
                   "--out run.html or run.gif instead")
    try:
        if target.suffix == ".parquet":
            if run_id or verify or gui:
                _bad_input("--run, --verify and --gui need a sweep DIR, not a trace file")
            trace, metadata = read_trace(target)
            _check_at(at_s, float(trace.floats["t_s"][-1]))
            _render(trace, metadata, out or target.with_suffix(".html"), every, at_s)
            return
        if run_id is None:
            _bad_input("--run: a run ID is required with a sweep DIR (see its results)")
        diverged = _replay_run(target, run_id, out, every, gui, at_s)
    except SdcError as e:
        _bad_input(str(e))
    except KeyboardInterrupt:
        click.echo("interrupted", err=True)
        sys.exit(EXIT_INTERRUPTED)
    if diverged is None or (verify and diverged):
        sys.exit(EXIT_RUN_ERROR)


def _replay_run(sweep_dir: Path, run_id: str, out: Path | None, every: int, gui: bool,
                at_s: float | None = None) -> bool | None:
    """Re-simulate, compare, report and draw; True when the replay is not identical
    (None: a run that failed in the sweep, not shown as far as it went)."""
    from analysis.trace_file import read_trace
    from sdc.batch.replay_check import first_divergence, load_recorded_run, version_warnings
    from sdc.run.episode import run_episode

    recorded = load_recorded_run(sweep_dir, run_id)
    # read before the re-simulation: a bad file stops the replay before it starts
    recorded_trace = read_trace(recorded.trace_path)[0] if recorded.trace_path else None
    for line in version_warnings(recorded.manifest):
        click.echo(line, err=True)
    if recorded.row is not None and recorded.row["status"] == "ok":
        _check_at(at_s, recorded.row["sim_time_s"])
    say_warm_up(recorded.spec)
    if recorded.row is not None and recorded.row["status"] != "ok":
        return _replay_failed_run(recorded, out, every, gui, at_s)
    episode = run_episode(recorded.spec, run_id=run_id, gui=gui)
    replayed_sha = episode.trace.sha256()
    row = recorded.row
    for line in summary_lines(run_id, episode.row):
        click.echo(line)
    diverged = True
    if row is None:
        click.echo(f"not comparable: {sweep_dir} has no result for {run_id} yet")
    elif row["status"] != "ok":
        click.echo(f"not comparable: the recorded run ended with status {row['status']}: "
                   f"{row['error']}")
    elif recorded_trace is not None:  # the recorded steps: compare step by step
        divergence = first_divergence(recorded_trace, episode.trace)
        if divergence is not None:
            click.echo(f"DIVERGED: {divergence.describe()}")
        elif row["trace_sha256"] != replayed_sha:
            click.echo(f"DIVERGED: the replay equals the recorded trace file, but its sha256 "
                       f"{replayed_sha} is not the result row's {row['trace_sha256']}")
        else:
            diverged = False
            click.echo(f"identical: trace sha256 {replayed_sha}")
    elif row["trace_sha256"] == replayed_sha:
        diverged = False
        click.echo(f"identical: trace sha256 {replayed_sha}")
    else:
        click.echo(f"DIVERGED: trace sha256 {replayed_sha} != recorded {row['trace_sha256']} "
                   "(the sweep kept no trace of this run to find the step; sweep with "
                   "--traces all)")
    if out is not None:
        _check_at(at_s, float(episode.trace.floats["t_s"][-1]))
        _render(episode.trace, episode.metadata, out, every, at_s)
    return diverged


def _replay_failed_run(recorded, out: Path | None, every: int, gui: bool,
                       at_s: float | None) -> bool | None:
    """A run that raised or timed out in its sweep: what it was and how it ended
    (one line), the replay's own end, and the run drawn as far as it went. True:
    the replay ended otherwise; None: it failed alike and nothing was drawn."""
    from scenarios.sweep_spec import PARAM_PREFIX
    from sdc.run.episode import Stopped, run_as_far_as_it_goes

    row = recorded.row
    params = ", ".join(f"{k[len(PARAM_PREFIX):]}={_param_text(v)}" for k, v in row.items()
                       if k.startswith(PARAM_PREFIX))
    click.echo(f"{recorded.run_id}: {row['status']} in the sweep: {row['error']} "
               f"(controller {row['controller']}, seed {row['seed']}"
               + (f"; {params}" if params else "") + ")")
    limit_s = row["wall_time_s"] if row["status"] == "timeout" else None
    replayed = run_as_far_as_it_goes(recorded.spec, run_id=recorded.run_id, gui=gui,
                                     wall_limit_s=limit_s)
    if not isinstance(replayed, Stopped):
        for line in summary_lines(recorded.run_id, replayed.row):
            click.echo(line)
        click.echo("DIVERGED: the replay ran to its end")
        if out is not None:
            _render(replayed.trace, replayed.metadata, out, every, at_s)
        return True
    where = f" at {replayed.raised_at}" if replayed.raised_at else ""
    click.echo(f"replay: {replayed.reason}{where}, after {replayed.steps} steps")
    if out is None:
        return None
    if replayed.episode is None:
        click.echo(f"nothing drawn to {out}: the run stopped before its first step")
        return None
    _check_at(at_s, float(replayed.episode.trace.floats["t_s"][-1]))
    _render(replayed.episode.trace, replayed.episode.metadata, out, every, at_s)
    return False


def _param_text(value) -> str:
    return f"{value:.4g}" if isinstance(value, float) else str(value)
