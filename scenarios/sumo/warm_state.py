"""Warm states: a road's background traffic after its warm-up, saved by SUMO once and
loaded by every run that shares it.

A warm state is identified by everything the warm-up depends on (:func:`warm_key`):
the network file's sha256, the traffic spec, the warm-up's seed
(``traffic.warm_seed``, default the scenario's), ``warm_up_s``, the step length,
SUMO's version and the options of the traffic model it runs with
(``scenarios/scene/traffic_model.py``), and this file's format. The ego, its route
and the obstacles are not part of it: they enter when a run loads it.

One state is one file (:class:`WarmState`): a zip holding SUMO's own state
(``simulation.saveState`` with ``--save-state.precision 17`` and
``--save-state.rng true``, so positions and SUMO's random generators come back
exact; ``--save-state.transportables true``, so its persons and their flows come
back too: without it a loaded state has none and their person flows stop) beside
what SUMO cannot save: our random-trip generator and its count of trips
(``sumo_net`` roads), and how the traffic settled while it warmed up
(:data:`SETTLING_COLUMNS`, sampled every :data:`SETTLING_SAMPLE_S`).

Loading a state into a SUMO that already ran does not rewind it exactly (lane-change
memory survives), but a SUMO started afresh on a state always continues alike. So
every run with a warm-up starts a fresh SUMO on the loaded state, whether the state
was just computed, found in the cache or shipped with the job: the trace is the same.
"""

from __future__ import annotations

import dataclasses
import hashlib
import io
import json
import zipfile
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING

from scenarios.common.cache_dir import sdc_cache_dir
from scenarios.common.errors import SdcError
from scenarios.scene import traffic_model
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.spec.world_seating import traffic_seed

if TYPE_CHECKING:  # a name only: the roads' import loads the kernels (SDC_KERNELS)
    from scenarios.sumo_net.road_source import RoadSource

#: bumped whenever what a state holds or how a warm-up runs changes (2: its persons)
WARM_FORMAT = 2
#: SUMO's options of the warm-up that saves a state (loading needs none of them)
SAVE_OPTIONS = ("--save-state.precision", "17", "--save-state.rng", "true",
                "--save-state.transportables", "true")
#: how often the warm-up records the network's traffic [s of simulated time]
SETTLING_SAMPLE_S = 1.0
SETTLING_COLUMNS = ("t_s", "vehicles", "mean_speed_mps", "halting")
#: a vehicle slower than this halts (SUMO's own threshold for "halting") [m/s]
HALTING_SPEED_MPS = 0.1
#: a sweep directory's file of how the traffic settled in its warm states' warm-ups
SETTLING_FILE = "warm-states.json"
_SUMO_STATE, _META = "sumo-state.xml.gz", "warm-state.json"
_ZIP_TIME = (2020, 1, 1, 0, 0, 0)  # fixed, so equal states make equal files


def warm_seed(spec: ScenarioSpec) -> int:
    """The seed of ``spec``'s warm-up: its traffic's seed, ``traffic.warm_seed`` or the
    scenario's (:func:`scenarios.spec.world_seating.traffic_seed`)."""
    return traffic_seed(spec)


def uses_warm_state(spec: ScenarioSpec) -> bool:
    """Does a run of ``spec`` start from a warm state (a SUMO run with a warm-up; a
    ``sumo_config`` road always: its demand runs until ``traffic.enter_s``)?"""
    return spec.scenario.world_backend.warm_states and (spec.traffic.warm_up_s > 0
                                                       or spec.road.own_demand)


def sumo_version() -> str:
    return metadata.version("libsumo")


def warm_key(spec: ScenarioSpec, net_sha256: str) -> str:
    """The identity of ``spec``'s warm state, on the network whose file has ``net_sha256``
    (:meth:`scenarios.sumo_net.road_source.RoadSource.identity_sha256`)."""
    traffic = {k: v for k, v in dataclasses.asdict(spec.traffic).items() if k != "warm_seed"}
    body = {"format": WARM_FORMAT, "sumo": sumo_version(), "net_sha256": net_sha256,
            "sumo_options": list(traffic_model.sumo_options(spec.traffic.lane_change_s)),
            "traffic": traffic, "seed": warm_seed(spec), "step_s": spec.scenario.step_s}
    return hashlib.sha256(json.dumps(body, sort_keys=True).encode()).hexdigest()


def warm_state_key(spec: ScenarioSpec, source: RoadSource, cache_dir: Path | None = None) -> str:
    """The key of ``spec``'s warm state: :func:`warm_key` on the identity of its road
    (``source``: its run's road source, handed down from where the run started)."""
    return warm_key(spec, source.identity_sha256(cache_dir))


#: a warm state as a result row names it: its key's first hex digits
WARM_ID_CHARS = 16


def warm_state_id(key: str | None) -> str | None:
    return None if key is None else key[:WARM_ID_CHARS]


def warm_state_dir() -> Path:
    """Where warm states are cached: ``<sdc cache>/warm-states``."""
    return sdc_cache_dir() / "warm-states"


def cached_path(key: str) -> Path:
    return warm_state_dir() / f"{key}.zip"


@dataclasses.dataclass(frozen=True)
class WarmState:
    """One warm state: its key, SUMO's saved state and what SUMO cannot save."""

    key: str
    t_s: float  # simulated time the state was saved at
    sumo_state: bytes  # SUMO's .xml.gz
    demand: dict | None  # the random trips' generator state and trips made (sumo_net)
    settling: dict[str, list[float]]  # SETTLING_COLUMNS over the warm-up

    def to_bytes(self) -> bytes:
        meta = {"format": WARM_FORMAT, "key": self.key, "t_s": self.t_s,
                "demand": self.demand, "settling": self.settling}
        out = io.BytesIO()
        with zipfile.ZipFile(out, "w") as z:
            z.writestr(zipfile.ZipInfo(_SUMO_STATE, _ZIP_TIME), self.sumo_state)
            z.writestr(zipfile.ZipInfo(_META, _ZIP_TIME), json.dumps(meta, sort_keys=True))
        return out.getvalue()

    @classmethod
    def read(cls, path: str | Path) -> WarmState:
        """The state in file ``path``; an :class:`SdcError` naming it when unusable."""
        try:
            with zipfile.ZipFile(path) as z:
                meta = json.loads(z.read(_META))
                sumo_state = z.read(_SUMO_STATE)
            if meta.get("format") != WARM_FORMAT:
                raise SdcError(f"warm state {path}: format {meta.get('format')}, this sdc "
                               f"reads {WARM_FORMAT}")
            return cls(meta["key"], meta["t_s"], sumo_state, meta["demand"], meta["settling"])
        except (OSError, KeyError, ValueError, AttributeError, zipfile.BadZipFile) as e:
            raise SdcError(f"warm state {path}: cannot be read ({type(e).__name__}: {e})") \
                from None
