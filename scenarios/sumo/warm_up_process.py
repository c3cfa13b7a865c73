"""Warm states computed in a Python process of their own.

libsumo (SUMO 1.28) seeds its route parser's random number generator again at every
start, so a simulation draws the same numbers whatever ran before it in the process,
but it does not reset the generator's count of draws; a saved state records that
count, and loading the state skips that many draws. A warm state computed after
another simulation in the same process held another count (measured: 670 draws
where a fresh process records 354), and every run loaded from it drew other numbers
than the same run from the same warm state computed elsewhere. Computed in a fresh
interpreter, a warm state depends on its inputs only, wherever and after whatever it
is computed.

The process runs ``python -m scenarios.sumo.warm_up_child SPEC.json KEY [CACHE_DIR]``.
"""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

from scenarios.common.errors import SdcError
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.sumo.warm_state import WarmState, cached_path

#: how the process says how far its warm-up got: this, then SUMO's clock [s]
PROGRESS_PREFIX = "t_s "


def computed_apart(spec: ScenarioSpec, key: str, cache_dir: Path | None, scratch: Path,
                   on_sample: Callable[[float], None] | None = None) -> WarmState:
    """Compute ``spec``'s warm state (key ``key``) in a fresh Python process into the
    cache, and read it; ``scratch``: a folder for the spec's file and the process's
    errors; ``on_sample``: called with SUMO's clock [s] as the warm-up goes on."""
    spec_file = scratch / "warm-spec.json"
    spec_file.write_text(json.dumps(spec.to_plain()))
    command = [sys.executable, "-m", "scenarios.sumo.warm_up_child", str(spec_file), key,
               *([str(cache_dir)] if cache_dir is not None else [])]
    with open(scratch / "warm-up-errors.txt", "w+") as errors:
        child = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=errors, text=True)
        try:
            for line in child.stdout:
                if on_sample is not None and line.startswith(PROGRESS_PREFIX):
                    on_sample(float(line.removeprefix(PROGRESS_PREFIX)))
            code = child.wait()
        finally:  # an interrupt leaves no SUMO behind
            if child.poll() is None:
                child.kill()
                child.wait()
            child.stdout.close()
        if code != 0:
            errors.seek(0)
            tail = "\n".join(errors.read().strip().splitlines()[-5:])
            raise SdcError(f"computing the warm state {key[:12]}... failed:\n{tail}")
    return WarmState.read(cached_path(key))
