"""How a sweep's runs shared worlds (``[sweep] egos_per_world``), from its rows."""

from __future__ import annotations

import pandas as pd


def world_sharing(results: pd.DataFrame, egos_per_world: int) -> dict | None:
    """The egos asked a world, the worlds, the runs in them, the SUMO simulations they
    took (a world whose runs did not all fit apart takes more: each run counts as
    1 / ``world_egos`` of one) and the runs that shared theirs with fewer egos than
    asked; None when no run shared a world."""
    if "world_id" not in results.columns or results.world_id.isna().all():
        return None
    shared = results[results.world_id.notna()]
    egos = shared.world_egos.dropna()
    return {"egos_per_world": egos_per_world, "worlds": int(shared.world_id.nunique()),
            "runs": len(shared), "simulations": round(float((1 / egos).sum())),
            "runs_with_fewer": int((egos < egos_per_world).sum())}
