"""`avoid` on any road, in libsumo: the catalog's avoid-roads family (curves both
ways, a town grid with turning routes, faster traffic from behind) on a few of
its scenarios. The family's full sweeps and their figures are
``benchmarks/avoid_roads.py``'s."""

from __future__ import annotations

import numpy as np
import pytest

from scenarios import CATALOG_DIR, ScenarioSpec, load_spec
from scenarios.world_backends import make_road
from sdc.run.episode import run_episode


def family_base(name: str, **changes: dict) -> dict:
    plain = load_spec(CATALOG_DIR / f"avoid-roads-{name}.toml").to_plain()
    for table, values in changes.items():
        plain[table] = {**plain[table], **values}
    return plain


def assert_passed_and_back(row: dict) -> None:
    assert row["outcome"] == "completed" and row["collision_with"] == "none"
    assert row["maneuver_started"] and row["returned_to_lane"]


@pytest.mark.slow
@pytest.mark.parametrize("radius_m", [-100.0, 100.0])
def test_avoid_passes_and_returns_on_tight_curves_both_ways(radius_m):
    spec = ScenarioSpec.from_plain(family_base("curve", road={"curve_radius_m": radius_m},
                                               ego={"speed_mps": 18.0}))
    row = run_episode(spec).row
    assert_passed_and_back(row)
    assert row["max_abs_lane_offset_m"] < 4.5  # one lane over, not off the road


@pytest.mark.slow
@pytest.mark.parametrize("seed", [2, 5])
def test_avoid_passes_and_returns_on_town_routes_that_turn(seed):
    spec = ScenarioSpec.from_plain(family_base("grid", scenario={"seed": seed},
                                               ego={"speed_mps": 11.0}))
    road = make_road(spec)
    turns = [p for p in road.pieces if p.lane.internal]
    headings = [np.ptp(np.unwrap(np.arctan2(*np.diff(p.lane.shape_xy, axis=0).T[::-1])))
                for p in turns]
    assert max(headings) > 1.2  # the route turns at a junction at least once
    assert_passed_and_back(run_episode(spec).row)


@pytest.mark.slow
def test_with_a_rear_view_avoid_passes_in_traffic_from_behind():
    plain = family_base("traffic", traffic={"flow_vph_per_lane": 500.0})
    rows = [run_episode(ScenarioSpec.from_plain({**plain, "scenario": {**plain["scenario"],
                                                                       "seed": seed}})).row
            for seed in (1, 2, 3)]
    assert all(row["collision_with"] != "vehicle" for row in rows)
    assert sum(row["outcome"] == "completed" for row in rows) >= 2
    front = {**plain, "lidar": {**plain["lidar"], "fov_deg": 180.0, "beams": 180}}
    row = run_episode(ScenarioSpec.from_plain(front)).row
    assert row["outcome"] == "stuck" and not row["collision"]  # it waits: traffic was seen
