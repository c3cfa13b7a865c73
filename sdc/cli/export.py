"""``sdc export``: one run of a sweep as an OpenSCENARIO scenario with its road as
OpenDRIVE (the writers: :mod:`scenarios.asam.xosc_export`,
:mod:`scenarios.asam.xodr_export`).

The glue: a run's recorded trace read into paths (the ego's poses are the trace's,
the other bodies' tracked through it: :mod:`analysis.measures.trace_paths`).
"""

from __future__ import annotations

from pathlib import Path

import click
import numpy as np

from analysis.measures.commands import exported_name
from analysis.measures.row_columns import RowCol
from analysis.measures.trace_columns import TraceCol, TraceMeta, VehicleMeta
from scenarios.common.errors import SdcError
from sdc.cli.common import bad_input, exit_interrupted

#: the farthest [m] the ego's path may lie from the written road's reference lines
#: before the export warns that the two are not in one frame
FRAME_WARN_M = 30.0


@click.command()
@click.argument("sweep_dir", metavar="DIR", type=click.Path(path_type=Path))
@click.option("--run", "run_id", metavar="ID", required=True,
              help="The run of sweep DIR to export; the sweep must have kept its trace "
                   "(DIR/traces/ID.parquet: sdc sweep --traces failures or all).")
@click.option("--out", type=click.Path(dir_okay=False, path_type=Path), metavar="FILE.xosc",
              help="The OpenSCENARIO file to write; its road goes beside it as FILE.xodr "
                   "[default: ID.xosc in the working directory].")
def export(sweep_dir: Path, run_id: str, out: Path | None) -> None:
    """Write run ID of sweep DIR as an OpenSCENARIO 1.0 scenario (FILE.xosc) with its
    road as OpenDRIVE (FILE.xodr beside it), from the run's recorded trace.

    The ego, every traffic body and person the ego sensed follow their recorded paths
    (timed trajectories, in the trace's frame, which the road shares); bodies enter
    and leave the scene when they entered and left the ego's sensing radius; the
    obstacles stand where they stood; the scenario stops at the run's end. The road:
    an OpenDRIVE road is copied as it came, a SUMO network converted by SUMO's
    netconvert. The scenario is checked against ASAM's schema, the road against the
    trace's frame (a warning when the ego's path lies off its roads); both paths are
    printed.
    """
    if out is None:
        out = Path(exported_name(run_id))
    if out.suffix != ".xosc":
        bad_input(f"--out: {out} must end in .xosc")
    if not out.parent.is_dir():
        bad_input(f"--out: directory {out.parent} does not exist")
    try:
        written = export_run(sweep_dir, run_id, out)
    except SdcError as e:
        bad_input(str(e))
    except KeyboardInterrupt:
        exit_interrupted("interrupted")
    for line in written:
        click.echo(line)


def export_run(sweep_dir: Path, run_id: str, out: Path) -> list[str]:
    """Write run ``run_id`` of ``sweep_dir`` to ``out`` and its road beside it; the lines
    to print (the two paths, and a warning when the road and the paths are not in one
    frame). Bad input is a :class:`SdcError`."""
    from analysis.measures.trace_file import read_trace
    from analysis.measures.trace_paths import body_paths, standing_bodies
    from scenarios.asam.xodr_export import distance_to_roads_m, export_road
    from scenarios.asam.xosc_export import EGO, MovingBody, write_xosc
    from scenarios.spec.bodies import VEHICLE_MODELS
    from scenarios.spec.scenario_spec import ScenarioSpec
    from sdc.batch.sweeps.replay_check import load_recorded_run

    recorded = load_recorded_run(Path(sweep_dir), run_id)
    if recorded.trace_path is None:
        status = recorded.row[RowCol.status] if recorded.row else "not run yet"
        raise SdcError(f"--run: {run_id} of {sweep_dir} has no trace ({status}; DIR/traces/"
                       f"{run_id}.parquet is missing: the sweep keeps the traces of runs "
                       "that did not complete, or of all with --traces all)")
    trace, metadata = read_trace(recorded.trace_path)
    if len(trace) == 0:
        raise SdcError(f"--run: the trace of {run_id} holds no steps")
    spec = ScenarioSpec.from_plain(metadata[TraceMeta.spec])
    vehicle = metadata[TraceMeta.vehicle]
    f = trace.floats
    ego = MovingBody(EGO, "ego", vehicle[VehicleMeta.length_m], vehicle[VehicleMeta.width_m],
                     f[TraceCol.t_s], np.column_stack([f[TraceCol.x_m], f[TraceCol.y_m]]),
                     f[TraceCol.yaw_rad],
                     vehicle[VehicleMeta.center_ahead_of_rear_axle_m])
    model = VEHICLE_MODELS.get(vehicle.get(VehicleMeta.model))
    xodr = out.with_suffix(".xodr")
    shift = export_road(spec.road, xodr)
    lines = []
    if shift != (0.0, 0.0):
        lines.append(f"the road's OpenDRIVE was moved by ({shift[0]:g}, {shift[1]:g}) m "
                     "into the network's frame")
    gap_m = float(distance_to_roads_m(xodr, ego.xy).max())
    if gap_m > FRAME_WARN_M:
        lines.append(f"warning: the ego's path lies up to {gap_m:.0f} m from the roads of "
                     f"{xodr}: the road and the paths may not share a frame")
    step_s = spec.scenario.step_s
    write_xosc(out, road_file=xodr.name, ego=ego, bodies=body_paths(trace),
               obstacles=standing_bodies(metadata, spec), end_s=float(f[TraceCol.t_s][-1]),
               step_s=step_s,
               description=f"sdc run {run_id} of {Path(sweep_dir).name}: "
                           f"{spec.scenario.name}, controller {spec.controller.label}",
               wheelbase_m=model.wheelbase_m if model else None)
    return [*lines, f"scenario written to {out}", f"road written to {xodr}"]
