"""The sweep report's word on its world: the world audit (bodies other than the ego that
overlapped), who moved into whom in each collision, the vehicle classes hit, the red
lights crossed; the traffic model and the SUMO configurations the runs stepped."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from analysis.measures.commands import draw_overlap_command, replay_command
from analysis.measures.row_columns import RowCol
from analysis.measures.run_outcome import collided
from analysis.measures.world_audit import ROLE_TEXT
from scenarios.scene.snapshot import OTHER_EGO, OTHER_OBSTACLE
from scenarios.spec.bodies import PEDESTRIAN

#: a body of another run of a shared world, in words (column collision_body)
OTHER_RUNS_BODIES = {OTHER_EGO: "another run's ego", OTHER_OBSTACLE: "another run's obstacle"}


def world_summary(results: pd.DataFrame) -> dict:
    """The world audit (runs with ``world_overlaps``) and, per controller, its
    collisions by who moved into whom and the part of the ego hit (sweeps made before
    these columns: not recorded)."""
    if RowCol.world_overlaps not in results.columns:
        return {"recorded": False}
    ok = results[results[RowCol.status] == "ok"]
    overlaps = ok[RowCol.world_overlaps].fillna(0)
    hits = ok[collided(ok) & ok[RowCol.collision_role].notna()]
    vclass, body = RowCol.collision_vclass, RowCol.collision_body
    classes = (hits[hits[vclass].notna() & (hits[vclass] != PEDESTRIAN)]
               if vclass in hits.columns else hits.iloc[:0].assign(**{vclass: None}))
    others = (hits[hits[body].isin(list(OTHER_RUNS_BODIES))]
              if body in hits.columns else hits.iloc[:0])
    classes = classes.drop(index=others.index, errors="ignore")  # traffic's classes only
    sumo = (ok[RowCol.sumo_overlaps].fillna(0) if RowCol.sumo_overlaps in ok.columns
            else overlaps * 0)
    controller = RowCol.controller
    return {"recorded": True, "runs_with_overlaps": int((overlaps > 0).sum()),
            "overlap_steps": int(overlaps.sum()),
            "first_overlap_run": _first_run(ok, overlaps),
            **_first_overlap(ok, overlaps, RowCol.first_overlap, RowCol.first_overlap_s),
            "runs_with_sumo_overlaps": int((sumo > 0).sum()),
            "sumo_overlap_steps": int(sumo.sum()),
            "first_sumo_overlap_run": _first_run(ok, sumo),
            **_first_overlap(ok, sumo, RowCol.first_sumo_overlap, RowCol.first_sumo_overlap_s),
            "collisions": {str(c): {str(role): {str(part): int(n) for part, n in
                                                 by_role[RowCol.collision_part]
                                                 .value_counts().items()}
                                    for role, by_role in rows.groupby(RowCol.collision_role)}
                           for c, rows in hits.groupby(controller, sort=False)},
            "vehicle_classes": {str(c): {str(k): int(n) for k, n in
                                         rows[vclass].value_counts().items()}
                                for c, rows in classes.groupby(controller, sort=False)},
            # collisions with another run's ego or obstacle (a shared world)
            "other_runs": {str(c): {str(k): int(n) for k, n in
                                    rows[body].value_counts().items()}
                           for c, rows in others.groupby(controller, sort=False)},
            "red_lights": _red_lights(ok)}


def _first_run(ok: pd.DataFrame, steps: pd.Series) -> str | None:
    """The id of the first run with ``steps`` > 0 (None: none)."""
    return str(ok[RowCol.run_id][steps > 0].iloc[0]) if (steps > 0).any() else None


def _first_overlap(ok: pd.DataFrame, steps: pd.Series, column: str, time_column: str) -> dict:
    """The first run's first overlap (``column``: in words; ``time_column``, named
    ``column``_s: its time), where the row names it (sweeps before the column: not at
    all)."""
    if column not in ok.columns or not (steps > 0).any():
        return {}
    row = ok[steps > 0].iloc[0]
    if pd.isna(row[column]):
        return {}
    return {column: str(row[column]), time_column: float(row[time_column])}


def _red_lights(ok: pd.DataFrame) -> dict | None:
    """Per controller: runs that crossed a red light, and the crossings (None: the
    sweep predates the column, or no run met a traffic light's red)."""
    if RowCol.red_light_violations not in ok.columns:
        return None
    counts = ok[RowCol.red_light_violations].fillna(0)
    if not counts.any():
        return None
    return {str(c): {"runs": int((rows > 0).sum()), "crossings": int(rows.sum()),
                     "of": int(len(rows))}
            for c, rows in counts.groupby(ok[RowCol.controller], sort=False)}


def world_lines(world: dict, traffic_model: str | None = None,
                sumo_config: list | None = None, sweep_dir: str | None = None) -> list[str]:
    """The traffic model, the world audit (``world``: a :func:`world_summary`; a WARNING
    when bodies other than the ego overlapped: a world that made something up), and
    each controller's collisions split into those it ran into and those in which it
    was hit. Its replay commands name ``sweep_dir`` (``DIR`` when not given)."""

    def replay(run_id: str) -> str:
        return replay_command(Path(sweep_dir) if sweep_dir else Path("DIR"), run_id)

    lines = [f"Traffic model: {traffic_model or 'not recorded'}."]
    for config in sumo_config or []:
        overridden = ", ".join(f"{name} {value}" for name, value in config["overridden"].items())
        step = (f"steps of {config['step_s']:g} s ({config['step_from']}); "
                if "step_s" in config else "")
        lines.append(f"SUMO configuration {config['file']}: its own demand from "
                     f"{config['begin_s']:g} s; {step}overridden by the run: "
                     f"{overridden or 'nothing'}; not applied: "
                     f"{', '.join(config['not_applied']) or 'nothing'}.")
    if not world["recorded"]:
        return lines + ["World audit: not recorded (the sweep predates it)."]
    if world["runs_with_overlaps"]:
        lines.append(f"WARNING: in {plural(world['runs_with_overlaps'], 'run')} two bodies "
                     f"other than the ego overlapped where SUMO's own lanes hold them apart "
                     f"({world['overlap_steps']} steps in all, column world_overlaps): sdc's "
                     "world made something up, and their verdicts are suspect; see one with "
                     f"{replay(world.get('first_overlap_run'))} and report it."
                     + _overlap_told(world, RowCol.first_overlap, sweep_dir))
    else:
        lines.append("World audit: no two bodies other than the ego overlapped in any run "
                     "where SUMO's own lanes hold them apart (world_overlaps 0).")
    if world.get("runs_with_sumo_overlaps"):
        lines.append(f"SUMO's own overlaps: in {plural(world['runs_with_sumo_overlaps'], 'run')}"
                     " SUMO's own model held two bodies inside each other "
                     f"({world['sumo_overlap_steps']} steps, column sumo_overlaps: vehicles "
                     "waiting on a junction's crossing lanes, bicycles through pedestrians); "
                     "that is SUMO's world as it is, not sdc's coupling, and the ego's verdicts "
                     f"stand; to see one: {replay(world['first_sumo_overlap_run'])}."
                     + _overlap_told(world, RowCol.first_sumo_overlap, sweep_dir))
    for controller, roles in world["collisions"].items():
        parts = [f"{ROLE_TEXT.get(role, role)} {sum(by_part.values())} ("
                 + ", ".join(f"{part} {n}" for part, n in sorted(by_part.items())) + ")"
                 for role, by_part in sorted(roles.items())]
        lines.append(f"{controller}'s collisions by who moved into whom: {'; '.join(parts)}.")
    for controller, classes in world.get("vehicle_classes", {}).items():
        hit = ", ".join(f"{vclass} {n}" for vclass, n in sorted(classes.items()))
        lines.append(f"{controller}'s collisions with vehicles by vehicle class: {hit}.")
    for controller, bodies in world.get("other_runs", {}).items():
        hit = ", ".join(f"{OTHER_RUNS_BODIES[body]} {n}" for body, n in sorted(bodies.items()))
        lines.append(f"{controller}'s collisions with another run's bodies in a shared world "
                     f"(column collision_body): {hit}.")
    red = world.get("red_lights")
    if red:
        lines.append("Red lights crossed (column red_light_violations: stop lines the front "
                     "bumper crossed while the light showed red): " + "; ".join(
                         f"{c} {v['crossings']} in {v['runs']} of {v['of']} runs"
                         for c, v in red.items()) + ".")
    return lines


def _overlap_told(world: dict, column: str, sweep_dir: str | None) -> str:
    """The first run's first overlap in words and the command that draws it, last on
    the line so that it copies whole (a sweep before the column: nothing)."""
    if column not in world:
        return ""
    run_id = world[f"{column}_run"]
    draw = draw_overlap_command(Path(sweep_dir) if sweep_dir else Path("DIR"), run_id,
                                world[f"{column}_s"])
    return f" {run_id} overlapped first {world[column]}; draw it: {draw}"


def plural(count: int, noun: str) -> str:
    return f"{count} {noun}" + ("" if count == 1 else "s")
