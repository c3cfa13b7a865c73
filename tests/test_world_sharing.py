"""What shared worlds cost and what they did to the intervals, as the report says it
(analysis/measures/world_sharing.py, analysis/report/sweep_words.py): the SUMO steps
and wall time of the worlds against the runs alone, measured or estimated and said
which; the design effect of counting a world as one cluster; the collisions with
another run's bodies told apart from those with traffic."""

from __future__ import annotations

import pandas as pd
import pytest

from analysis.measures.sweep_manifest import SweepManifest
from analysis.measures.world_sharing import world_sharing
from analysis.report.look_at import what_happened
from analysis.report.sweep_summary import build_summary
from analysis.report.sweep_words import DEFF_HEAD, verdict_rows, warm_state_lines
from analysis.report.sweep_world import world_lines, world_summary


def rows(worlds: list[tuple[str | None, int, int, float]], status: list[str] | None = None
         ) -> pd.DataFrame:
    """Result rows, one per (world_id, world_egos, steps, wall_time_s)."""
    frame = pd.DataFrame(worlds, columns=["world_id", "world_egos", "steps", "wall_time_s"])
    frame["status"] = status or ["ok"] * len(frame)
    frame["run_id"] = [f"r{i}" for i in range(len(frame))]
    return frame


def test_the_worlds_steps_and_wall_time_against_the_runs_alone():
    results = rows([
        ("w0", 3, 100, 3.0), ("w0", 3, 80, 3.0), ("w0", 3, 60, 3.1),  # one world of 3
        # w1: the placement rule split it, a world of 2 and one alone
        ("w1", 2, 50, 2.0), ("w1", 2, 70, 2.1), ("w1", 1, 90, 1.8),
        ("w0", 3, None, 0.5),  # an error row: no steps
    ], status=["ok"] * 6 + ["error"])
    sharing = world_sharing(results, egos_per_world=4)
    assert sharing["simulations"] == 3
    # each simulation steps as long as its longest run; alone, each run its own steps
    assert sharing["sumo_steps"] == 100 + 70 + 90
    assert sharing["sumo_steps_exact"] is True
    assert sharing["steps_alone"] == 100 + 80 + 60 + 50 + 70 + 90
    # a run's wall_time_s is its simulation's: each simulation once
    assert sharing["wall_time_s"] == pytest.approx(3.1 + 2.1 + 1.8)
    # alone: the wall time a step of the run that ran alone (1.8 s / 90) times every step
    assert sharing["wall_time_alone_s"] == pytest.approx(1.8 / 90 * 450)
    assert sharing["alone_runs"] == 1


def test_two_simulations_of_as_many_egos_are_bounded_and_no_run_alone_estimates_nothing():
    results = rows([("w0", 2, 100, 3.0), ("w0", 2, 40, 2.0), ("w0", 2, 60, 2.5),
                    ("w0", 2, 60, 2.5)])
    sharing = world_sharing(results, egos_per_world=4)
    # which runs shared a simulation is not recorded: at most twice the longest
    assert sharing["sumo_steps"] == 200 and sharing["sumo_steps_exact"] is False
    assert sharing["wall_time_s"] == pytest.approx(6.0)
    assert sharing["wall_time_alone_s"] is None and sharing["alone_runs"] == 0


def shared_sweep(samples: int = 40, egos: int = 8, completed: int = 40) -> pd.DataFrame:
    """One controller's ``samples`` runs in worlds of ``egos``, ``completed`` of them
    completed (the rest stuck), no warm-up; two runs split off to run alone."""
    out = []
    for i in range(samples):
        alone = i in (0, 1)
        out.append({
            "run_id": f"{i:05d}-avoid", "sample": i, "controller": "avoid", "backend": "sumo",
            "status": "ok", "error": None, "collision": False, "collision_with": "none",
            "outcome": "completed" if i < completed else "stuck", "time_lost_s": 1.0,
            "progress_m": 100.0, "world_id": f"w{i - i % egos}-avoid",
            "world_egos": 1 if alone else egos - 2 if i < egos else egos,
            "steps": 400, "wall_time_s": 4.0 if alone else 12.0})
    return pd.DataFrame(out)


def summary_of(results: pd.DataFrame, egos_per_world: int = 8):
    manifest = SweepManifest(sweep={"sweep": {"name": "towns",
                                              "egos_per_world": egos_per_world}},
                             runs=len(results))
    return build_summary(results, manifest, [], "wilson", pd.Index(results["sample"].unique()))


def test_the_report_says_what_sharing_cost_and_how_much_wider_the_intervals_are():
    summary = summary_of(shared_sweep())
    plain = summary.to_plain()["shared_worlds"]
    # 7 simulations: the 2 runs alone, the other 6 of the first world, 4 worlds of 8
    assert plain["simulations"] == 7 and plain["sumo_steps_exact"] is True
    assert plain["sumo_steps"] == 400 * 7 and plain["steps_alone"] == 400 * 40
    lines = warm_state_lines(summary)
    cost = next(line for line in lines if line.startswith("Cost of sharing"))
    assert ("SUMO stepped 2,800 steps for the 40 runs (measured: each simulation as long "
            "as its longest run) against 16,000 had each run a world of its own (estimated: "
            "the sum of the runs' steps): 5.7x fewer") in cost
    # 12 s for each of the 5 simulations of several egos, 4 s for each run alone
    assert ("the simulations took 68.0 s of wall time (measured: a run's wall_time_s is "
            "its simulation's) against about 160.0 s alone (estimated: 10.00 ms a step, "
            "the wall time per step of the 2 runs that ran alone, times every run's "
            "steps): 2.4x faster shared") in cost
    clusters = next(line for line in lines if line.startswith("Clustering"))
    # 40 of 40 in 5 worlds of 8: Wilson [91.2%, 100%] for 40 independent runs, as wide
    # as 5 runs' when a world is one cluster
    assert ("avoid's completed rate: design effect 8.00, its 95% interval "
            "[56.6%, 100.0%] as wide as 5.0 independent runs' (were its 40 runs "
            "independent: [91.2%, 100.0%])") in clusters
    assert DEFF_HEAD in verdict_rows(summary)[0]  # the table shows it too


def test_sharing_that_did_not_pay_says_so():
    results = shared_sweep().assign(wall_time_s=lambda f: f.wall_time_s.where(
        f.world_egos == 1, 40.0))
    cost = next(line for line in warm_state_lines(summary_of(results))
                if line.startswith("Cost of sharing"))
    assert "1.3x slower shared: sharing did not pay here" in cost


def hit(body: str | None, vclass: str | None, role: str = "ran_into",
        controller: str = "avoid") -> dict:
    return {"status": "ok", "controller": controller, "world_overlaps": 0, "collision": True,
            "outcome": "collided", "collision_with": "vehicle", "collision_part": "front",
            "collision_role": role, "collision_vclass": vclass, "collision_body": body,
            "collision_speed_mps": 5.0, "collision_time_s": 3.0}


def test_collisions_with_another_runs_bodies_are_told_from_traffic():
    results = pd.DataFrame([hit("other_ego", "passenger"), hit("other_ego", "passenger"),
                            hit("other_obstacle", "barrel"), hit("traffic", "truck")])
    summary = world_summary(results)
    assert summary["vehicle_classes"] == {"avoid": {"truck": 1}}
    assert summary["other_runs"] == {"avoid": {"other_ego": 2, "other_obstacle": 1}}
    lines = world_lines(summary)
    assert ("avoid's collisions with another run's bodies in a shared world (column "
            "collision_body): another run's ego 2, another run's obstacle 1.") in lines
    assert what_happened(hit("other_ego", "passenger")).startswith(
        "hit another run's ego (passenger) with its front at 5.0 m/s")
    assert what_happened(hit("other_ego", "passenger", role="was_hit")).startswith(
        "was hit by another run's ego (passenger) with its front")
    assert what_happened(hit("other_obstacle", "barrel")).startswith(
        "hit another run's obstacle (barrel) with its front")
    assert what_happened(hit("traffic", "truck")).startswith("hit a vehicle (truck)")
    # results from before the column: vehicles by class, as before
    older = world_summary(results.drop(columns="collision_body"))
    assert older["vehicle_classes"] == {"avoid": {"passenger": 2, "barrel": 1, "truck": 1}}
