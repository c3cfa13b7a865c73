"""The runs of a sweep worth looking at, ranked, each with what it was and, where its
trace was kept, a thumbnail of the moment that decided it."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from analysis.run_outcome import STUCK, UNFINISHED
from analysis.verdicts import completed_runs

#: the classes, in the order they are listed
RANK_CLASSES = ("no outcome (error or timeout)", "collided where braking alone could stop",
                "collided", "stuck", "unfinished")
RANKING = ("Ranked: runs without an outcome first, then collisions where braking alone could "
           "have stopped, other collisions, stuck runs, unfinished ones; within each, runs "
           "whose scenario other controllers completed first, then the smallest gap to an "
           "obstacle.")
MAX_THUMBNAILS = 12


def _rank_class(results: pd.DataFrame) -> pd.Series:
    """Each run's index in :data:`RANK_CLASSES`; NaN for a run not worth a look."""
    ok = results.status == "ok"
    collided = ok & results.collision.fillna(False).astype(bool)
    stop = (results.stop_possible.fillna(False).astype(bool) if "stop_possible" in results
            else pd.Series(False, index=results.index))
    outcome = results.outcome if "outcome" in results else pd.Series(None, index=results.index)
    conditions = [~ok, collided & stop, collided, ok & (outcome == STUCK),
                  ok & (outcome == UNFINISHED)]
    return pd.Series(np.select(conditions, range(len(conditions)), default=-1),
                     index=results.index).replace(-1, np.nan)


def ranked_runs(results: pd.DataFrame) -> pd.DataFrame:
    """The runs that did not complete without a collision, ranked (:data:`RANKING`),
    with ``why`` (their class) and ``others_completed`` (how many other controllers
    completed the same sample)."""
    done = completed_runs(results)
    completed_per_sample = done.groupby(results["sample"]).transform("sum")
    ranked = results.assign(_class=_rank_class(results),
                            others_completed=completed_per_sample - done.astype(int))
    ranked = ranked.dropna(subset=["_class"])
    ranked = ranked.assign(why=[RANK_CLASSES[int(c)] for c in ranked._class],
                           _gap=ranked.min_gap_obstacle_m.fillna(np.inf),
                           _others=-ranked.others_completed)
    return (ranked.sort_values(["_class", "_others", "_gap", "run_index"])
            .drop(columns=["_class", "_others", "_gap"]))


def params_text(row: Mapping[str, Any], columns: list[str]) -> str:
    """A run's swept values, ``name=value`` without the ``p.`` prefix."""
    parts = []
    for column in columns:
        value = row[column]
        shown = f"{value:.4g}" if isinstance(value, float) else str(value)
        parts.append(f"{column.removeprefix('p.')}={shown}")
    return ", ".join(parts)


def thumbnail(sweep_dir: Path, run_id: str) -> bytes | None:
    """The decisive moment of a run whose trace the sweep kept, as a small PNG; None
    without a trace."""
    from analysis.render import decisive_step, frame_png, scene_from_trace
    from analysis.trace_file import read_trace

    path = Path(sweep_dir) / "traces" / f"{run_id}.parquet"
    if not path.exists():
        return None
    trace, metadata = read_trace(path)
    scene = scene_from_trace(trace, metadata)
    step = decisive_step(scene, metadata.get("run", {}).get("outcome"))
    return frame_png(scene, step, width_px=420, height_px=220, title=False)
