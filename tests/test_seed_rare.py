"""The catalog family seed-rare: rare failures of the seed maneuver, with a documented truth."""

from __future__ import annotations

import json

import numpy as np
import pytest

from analysis.rare.grid_probability import threshold_probability
from scenarios import CATALOG_DIR
from scenarios.spec.scenario_spec import ScenarioSpec
from scenarios.spec.sweep_params import set_path
from scenarios.spec.sweep_plan import expand
from scenarios.spec.sweep_spec import load_sweep

FAMILY = CATALOG_DIR / "sweeps" / "seed-rare.toml"
TRUTH = json.loads((CATALOG_DIR / "sweeps" / "seed-rare.truth.json").read_text())


def test_the_family_is_continuous_deterministic_and_runs_the_seed():
    sweep = load_sweep(FAMILY)
    assert sweep.controllers == ("seed",) and sweep.sampler == "random"
    assert {p.kind for p in sweep.params} <= {"uniform", "normal", "loguniform"}
    base = sweep.base
    assert base.traffic.flow_vph_per_lane == 0 and base.lidar.noise_std_m == 0
    assert all(run.spec is not None for run in expand(sweep.with_samples(50)))


def test_the_truth_file_describes_this_family():
    params = {p.path: list(p.args) for p in load_sweep(FAMILY).params}
    assert {name: table["normal"] for name, table in TRUTH["nominal"].items()} == params
    assert TRUTH["family"] == "scenarios/catalog/sweeps/seed-rare.toml"



def test_the_truth_recomputes_from_the_recorded_swing():
    """The integral of truths/seed_rare_truth.py over the stored C(v), without SUMO."""
    scan = TRUTH["truth_scan"]
    speeds = np.linspace(*scan["speed_grid"])
    normals = {name: tuple(table["normal"]) for name, table in TRUTH["nominal"].items()}
    again = threshold_probability(speeds, np.array(scan["swing_m"]) / 2.5,
                                  normals["ego.speed_mps"], normals["road.lane_width_m"])
    assert again.p == pytest.approx(TRUTH["p_true"], rel=1e-4)
    assert again.low == pytest.approx(TRUTH["p_low"], rel=1e-4)
    assert again.high == pytest.approx(TRUTH["p_high"], rel=1e-4)



@pytest.mark.slow
@pytest.mark.parametrize("example", TRUTH["boundary_examples"],
                         ids=lambda e: f"{e['lane_width_m']}m-{e['speed_mps']}mps")
def test_runs_beside_the_boundary_collide_or_pass_as_the_truth_says(example):
    from sdc.run.episode import run_episode

    plain = load_sweep(FAMILY).base.to_plain()
    set_path(plain, "ego.speed_mps", example["speed_mps"])
    set_path(plain, "road.lane_width_m", example["lane_width_m"])
    row = run_episode(ScenarioSpec.from_plain(plain)).row
    assert row["collision"] is example["collision"]
    if example["collision"]:
        assert row["collision_with"] == "road_edge"
    else:
        assert row["min_road_edge_gap_m"] == pytest.approx(example["predicted_gap_m"], abs=1e-6)
