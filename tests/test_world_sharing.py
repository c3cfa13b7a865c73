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
from analysis.report.sweep_words import (
    DEFF_HEAD,
    sharing_cost_line,
    verdict_rows,
    warm_state_lines,
)
from analysis.report.sweep_world import world_lines, world_summary


def rows(worlds: list[tuple[str | None, int, int | None, int | None, float]],
         status: list[str] | None = None) -> pd.DataFrame:
    """Result rows, one per (world_id, world_egos, world_entry_step, steps, wall_time_s)."""
    frame = pd.DataFrame(worlds, columns=["world_id", "world_egos", "world_entry_step",
                                          "steps", "wall_time_s"])
    frame["status"] = status or ["ok"] * len(frame)
    frame["run_id"] = [f"r{i}" for i in range(len(frame))]
    return frame


def test_the_worlds_steps_and_wall_time_against_the_runs_alone():
    results = rows([
        # w0: three runs, the third entering at step 100 as a seat freed
        ("w0", 3, 0, 100, 3.0), ("w0", 3, 0, 80, 2.5), ("w0", 3, 100, 60, 4.1),
        ("w1", 2, 0, 50, 2.0), ("w1", 2, 50, 70, 2.1),  # w1: the second entered at 50
        (None, 1, None, 90, 1.8),  # a run alone
        ("w0", 3, None, None, 0.5),  # an error row: no steps
    ], status=["ok"] * 6 + ["error"])
    sharing = world_sharing(results, egos_per_world=2)
    assert sharing["worlds"] == 2 and sharing["runs"] == 6
    # a world steps until its last run ends: its entry step plus its steps
    assert sharing["sumo_steps"] == (100 + 60) + (50 + 70) + 90
    assert sharing["sumo_steps_exact"] is True
    assert sharing["steps_alone"] == 100 + 80 + 60 + 50 + 70 + 90
    assert sharing["egos_per_step"] == pytest.approx(450 / 370, abs=1e-3)
    # a run's wall_time_s is its world's: each world once (its runs' largest)
    assert sharing["wall_time_s"] == pytest.approx(4.1 + 2.1 + 1.8)
    # alone: the wall time a step of the run that ran alone (1.8 s / 90) times every step
    assert sharing["wall_time_alone_s"] == pytest.approx(1.8 / 90 * 450)
    assert sharing["alone_runs"] == 1


def test_rows_that_do_not_say_when_a_run_entered_give_a_lower_bound():
    results = rows([("w0", 4, None, 100, 3.0), ("w0", 4, None, 40, 2.0),
                    ("w0", 4, None, 60, 2.5), ("w0", 4, None, 60, 2.5)]).drop(
        columns="world_entry_step")
    sharing = world_sharing(results, egos_per_world=4)
    assert sharing["sumo_steps"] == 100 and sharing["sumo_steps_exact"] is False
    assert sharing["wall_time_s"] == pytest.approx(3.0)
    assert sharing["wall_time_alone_s"] is None and sharing["alone_runs"] == 0
    assert "at least: rows without world_entry_step" in sharing_cost_line(
        {**sharing, "ok_runs": 4})


def shared_sweep(samples: int = 40, egos: int = 8, completed: int = 40) -> pd.DataFrame:
    """One controller's ``samples`` runs in worlds of ``egos`` runs, ``egos / 2`` at a
    time (the second half entering at step 400 as the first half ends), ``completed``
    of them completed (the rest stuck), no warm-up."""
    out = []
    for i in range(samples):
        late = i % egos >= egos // 2
        out.append({
            "run_id": f"{i:05d}-avoid", "sample": i, "controller": "avoid", "backend": "sumo",
            "status": "ok", "error": None, "collision": False, "collision_with": "none",
            "outcome": "completed" if i < completed else "stuck", "time_lost_s": 1.0,
            "progress_m": 100.0, "world_id": f"w{i - i % egos}-avoid", "world_egos": egos,
            "world_entry_step": 400 if late else 0, "steps": 400,
            "wall_time_s": 12.0 if late else 11.9})
    return pd.DataFrame(out)


def summary_of(results: pd.DataFrame, egos_per_world: int = 4):
    manifest = SweepManifest(sweep={"sweep": {"name": "towns",
                                              "egos_per_world": egos_per_world}},
                             runs=len(results))
    return build_summary(results, manifest, [], "wilson", pd.Index(results["sample"].unique()))


def test_the_report_says_what_sharing_cost_and_how_much_wider_the_intervals_are():
    summary = summary_of(shared_sweep())
    plain = summary.to_plain()["shared_worlds"]
    # 5 worlds of 8 runs, 4 at a time: each stepped 800 steps for its runs' 3,200
    assert plain["worlds"] == 5 and plain["sumo_steps_exact"] is True
    assert plain["sumo_steps"] == 800 * 5 and plain["steps_alone"] == 400 * 40
    assert plain["egos_per_step"] == 4.0
    lines = warm_state_lines(summary)
    shared = next(line for line in lines if line.startswith("Shared worlds"))
    assert ("the 40 runs ran as egos of 5 worlds, each one SUMO simulation holding up to 4 "
            "egos at a time") in shared
    assert "their SUMO steps carried 4.00 egos on average (measured)" in shared
    cost = next(line for line in lines if line.startswith("Cost of sharing"))
    assert ("SUMO stepped 4,000 steps for the 40 runs (measured: each world until its last "
            "run ended) against 16,000 had each run a world of its own (estimated: the sum "
            "of the runs' steps): 4.0x fewer") in cost
    # each world took 12 s; no run alone to time a step by
    assert ("the worlds took 60.0 s of wall time (measured: a run's wall_time_s is its "
            "world's) against an unknown wall time alone") in cost
    clusters = next(line for line in lines if line.startswith("Clustering"))
    # 40 of 40 in 5 worlds of 8: Wilson [91.2%, 100%] for 40 independent runs, as wide
    # as 5 runs' when a world is one cluster
    assert ("avoid's completed rate: design effect 8.00, its 95% interval "
            "[56.6%, 100.0%] as wide as 5.0 independent runs' (were its 40 runs "
            "independent: [91.2%, 100.0%])") in clusters
    assert DEFF_HEAD in verdict_rows(summary)[0]  # the table shows it too


def test_the_report_says_how_many_paired_runs_met_the_traffic_at_different_moments():
    """A sample's runs under two controllers sit in two worlds; a run that entered
    later may enter at another step under the other controller (its world's runs ended
    otherwise), on other traffic: the report counts those samples."""
    avoid = shared_sweep(samples=16)
    seed = avoid.assign(controller="seed", run_id=avoid.run_id.str.replace("avoid", "seed"),
                        world_id=avoid.world_id.str.replace("avoid", "seed"))
    seed.loc[[5, 6, 13], "world_entry_step"] = 350  # they entered earlier there
    both = pd.concat([avoid, seed], ignore_index=True)
    plain = summary_of(both).to_plain()["shared_worlds"]
    assert (plain["samples_paired"], plain["samples_apart"]) == (16, 3)
    shared = next(line for line in warm_state_lines(summary_of(both))
                  if line.startswith("Shared worlds"))
    assert ("Of the 16 samples run under several controllers, 3 entered their controllers' "
            "worlds at different steps: the comparisons below pair those runs on traffic "
            "of different moments.") in shared
    alone = next(line for line in warm_state_lines(summary_of(avoid))
                 if line.startswith("Shared worlds"))
    assert "Of the" not in alone  # one controller: nothing paired


def with_runs_alone(results: pd.DataFrame, wall_time_s: float) -> pd.DataFrame:
    """``results`` and two runs of 400 steps alone, each taking ``wall_time_s``."""
    alone = results.iloc[:2].assign(world_id=None, world_egos=1, world_entry_step=None,
                                    wall_time_s=wall_time_s, sample=[100, 101],
                                    run_id=["00100-avoid", "00101-avoid"])
    return pd.concat([results, alone], ignore_index=True)


@pytest.mark.parametrize(("world_s", "said"), [
    (12.0, "about 168.0 s alone (estimated: 10.00 ms a step, the wall time per step of the "
           "2 runs that ran alone, times every run's steps): 2.5x faster shared"),
    (40.0, "1.2x slower shared: sharing did not pay here")])
def test_the_wall_time_alone_is_estimated_from_the_runs_alone(world_s, said):
    results = with_runs_alone(shared_sweep().assign(wall_time_s=world_s), 4.0)
    cost = next(line for line in warm_state_lines(summary_of(results))
                if line.startswith("Cost of sharing"))
    # the worlds 5 x world_s, the runs alone 2 x 4 s; alone 16,800 steps at 10 ms
    assert f"took {5 * world_s + 8.0:.1f} s of wall time" in cost
    assert said in cost


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
