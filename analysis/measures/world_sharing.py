"""How a sweep's runs shared worlds (``[sweep] egos_per_world``), from its rows: the
worlds and SUMO simulations, and what they cost against the same runs alone."""

from __future__ import annotations

import math

import pandas as pd

from analysis.measures.row_columns import RowCol


def world_sharing(results: pd.DataFrame, egos_per_world: int) -> dict | None:
    """The egos asked a world, the worlds, the runs in them, the SUMO simulations they
    took (a world whose runs did not all fit apart takes more: each run counts as
    1 / ``world_egos`` of one), the runs that shared theirs with fewer egos than
    asked, and the cost (:func:`sharing_cost`); None when no run shared a world."""
    if RowCol.world_id not in results.columns or results[RowCol.world_id].isna().all():
        return None
    shared = results[results[RowCol.world_id].notna()]
    egos = shared[RowCol.world_egos].dropna()
    return {"egos_per_world": egos_per_world, "worlds": int(shared[RowCol.world_id].nunique()),
            "runs": len(shared), "simulations": round(float((1 / egos).sum())),
            "runs_with_fewer": int((egos < egos_per_world).sum()), **sharing_cost(results)}


def sharing_cost(results: pd.DataFrame) -> dict:
    """SUMO's steps and the wall time of the ok runs, in the simulations they shared
    against each run in a simulation of its own.

    - ``sumo_steps`` (measured): a simulation steps as long as its longest run. The rows
      tell a world's simulations apart by their ``world_egos`` only: a world's runs of
      one ``world_egos`` that took several simulations of that many egos count the
      longest run's steps for each (an upper bound: ``sumo_steps_exact`` is False).
    - ``steps_alone`` (estimated): each run's own steps, summed.
    - ``wall_time_s`` (measured): a run's ``wall_time_s`` is its simulation's, counted
      once a simulation (bounded as the steps are).
    - ``wall_time_alone_s`` (estimated): the wall time per step of the runs that ran in
      a simulation of their own (``alone_runs`` of them) times ``steps_alone``; None
      when no run ran alone.

    Warm-ups (shared by a warm state either way) are not counted."""
    ran = results[(results[RowCol.status] == "ok") & results[RowCol.steps].notna()]
    egos = ran[RowCol.world_egos].fillna(1).astype(int)
    simulation = [ran[RowCol.world_id].fillna(ran[RowCol.run_id]), egos]
    steps, wall_s, exact = 0, 0.0, True
    for (_, egos_each), runs in ran.groupby(simulation):
        run_steps, run_wall_s = runs[RowCol.steps], runs[RowCol.wall_time_s]
        if egos_each == 1:  # each run its own simulation
            steps, wall_s = steps + int(run_steps.sum()), wall_s + float(run_wall_s.sum())
            continue
        simulations = math.ceil(len(runs) / egos_each)
        exact &= simulations == 1
        steps += simulations * int(run_steps.max())
        wall_s += simulations * float(run_wall_s.max())
    alone = ran[egos == 1]
    steps_alone = int(ran[RowCol.steps].sum())
    alone_steps = alone[RowCol.steps].sum()
    per_step_s = (float(alone[RowCol.wall_time_s].sum() / alone_steps)
                  if len(alone) and alone_steps > 0 else None)
    return {"sumo_steps": steps, "sumo_steps_exact": exact, "steps_alone": steps_alone,
            "wall_time_s": round(wall_s, 3),
            "wall_time_alone_s": None if per_step_s is None else round(per_step_s * steps_alone, 3),
            "alone_runs": len(alone), "ok_runs": len(ran)}
