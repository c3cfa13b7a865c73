"""The ``sdc`` command line.

Exit codes: 0 done (a collision is an outcome, not an error); 1 a run errored;
2 bad input (the message names the field); 130 interrupted.
"""

from __future__ import annotations

import json
import math
import sys
import traceback
from pathlib import Path

import click

from scenarios import CATALOG_DIR
from scenarios.errors import SdcError
from scenarios.spec import CONTROLLER_PARAMS, ScenarioSpec
from scenarios.toml_io import load_spec

EXIT_OK, EXIT_RUN_ERROR, EXIT_BAD_INPUT, EXIT_INTERRUPTED = 0, 1, 2, 130


def _bad_input(message: str) -> None:
    click.echo(f"error: {message}", err=True)
    sys.exit(EXIT_BAD_INPUT)


def _json_safe(value):
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if hasattr(value, "item"):  # numpy scalar
        return _json_safe(value.item())
    return value


def _check_trace_path(trace: Path | None) -> None:
    if trace is None:
        return
    if trace.suffix != ".parquet":
        _bad_input(f"--trace: {trace} must end in .parquet")
    if not trace.parent.is_dir():
        _bad_input(f"--trace: directory {trace.parent} does not exist")


def run_one(spec: ScenarioSpec, trace: Path | None = None) -> dict:
    """Run a spec; a failure inside the run becomes a row with ``status`` error."""
    from sdc.episode import run_episode  # keeps `sdc --help` fast

    run_id = f"{spec.scenario.name}-{spec.controller.name}-{spec.scenario.seed}"
    try:
        episode = run_episode(spec)
    except SdcError:
        raise
    except Exception as e:  # the run's own failure is an outcome row, not a crash
        return {"run_id": run_id, "seed": spec.scenario.seed, "controller": spec.controller.name,
                "backend": "sumo", "status": "error", "error": f"{type(e).__name__}: {e}",
                "traceback": traceback.format_exc()}
    if trace is not None:
        episode.write_trace(trace)
    return {"run_id": run_id, **{k: _json_safe(v) for k, v in episode.row.items()}}


def _fmt(value, unit: str = "", digits: int = 2) -> str:
    return "-" if value is None else f"{value:.{digits}f}{unit}"


def summary_lines(name: str, row: dict) -> list[str]:
    if row["status"] != "ok":
        return [f"{name}: run failed: {row['error']}"]
    outcome = (f"COLLISION with {row['collision_with']} at {row['collision_time_s']:.2f} s"
               if row["collision"] else "no collision")
    maneuver = "not started"
    if row["maneuver_started"]:
        returned = (f"returned to lane after {row['return_time_s']:.2f} s"
                    if row["returned_to_lane"] else "did not return to lane")
        maneuver = f"started at {_fmt(row['detection_range_m'], ' m')}, {returned}"
    return [
        f"{name}  controller={row['controller']}  seed={row['seed']}  backend={row['backend']}",
        f"  outcome:   {outcome}; ended by {row['termination']} after "
        f"{row['sim_time_s']:.2f} s ({row['steps']} steps, {row['wall_time_s']:.2f} s wall)",
        f"  maneuver:  {maneuver}",
        f"  max |lane offset| {_fmt(row['max_abs_lane_offset_m'], ' m')}, "
        f"min gap to obstacle {_fmt(row['min_gap_obstacle_m'], ' m')}",
        f"  trace sha256 {row['trace_sha256']}",
    ]


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="sdc")
def main() -> None:
    """sdc: traffic-scale scenario simulator for a lidar avoid-then-return maneuver.

    Exit codes: 0 done (a collision is an outcome), 1 a run errored,
    2 bad input, 130 interrupted.
    """


@main.command()
@click.argument("spec_file", metavar="SPEC.toml", type=click.Path(path_type=Path))
@click.option("--seed", type=click.IntRange(0, 2**31 - 1),
              help="Override the spec's scenario.seed (SUMO's and the lidar noise's seed).")
@click.option("--controller", type=click.Choice(sorted(CONTROLLER_PARAMS)),
              help="Override the spec's controller (shared parameters carry over).")
@click.option("--backend", type=click.Choice(["sumo"]), default="sumo", show_default=True,
              help="World backend.")
@click.option("--trace", type=click.Path(dir_okay=False, path_type=Path), metavar="FILE.parquet",
              help="Write one row per step (pose, steering, lane offset, phase, lidar, traffic).")
@click.option("--json", "as_json", is_flag=True,
              help="Print the result row as one JSON object on the last line.")
def run(spec_file: Path, seed: int | None, controller: str | None, backend: str,
        trace: Path | None, as_json: bool) -> None:
    """Run one scenario and print its outcome."""
    _check_trace_path(trace)
    try:
        spec = load_spec(spec_file)
        if seed is not None:
            spec = spec.with_seed(seed)
        if controller is not None:
            spec = spec.with_controller(controller)
        row = run_one(spec, trace)
    except SdcError as e:
        _bad_input(str(e))
    except KeyboardInterrupt:
        click.echo("interrupted", err=True)
        sys.exit(EXIT_INTERRUPTED)
    if as_json:
        click.echo(json.dumps({k: v for k, v in row.items() if k != "traceback"}))
    else:
        for line in summary_lines(spec.scenario.name, row):
            click.echo(line)
        if trace is not None and row["status"] == "ok":
            click.echo(f"  trace written to {trace}")
    if row["status"] != "ok":
        click.echo(row.get("traceback", ""), err=True)
        sys.exit(EXIT_RUN_ERROR)


@main.command()
def demo() -> None:
    """Run the catalog's seed-lesson and highway-obstacle under both controllers."""
    failed = False
    try:
        for name in ("seed-lesson", "highway-obstacle"):
            spec = load_spec(CATALOG_DIR / f"{name}.toml")
            for controller in ("seed", "lane-keep"):
                row = run_one(spec.with_controller(controller))
                failed |= row["status"] != "ok"
                for line in summary_lines(name, row):
                    click.echo(line)
    except SdcError as e:
        _bad_input(str(e))
    except KeyboardInterrupt:
        click.echo("interrupted", err=True)
        sys.exit(EXIT_INTERRUPTED)
    sys.exit(EXIT_RUN_ERROR if failed else EXIT_OK)
