"""How a sweep's runs shared worlds (``[sweep] egos_per_world``), from its rows: the
worlds, how many egos their SUMO steps carried, and what they cost against the same
runs alone."""

from __future__ import annotations

import pandas as pd

from analysis.measures.row_columns import RowCol


def world_sharing(results: pd.DataFrame, egos_per_world: int) -> dict | None:
    """The egos a world held at a time, the worlds (one SUMO simulation each) and the
    runs in them, and the cost (:func:`sharing_cost`); None when no run shared a
    world."""
    if RowCol.world_id not in results.columns or results[RowCol.world_id].isna().all():
        return None
    shared = results[results[RowCol.world_id].notna()]
    return {"egos_per_world": egos_per_world, "worlds": int(shared[RowCol.world_id].nunique()),
            "runs": len(shared), **entered_apart(shared), **sharing_cost(results)}


def entered_apart(shared: pd.DataFrame) -> dict:
    """Of the samples that ran under several controllers in shared worlds (each
    controller's runs in worlds of their own), how many entered their worlds at
    different steps: their runs met the traffic at different moments, so a paired
    comparison of those controllers does not compare them on the same traffic
    (``samples_apart`` of ``samples_paired``; both 0 without the columns)."""
    if RowCol.world_entry_step not in shared.columns or RowCol.sample not in shared.columns:
        return {"samples_paired": 0, "samples_apart": 0}
    steps = shared.groupby(RowCol.sample)[RowCol.world_entry_step]
    paired = steps.size() > 1
    apart = steps.nunique(dropna=False) > 1
    return {"samples_paired": int(paired.sum()), "samples_apart": int((paired & apart).sum())}


def sharing_cost(results: pd.DataFrame) -> dict:
    """SUMO's steps and the wall time of the ok runs, in the worlds they shared against
    each run in a world of its own.

    - ``sumo_steps`` (measured): a world steps until its last run ends, the run that
      entered at its step ``world_entry_step`` ending ``steps`` later; a run alone
      steps its own. Rows from before ``world_entry_step`` do not say when a run
      entered: each counts as entering at the start, a lower bound
      (``sumo_steps_exact`` is False).
    - ``steps_alone`` (estimated): each run's own steps, summed; ``egos_per_step``
      (measured): those over ``sumo_steps``, the egos a SUMO step carried on average.
    - ``wall_time_s`` (measured): a run's ``wall_time_s`` is its world's (its runs are
      summed up as the world ends), counted once a world: its runs' largest.
    - ``wall_time_alone_s`` (estimated): the wall time per step of the runs that ran
      in a world of their own (``alone_runs`` of them) times ``steps_alone``; None
      when no run ran alone.

    Warm-ups (shared by a warm state either way) are not counted."""
    ran = results[(results[RowCol.status] == "ok") & results[RowCol.steps].notna()]
    world = ran[RowCol.world_id].fillna(ran[RowCol.run_id])
    if RowCol.world_entry_step in ran.columns:
        entry = ran[RowCol.world_entry_step]
    else:
        entry = pd.Series(float("nan"), index=ran.index)
    exact = not (ran[RowCol.world_id].notna() & entry.isna()).any()
    last_step = entry.fillna(0) + ran[RowCol.steps]
    steps = int(last_step.groupby(world).max().sum())
    wall_s = float(ran[RowCol.wall_time_s].groupby(world).max().sum())
    alone = ran[ran[RowCol.world_egos].fillna(1) == 1]
    steps_alone = int(ran[RowCol.steps].sum())
    alone_steps = alone[RowCol.steps].sum()
    per_step_s = (float(alone[RowCol.wall_time_s].sum() / alone_steps)
                  if len(alone) and alone_steps > 0 else None)
    return {"sumo_steps": steps, "sumo_steps_exact": exact, "steps_alone": steps_alone,
            "egos_per_step": round(steps_alone / steps, 3) if steps else None,
            "wall_time_s": round(wall_s, 3),
            "wall_time_alone_s": None if per_step_s is None else round(per_step_s * steps_alone, 3),
            "alone_runs": len(alone), "ok_runs": len(ran)}
