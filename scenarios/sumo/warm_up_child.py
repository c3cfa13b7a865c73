"""The fresh process a warm state is computed in (``scenarios/sumo/warm_up_process.py``
says why): ``python -m scenarios.sumo.warm_up_child SPEC.json KEY [CACHE_DIR]`` computes the
warm state of the spec (its plain JSON) with key ``KEY`` into the warm-state cache,
printing ``t_s T`` (SUMO's clock) on stdout as it goes.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from scenarios.common.atomic_write import write_atomic
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.sumo.sumo_world import SumoWorld
from scenarios.sumo.warm_state import cached_path
from scenarios.sumo.warm_up_process import PROGRESS_PREFIX
from scenarios.sumo_net.road_source import road_source


def main(argv: list[str]) -> None:
    spec = ScenarioSpec.from_plain(json.loads(Path(argv[0]).read_text()))
    key, cache_dir = argv[1], (Path(argv[2]) if len(argv) > 2 else None)
    source = road_source(spec.road)  # this process's one: its world is handed it
    with SumoWorld(spec, source.geometry(spec, cache_dir), cache_dir, source=source) as world:
        state = world.compute_warm_state(
            key, lambda t_s: print(f"{PROGRESS_PREFIX}{t_s!r}", flush=True))
    path = cached_path(key)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(path, lambda tmp: tmp.write_bytes(state.to_bytes()))


if __name__ == "__main__":
    main(sys.argv[1:])
