"""The runs of a sweep worth looking at, ranked, each with what it was and, where its
trace was kept, a thumbnail of the moment that decided it."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from analysis.measures.commands import kept_trace_path
from analysis.measures.numbers import params_text
from analysis.measures.row_columns import RowCol
from analysis.measures.run_outcome import COLLIDED, STUCK, UNFINISHED, collided
from analysis.measures.stood_for import stood_for_text
from analysis.report.sweep_world import OTHER_RUNS_BODIES
from analysis.stats.verdicts import completed_runs

#: the classes, in the order they are listed
RANK_CLASSES = ("no outcome (error or timeout)", "collided where braking alone could stop",
                "collided", "stuck", "unfinished")
RANKING = ("Per controller, the controllers under test first, the lesson's seed maneuver and "
           "the lane-keep control group last. Ranked: runs without an outcome first, then "
           "collisions where braking alone could have stopped, other collisions, stuck runs, "
           "unfinished ones; within each, runs whose scenario other controllers completed "
           "first, then the smallest gap to an obstacle.")
#: the lesson's maneuver and the control group: listed after the controllers under test
REFERENCE_CONTROLLERS = ("seed", "lane-keep")
#: runs shown per controller and class, each with its thumbnail where its trace was
#: kept; the whole ranked list is a CSV beside the report
SHOWN_PER_CLASS = 3
#: that list's file, in the sweep directory
LIST_FILE = "runs-to-look-at.csv"


def classes_shown(rows: pd.DataFrame) -> list[tuple[str, list[dict], int]]:
    """One controller's ranked runs (:func:`ranked_runs`) class by class: the class,
    its first :data:`SHOWN_PER_CLASS` runs (records) and how many more it holds."""
    return [(rank_class, of_class.head(SHOWN_PER_CLASS).to_dict("records"),
             max(len(of_class) - SHOWN_PER_CLASS, 0))
            for rank_class, of_class in rows.groupby("rank_class", sort=False)]


def look_at_list(ranked: pd.DataFrame, params: list[str], replay) -> pd.DataFrame:
    """The whole ranked list (:func:`ranked_runs`) as a table to write beside the
    report: controller, rank within it, run, class, what happened, parameters and
    ``replay(run_id)``."""
    records = ranked.to_dict("records")
    return pd.DataFrame({
        RowCol.controller: ranked[RowCol.controller].to_numpy(),
        "rank": ranked["rank"].to_numpy(),
        RowCol.run_id: ranked[RowCol.run_id].to_numpy(), "class": ranked.rank_class.to_numpy(),
        "what_happened": ranked.why.to_numpy(),
        "parameters": [params_text(r, params) for r in records],
        "replay": [replay(r[RowCol.run_id]) for r in records]})


def _rank_class(results: pd.DataFrame) -> pd.Series:
    """Each run's index in :data:`RANK_CLASSES`; NaN for a run not worth a look."""
    ok = results[RowCol.status] == "ok"
    hit = ok & collided(results)
    stop = (results[RowCol.stop_possible].fillna(False).astype(bool)
            if RowCol.stop_possible in results else pd.Series(False, index=results.index))
    outcome = (results[RowCol.outcome] if RowCol.outcome in results
               else pd.Series(None, index=results.index))
    conditions = [~ok, hit & stop, hit, ok & (outcome == STUCK),
                  ok & (outcome == UNFINISHED)]
    return pd.Series(np.select(conditions, range(len(conditions)), default=-1),
                     index=results.index).replace(-1, np.nan)


def controller_order(controllers) -> list[str]:
    """The controllers under test in their order, then :data:`REFERENCE_CONTROLLERS`."""
    controllers = list(dict.fromkeys(controllers))
    return ([c for c in controllers if c not in REFERENCE_CONTROLLERS]
            + [c for c in REFERENCE_CONTROLLERS if c in controllers])


def ranked_runs(results: pd.DataFrame) -> pd.DataFrame:
    """The runs that did not complete without a collision, per controller
    (:func:`controller_order`) and ranked (:data:`RANKING`), with ``rank_class``
    (their class in :data:`RANK_CLASSES`), ``why`` (:func:`what_happened`) and
    ``others_completed`` (how many other controllers completed the same sample) and
    ``rank`` (its place among its controller's runs, from 1)."""
    done = completed_runs(results)
    completed_per_sample = done.groupby(results[RowCol.sample]).transform("sum")
    ranked = results.assign(_class=_rank_class(results),
                            others_completed=completed_per_sample - done.astype(int))
    ranked = ranked.dropna(subset=["_class"])
    order = {c: k for k, c in enumerate(controller_order(results[RowCol.controller]))}
    ranked = ranked.assign(rank_class=[RANK_CLASSES[int(c)] for c in ranked._class],
                           why=[what_happened(r) for r in ranked.to_dict("records")],
                           _controller=ranked[RowCol.controller].map(order),
                           _gap=ranked[RowCol.min_gap_obstacle_m].fillna(np.inf),
                           _others=-ranked.others_completed)
    ranked = (ranked.sort_values(["_controller", "_class", "_others", "_gap", RowCol.run_index])
              .drop(columns=["_controller", "_class", "_others", "_gap"]))
    return ranked.assign(rank=ranked.groupby(RowCol.controller, sort=False).cumcount() + 1)


def what_happened(row: Mapping[str, Any]) -> str:
    """A run that did not complete, in words: its error; what it hit, with which part,
    how fast and when; or how long it stood, how far it got and what it stood for
    (:func:`stood_for_text`; results from before it: how near it came to an obstacle)."""
    if row[RowCol.status] != "ok":
        return f"{row[RowCol.status]}: {row[RowCol.error]}"
    value = {k: None if pd.isna(v) else v for k, v in row.items() if not isinstance(v, list)}
    made = value.get(RowCol.progress_m)
    progress = "" if made is None else f", {made:.0f} m along the route"
    gap = value.get(RowCol.min_gap_obstacle_m)
    nearest = (f", {gap:.1f} m from an obstacle at the closest"
               if gap is not None and np.isfinite(gap) else "")
    outcome = value.get(RowCol.outcome)
    if outcome == COLLIDED or (outcome is None and value[RowCol.collision]):
        hit_what = value[RowCol.collision_with]
        what = {"obstacle": "the obstacle", "road_edge": "the road edge",
                "pedestrian": "a pedestrian"}.get(hit_what, "a vehicle")
        what = OTHER_RUNS_BODIES.get(value.get(RowCol.collision_body), what)  # a shared world's
        if value.get(RowCol.collision_vclass) and hit_what != "pedestrian":
            what += f" ({value[RowCol.collision_vclass]})"
        speed = value.get(RowCol.collision_speed_mps)
        verb = "was hit by" if value.get(RowCol.collision_role) == "was_hit" else "hit"
        return (f"{verb} {what} with its {value.get(RowCol.collision_part) or '?'}"
                + (f" at {speed:.1f} m/s" if speed is not None else "")
                + f", {value[RowCol.collision_time_s]:.1f} s in"
                + ("; braking alone could have stopped" if value.get(RowCol.stop_possible)
                   else ""))
    stood = value.get(RowCol.stood_at_end_s)
    what = stood_for_text(value)
    if outcome == STUCK:
        return ((f"stood still for the last {stood:.1f} s" if stood is not None
                 else "stood still at the end") + f"{progress}, "
                + (what or nearest.removeprefix(", ")))
    if what:  # unfinished, standing
        cycle = value.get(RowCol.stood_for_cycle_s)
        short = (f" (less than its light's {cycle:.0f} s cycle: the run ended too soon)"
                 if cycle is not None else "")
        return f"stood still for the last {stood:.1f} s{short}{progress}, {what}"
    return f"still moving when the run ended{progress}{nearest}"




def thumbnail(sweep_dir: Path, run_id: str) -> bytes | None:
    """The decisive moment of a run whose trace the sweep kept, as a small PNG; None
    without a trace."""
    from analysis.measures.trace_file import read_trace
    from analysis.report.render import (
        decisive_step,
        recorded_outcome,
        scene_from_trace,
        thumbnail_png,
    )

    path = kept_trace_path(sweep_dir, run_id)
    if not path.exists():
        return None
    trace, metadata = read_trace(path)
    scene = scene_from_trace(trace, metadata)
    step = decisive_step(scene, recorded_outcome(metadata))
    return thumbnail_png(scene, step)
