"""``sdc replay``: re-simulate one run of a sweep exactly, or draw a recorded trace."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import click

from analysis.measures.row_columns import RowCol
from analysis.measures.trace_columns import TraceCol
from scenarios.common.errors import SdcError
from sdc.cli.common import (
    EXIT_RUN_ERROR,
    a_finite_number,
    bad_input,
    check_at,
    exit_interrupted,
    progress_bar,
    warm_up_first,
)
from sdc.cli.run import summary_lines


def _has_display() -> bool:
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def _render(trace, metadata, out: Path, every: int, at_s: float | None = None) -> None:
    from analysis.measures.overlap_detail import drawn_overlaps
    from analysis.report.render import (
        animate,
        decisive_step,
        frame_png,
        recorded_outcome,
        scene_from_trace,
        step_at,
        write_html,
    )

    scene = scene_from_trace(trace, metadata)
    if out.suffix == ".png":
        k = (decisive_step(scene, recorded_outcome(metadata)) if at_s is None
             else step_at(scene, at_s))
        marked = drawn_overlaps(trace, metadata, k)
        out.write_bytes(frame_png(scene, k, marks=[
            (box, body.text()) for overlap, boxes in marked
            for box, body in zip(boxes, (overlap.first, overlap.second), strict=True)]))
        click.echo(f"step {k} (t = {scene.t_s[k]:.3f} s) written to {out}")
        for overlap, _ in marked:
            click.echo(f"  marked in red: {overlap.text()}")
        return
    if out.suffix == ".html":
        frames = write_html(scene, out, every)
    else:  # about 0.2 s a frame: show the progress
        with progress_bar(f"drawing {out.name}") as update:
            frames = animate(scene, out, every, on_frame=lambda i, n: update(i + 1, n))
    click.echo(f"{frames} frames written to {out}")


@click.command()
@click.argument("target", metavar="DIR|TRACE.parquet", type=click.Path(path_type=Path))
@click.option("--run", "run_id", metavar="ID", help="The run of sweep DIR to re-simulate.")
@click.option("--verify", is_flag=True, help="Exit 1 unless the re-simulation is identical.")
@click.option("--out", type=click.Path(dir_okay=False, path_type=Path),
              metavar="FILE.gif|.mp4|.html|.png",
              help="Draw the run: an animation (mp4 needs ffmpeg), an interactive page, or "
                   "one frame (.png: the decisive moment, or --at).")
@click.option("--at", "at_s", type=click.FloatRange(min=0.0, max_open=False),
              callback=a_finite_number, metavar="T",
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
    from analysis.measures.trace_file import read_trace

    if out is not None and out.suffix not in (".gif", ".mp4", ".html", ".png"):
        bad_input(f"--out: {out} must end in .gif, .mp4, .html or .png")
    if at_s is not None and (out is None or out.suffix != ".png"):
        bad_input("--at: draws one frame; give --out FILE.png with it")
    if out is not None and not out.parent.is_dir():
        bad_input(f"--out: directory {out.parent} does not exist")
    if out is not None and out.suffix == ".mp4":
        from analysis.report.render import can_write_mp4

        if not can_write_mp4():
            bad_input("--out: writing .mp4 needs ffmpeg on PATH; use .gif or .html")
    if gui and not _has_display():
        bad_input("--gui: no display here (DISPLAY is not set); draw the run with "
                   "--out run.html or run.gif instead")
    try:
        if target.suffix == ".parquet":
            if run_id or verify or gui:
                bad_input("--run, --verify and --gui need a sweep DIR, not a trace file")
            trace, metadata = read_trace(target)
            check_at(at_s, float(trace.floats[TraceCol.t_s][-1]))
            _render(trace, metadata, out or target.with_suffix(".html"), every, at_s)
            return
        if run_id is None:
            bad_input("--run: a run ID is required with a sweep DIR (see its results)")
        diverged = _replay_run(target, run_id, out, every, gui, at_s)
    except SdcError as e:
        bad_input(str(e))
    except KeyboardInterrupt:
        exit_interrupted("interrupted")
    if diverged is None or (verify and diverged):
        sys.exit(EXIT_RUN_ERROR)


def _replay_run(sweep_dir: Path, run_id: str, out: Path | None, every: int, gui: bool,
                at_s: float | None = None) -> bool | None:
    """Re-simulate, compare, report and draw; True when the replay is not identical
    (None: a run that failed in the sweep, not shown as far as it went)."""
    from analysis.measures.commands import draw_overlap_command
    from analysis.measures.trace_file import read_trace
    from sdc.batch.sweeps.replay_check import load_recorded_run, replay_verdict, version_warnings
    from sdc.run.episode import run_episode

    recorded = load_recorded_run(sweep_dir, run_id)
    # read before the re-simulation: a bad file stops the replay before it starts
    recorded_trace = read_trace(recorded.trace_path)[0] if recorded.trace_path else None
    for line in version_warnings(recorded.manifest):
        click.echo(line, err=True)
    if recorded.row is not None and recorded.row[RowCol.status] == "ok":
        check_at(at_s, recorded.row[RowCol.sim_time_s])
    warm_up_first(recorded.spec)
    if recorded.world is not None:
        episode = _replay_in_world(recorded, gui)
        if episode is None:
            return None
    elif recorded.row is not None and recorded.row[RowCol.status] != "ok":
        return _replay_failed_run(recorded, out, every, gui, at_s)
    else:
        episode = run_episode(recorded.spec, run_id=run_id, gui=gui)
    for line in summary_lines(run_id, episode.row,
                              lambda t_s: draw_overlap_command(sweep_dir, run_id, t_s)):
        click.echo(line)
    diverged, verdict = replay_verdict(recorded.row, recorded_trace, episode.trace, sweep_dir,
                                       run_id)
    click.echo(verdict)
    if out is not None:
        check_at(at_s, float(episode.trace.floats[TraceCol.t_s][-1]))
        _render(episode.trace, episode.metadata, out, every, at_s)
    return diverged


def _replay_in_world(recorded, gui: bool):
    """A run of a shared world: its world re-simulated with all its runs; the run's
    episode (None: it failed, said here)."""
    from sdc.run.shared_world import Failed, replay_in_world

    if gui:
        raise SdcError(f"--gui: {recorded.run_id} shared a world with other runs; sumo-gui "
                       "shows one ego's run (replay it without --gui)")
    run_ids, specs = recorded.world
    click.echo(f"{recorded.run_id}: slot {run_ids.index(recorded.run_id)} of a world of "
               f"{len(run_ids)} runs; re-simulating the world")
    outcome = replay_in_world(specs, run_ids, recorded.run_id,
                              recorded.manifest.egos_per_world)
    if isinstance(outcome, Failed):
        row = recorded.row
        click.echo(f"replay: {outcome.error}" + (f" (in the sweep: {row[RowCol.status]}: "
                                                 f"{row[RowCol.error]})" if row else ""))
        return None
    return outcome


def _replay_failed_run(recorded, out: Path | None, every: int, gui: bool,
                       at_s: float | None) -> bool | None:
    """A run that raised or timed out in its sweep: what it was and how it ended
    (one line), the replay's own end, and the run drawn as far as it went. True:
    the replay ended otherwise; None: it failed alike and nothing was drawn."""
    from analysis.measures.numbers import params_text
    from scenarios.spec.sweep_spec import PARAM_PREFIX
    from sdc.run.episode import Stopped, run_as_far_as_it_goes

    row = recorded.row
    params = params_text(row, [k for k in row if k.startswith(PARAM_PREFIX)])
    click.echo(f"{recorded.run_id}: {row[RowCol.status]} in the sweep: {row[RowCol.error]} "
               f"(controller {row[RowCol.controller]}, seed {row[RowCol.seed]}"
               + (f"; {params}" if params else "") + ")")
    limit_s = row[RowCol.wall_time_s] if row[RowCol.status] == "timeout" else None
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
    check_at(at_s, float(replayed.episode.trace.floats[TraceCol.t_s][-1]))
    _render(replayed.episode.trace, replayed.episode.metadata, out, every, at_s)
    return False
