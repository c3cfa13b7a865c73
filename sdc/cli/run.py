"""``sdc run``: one scenario, its outcome printed."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import click

from analysis.measures.numbers import params_text
from analysis.measures.row_columns import RowCol
from analysis.measures.stood_for import stood_for_text
from analysis.measures.world_audit import ROLE_TEXT
from scenarios.common.errors import SdcError, SpecError
from scenarios.common.seeding import SEED_LIMIT
from scenarios.spec.backends import BACKENDS
from scenarios.spec.controller_ref import resolve_file
from scenarios.spec.overrides import Override
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.spec.sweep_spec import PARAM_PREFIX
from scenarios.spec.toml_io import load_spec
from sdc.cli.common import (
    EXIT_RUN_ERROR,
    bad_input,
    check_spec_inputs,
    exit_interrupted,
    set_option,
    warm_up_first,
)


def check_trace_path(trace: Path | None) -> None:
    if trace is None:
        return
    if trace.suffix != ".parquet":
        bad_input(f"--trace: {trace} must end in .parquet")
    if not trace.parent.is_dir():
        bad_input(f"--trace: directory {trace.parent} does not exist")


def run_one(spec: ScenarioSpec, trace: Path | None = None) -> dict:
    """Run a spec; a failure inside the run becomes a row with ``status`` error."""
    from sdc.batch.tasks.run_task import RunTask
    from sdc.run.episode import default_run_id

    warm_up_first(spec)
    return RunTask(default_run_id(spec), spec, trace_path=trace).execute()


def set_values(spec: ScenarioSpec, overrides: tuple[str, ...]) -> dict:
    """The fields ``--set`` changed, as the run's spec holds them: ``p.<path>`` columns,
    as a sweep's row holds its swept values."""
    plain = spec.to_plain()
    return {PARAM_PREFIX + o.path: o.value_in(plain) for o in map(Override.parse, overrides)}


def _fmt(value, unit: str = "", digits: int = 2) -> str:
    return "-" if value is None else f"{value:.{digits}f}{unit}"


def overlap_lines(row: dict, draw=None) -> list[str]:
    """The first overlap of bodies other than the ego counted in world_overlaps and the
    first in sumo_overlaps, in words; ``draw(t_s)``: the command that draws one."""
    return [f"  overlap:   the first counted in {count}, {row[column]}"
            + (f"; draw it: {draw(row[column_s])}" if draw else "")
            for column, column_s, count in (
                (RowCol.first_overlap, RowCol.first_overlap_s, RowCol.world_overlaps),
                (RowCol.first_sumo_overlap, RowCol.first_sumo_overlap_s, RowCol.sumo_overlaps))
            if row.get(column)]


def stood_lines(row: dict) -> list[str]:
    """Where a run that ended standing stood, and for what (none: it ended moving)."""
    if not row.get(RowCol.stood_for):
        return []
    cycle = row.get(RowCol.stood_for_cycle_s)
    short = (f" (less than the light's {cycle:.0f} s cycle: too short to tell)"
             if row[RowCol.outcome] == "unfinished" and cycle is not None else "")
    return [f"  stood:     for the last {row[RowCol.stood_at_end_s]:.1f} s, "
            f"{stood_for_text(row)}{short}"]


def summary_lines(name: str, row: dict, draw=None) -> list[str]:
    """A run's row in lines; ``draw``: as :func:`overlap_lines` takes it."""
    if row[RowCol.status] != "ok":
        return [f"{name}: run failed: {row[RowCol.error]}"]
    what = row[RowCol.collision_with]
    if row.get(RowCol.collision_vclass) and row[RowCol.collision_vclass] != what:
        what += f" ({row[RowCol.collision_vclass]})"
    outcome = row[RowCol.outcome] + (
        f": COLLISION with {what} at {row[RowCol.collision_time_s]:.2f} s "
        f"({row[RowCol.collision_part]}; {ROLE_TEXT.get(row[RowCol.collision_role], '?')})"
        if row[RowCol.collision] else " (no collision)")
    if row.get(RowCol.world_overlaps):
        outcome += (f"; WARNING: bodies other than the ego overlapped in "
                    f"{row[RowCol.world_overlaps]} steps (world_overlaps)")
    if row.get(RowCol.sumo_overlaps):
        outcome += (f"; SUMO's own model held bodies inside each other in "
                    f"{row[RowCol.sumo_overlaps]} steps (sumo_overlaps; SUMO's world, not sdc's)")
    if row.get(RowCol.red_light_violations):
        outcome += f"; crossed {row[RowCol.red_light_violations]} red light(s)"
    maneuver = "not started"
    if row[RowCol.maneuver_started]:
        returned = (f"returned to lane after {row[RowCol.return_time_s]:.2f} s"
                    if row[RowCol.returned_to_lane] else "did not return to lane")
        maneuver = f"started at {_fmt(row[RowCol.detection_range_m], ' m')}, {returned}"
    params = [k for k in row if k.startswith(PARAM_PREFIX)]
    return [
        f"{name}  controller={row[RowCol.controller]}  seed={row[RowCol.seed]}  "
        f"backend={row[RowCol.backend]}",
        *([f"  set:       {params_text(row, params)}"] if params else []),
        f"  outcome:   {outcome}; ended by {row[RowCol.termination]} after "
        f"{row[RowCol.sim_time_s]:.2f} s ({row[RowCol.steps]} steps, "
        f"{row[RowCol.wall_time_s]:.2f} s wall, "
        f"{row[RowCol.network_vehicles]} vehicles in the network"
        + (f", warm state {row[RowCol.warm_state]}" if row.get(RowCol.warm_state) else "") + ")",
        *overlap_lines(row, draw),
        *stood_lines(row),
        f"  progress:  {_fmt(row[RowCol.progress_m], ' m', 1)} along the route, time lost "
        f"{_fmt(row[RowCol.time_lost_s], ' s', 1)} (against driving on at the start speed)",
        f"  maneuver:  {maneuver}",
        f"  max |lane offset| {_fmt(row[RowCol.max_abs_lane_offset_m], ' m')}, "
        f"min gap to obstacle {_fmt(row[RowCol.min_gap_obstacle_m], ' m')}, "
        f"min TTC {_fmt(row[RowCol.min_ttc_s], ' s')}, "
        f"closest to road edge {_fmt(row[RowCol.min_road_edge_gap_m], ' m')}",
        f"  max DRAC {_fmt(row[RowCol.max_drac_mps2], ' m/s^2')}, "
        f"min headway {_fmt(row[RowCol.min_headway_s], ' s')}",
        f"  trace sha256 {row[RowCol.trace_sha256]}",
    ]


def load_scenario(spec_file: Path, overrides: tuple[str, ...], ego: str | None,
                  parameters: tuple[str, ...] = ()) -> ScenarioSpec:
    """The scenario in ``spec_file``: a TOML scenario, or an OpenSCENARIO ``.xosc``
    (``scenarios/asam/xosc_spec.py``; what sdc holds differently from it is printed as
    notes) with its ``parameters`` (``NAME=VALUE``) set, changed by ``overrides``."""
    if spec_file.suffix.lower() != ".xosc":
        for option, given in (("--ego", ego), ("--param", parameters)):
            if given:
                bad_input(f"{option}: applies to an OpenSCENARIO file (.xosc), not to a TOML "
                          "scenario (its fields: --set)")
        return load_spec(spec_file, overrides)
    from scenarios.asam.xosc_distribution import typed_value
    from scenarios.asam.xosc_spec import xosc_spec
    from scenarios.spec.overrides import apply_overrides, blame

    values = {}
    for text in parameters:
        name, equals, value = text.partition("=")
        if not equals or not name.strip():
            bad_input(f"--param: {text!r} is not NAME=VALUE")
        values[name.strip()] = typed_value(value)
    read = xosc_spec(spec_file, values, ego=ego)
    for note in read.notes:
        click.echo(f"note: {note}", err=True)
    plain = read.spec.to_plain()
    changes = apply_overrides(plain, overrides)
    try:
        return ScenarioSpec.from_plain(plain)
    except SpecError as e:
        raise blame(e, changes, spec_file) from None


@click.command()
@click.argument("spec_file", metavar="SPEC.toml|X.xosc", type=click.Path(path_type=Path))
@click.option("--seed", type=click.IntRange(0, SEED_LIMIT - 1),
              help="Override the spec's scenario.seed (SUMO's and the lidar noise's seed).")
@click.option("--controller", metavar="NAME",
              help="Override the spec's controller: a built-in (seed, lane-keep, avoid), "
                   "FILE.py:Class (from the working directory), package.module:Class, or an "
                   "installed plug-in's name (shared parameters carry over).")
@click.option("--backend", type=click.Choice(list(BACKENDS)),
              help="Override the spec's scenario.backend (the world simulator).")
@click.option("--trace", type=click.Path(dir_okay=False, path_type=Path), metavar="FILE.parquet",
              help="Write one row per step (pose, steering, lane offset, phase, lidar, traffic).")
@click.option("--json", "as_json", is_flag=True,
              help="Print the result row as one JSON object on the last line (with "
                   "--set, one p.<path> value per field set, as a sweep's row has).")
@click.option("--ego", metavar="NAME",
              help="An .xosc's ego: the entity of this name (default: the one named Ego, "
                   "ego or hero).")
@click.option("--param", "parameters", metavar="NAME=VALUE", multiple=True,
              help="Set an .xosc's declared parameter (a distribution's row: its "
                   "p.<NAME> values). Repeatable.")
@set_option("scenario")
def run(spec_file: Path, seed: int | None, controller: str | None, backend: str | None,
        trace: Path | None, as_json: bool, ego: str | None, parameters: tuple[str, ...],
        overrides: tuple[str, ...]) -> None:
    """Run one scenario and print its outcome.

    SPEC.toml is an sdc scenario; X.xosc an OpenSCENARIO 1.0-1.3 scenario of the
    subset sdc runs (an OpenDRIVE road, the ego placed and at its speed, bodies
    standing still, a stop time: docs/reference/openscenario.md), its road converted
    by SUMO's netconvert.
    """
    check_trace_path(trace)
    try:
        spec = load_scenario(spec_file, overrides, ego, parameters)
        if seed is not None:
            spec = spec.with_seed(seed)
        if controller is not None:
            spec = spec.with_controller(resolve_file(controller, Path.cwd(), "--controller"))
        if backend is not None:
            spec = spec.with_backend(backend)
        from sdc.car.controller_plugins import make_controller

        check_spec_inputs(spec, spec_file, overrides)
        try:  # a plug-in that cannot be built is bad input, before any run
            make_controller(spec.controller, "--controller" if controller else "controller.name")
        except SpecError as e:
            raise (e if controller else e.in_file(spec_file)) from None
        row = run_one(spec, trace)
    except SdcError as e:
        bad_input(str(e))
    except KeyboardInterrupt:
        exit_interrupted("interrupted")
    from sdc.run.result_row import JSON_COLUMNS

    shown = {**{k: row[k] for k in JSON_COLUMNS}, **set_values(spec, overrides)}
    if as_json:
        click.echo(json.dumps(shown))
    else:
        for line in summary_lines(spec.scenario.name, shown):
            click.echo(line)
        if trace is not None and row[RowCol.status] == "ok":
            click.echo(f"  trace written to {trace}")
    if row[RowCol.status] != "ok":
        from sdc.run.result_row import raised_at

        where = raised_at(row[RowCol.traceback])
        click.echo(f"error: {row[RowCol.error]}" + (f" (raised at {where})" if where else ""),
                   err=True)
        sys.exit(EXIT_RUN_ERROR)
