"""A world's warm-up: its traffic run on its own before any ego enters, saved as a warm
state (``scenarios/sumo/warm_state.py``) that every run of the same traffic starts
from; found where the caller has it, in the cache, or computed.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from scenarios.common.errors import SdcError
from scenarios.scene.road_geometry import RoadGeometry
from scenarios.sumo.network_demand import NetworkDemand
from scenarios.sumo.routes_xml import warm_up_routes_xml
from scenarios.sumo.sumo_process import SumoProcess
from scenarios.sumo.warm_state import (
    HALTING_SPEED_MPS,
    SAVE_OPTIONS,
    SETTLING_COLUMNS,
    SETTLING_SAMPLE_S,
    WarmState,
    cached_path,
    warm_seed,
)
from scenarios.sumo.warm_up_process import computed_apart

OnSample = Callable[[float], None] | None


def find_warm_state(process: SumoProcess, key: str, given: Path | None,
                    on_sample: OnSample = None) -> WarmState:
    """The warm state of ``process``'s spec with key ``key``: the file ``given``, else
    the cached one, else computed now in a fresh process (and cached; ``on_sample`` is
    called with SUMO's clock as it goes). A given or cached file made for other
    traffic is an :class:`SdcError`, never a run on it."""
    path = given or cached_path(key)
    if given is None and not path.is_file():
        # apart: SUMO's state would hold what ran before it in this process
        return computed_apart(process.spec, key, process.cache_dir, process.scratch(),
                              on_sample)
    state = WarmState.read(path)
    if state.key != key:
        raise SdcError(f"warm state {path}: made for other traffic (key "
                       f"{state.key[:12]}..., this run's {key[:12]}...)")
    return state


def compute_warm_state(process: SumoProcess, sim, road: RoadGeometry, key: str,
                       is_traffic: Callable[[str], bool], on_sample: OnSample = None
                       ) -> WarmState:
    """Warm ``process``'s traffic up on ``road`` in SUMO (``sim``: libsumo), no ego in
    it, and save it as the warm state of key ``key``, recording how the network's
    traffic settles on the way (each sample's time goes to ``on_sample``, for
    progress); SUMO is closed after."""
    spec = process.spec
    demand = NetworkDemand.drawn(spec, road, process.source, warm_seed(spec))
    trips = demand.first(spec.traffic.vehicles)
    own = (None if process.config is not None
           else warm_up_routes_xml(spec, process.source.flows, trips))
    process.start(sim, ["sumo"], own, *SAVE_OPTIONS, seed=warm_seed(spec))
    try:
        steps = process.source.warm_up_steps(spec)
        every = max(1, round(SETTLING_SAMPLE_S / spec.scenario.step_s))
        settling: dict[str, list[float]] = {c: [] for c in SETTLING_COLUMNS}
        for k in range(1, steps + 1):
            sim.simulationStep()
            demand.renew(sim, is_traffic)
            if k % every == 0 or k == steps:
                _record_settling(sim, settling)
                if on_sample is not None:
                    on_sample(settling["t_s"][-1])
        saved = process.scratch() / "saved-state.xml.gz"
        sim.simulation.saveState(str(saved))
        state = WarmState(key, sim.simulation.getTime(), saved.read_bytes(), demand.saved(),
                          settling)
    finally:
        process.end()
    return state


def _record_settling(sim, settling: dict[str, list[float]]) -> None:
    """One sample of how the network's traffic settles: SUMO's clock, its vehicles,
    their mean speed and how many halt."""
    vehicle = sim.vehicle
    speeds = np.array([vehicle.getSpeed(v) for v in vehicle.getIDList()])
    settling["t_s"].append(sim.simulation.getTime())
    settling["vehicles"].append(len(speeds))
    settling["mean_speed_mps"].append(float(speeds.mean()) if len(speeds) else 0.0)
    settling["halting"].append(int((speeds < HALTING_SPEED_MPS).sum()))
