"""``avoid`` passing a stopped car on the A10 with its demand (the catalog's
real-motorway-stop family, libsumo): the run where, before, it passed on the
right at a ramp's 23-degree kink and ran off the road, the line of the lane
beside never checked against the room its body sweeps. (A pass into a lane that
ends: test_avoid_traffic.)"""

from __future__ import annotations

import pytest

from scenarios import CATALOG_DIR
from scenarios.spec.sweep_plan import expand
from scenarios.spec.sweep_spec import load_sweep
from sdc.run.episode import run_episode


@pytest.fixture(scope="module")
def motorway_runs():
    sweep = load_sweep(CATALOG_DIR / "sweeps" / "real-motorway-stop.toml")
    return {run.run_id: run.spec for run in expand(sweep)}


@pytest.mark.slow
def test_a_pass_through_a_kink_stays_on_the_road(motorway_runs):
    row = run_episode(motorway_runs["00008-avoid"]).row
    assert row["collision_with"] == "none"
    assert row["outcome"] == "completed"
