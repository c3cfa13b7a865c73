"""Whose overlap is it? The world's audit (:mod:`analysis.measures.world_audit`) finds the
steps in which two bodies other than the ego overlap; here each such step is judged
against SUMO's own placement of the bodies.

The run's SUMO is run once more, the ego pushed where the trace has it (same spec, same
seed, the same pushes: the same world, step for step, checked against the trace), and
at each such step the overlapping bodies are laid along their lanes as SUMO's own model
holds them (:meth:`scenarios.sumo.sumo_world.SumoWorld.placed_by_sumo`). Where those overlap
too, SUMO's own model put them through each other (its junctions let vehicles on
crossing lanes wait inside one another, its bicycles ride through its pedestrians):
``sumo_overlaps``. Where they do not, what we made of SUMO's world did (a rigid box
where SUMO holds a body along its lane, a body reaching where SUMO was not shown it):
``world_overlaps``. A step whose replay differs from the trace counts as ours: missing
evidence is never SUMO's alibi. Only runs with an overlap pay for the second run.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from analysis.measures.trace_file import Trace
from analysis.measures.world_audit import overlapping_pairs, pairs_overlap
from scenarios.sumo.routes_xml import OBSTACLE_PREFIX
from sdc.car.vehicle import Vehicle, VehicleState


class Witnessed(NamedTuple):
    """One overlapping pair at one step, judged."""

    step: int
    sumo_time_s: float  # SUMO's clock at that step
    first: str  # SUMO's ids of the two bodies (an obstacle: obstacle.<i>)
    second: str
    sumo_holds_both: bool  # laid along their lanes as SUMO holds them, they overlap too


def _overlap_anywhere(a: np.ndarray, b: np.ndarray) -> bool:
    """Do two bodies, each (P, 5) boxes, overlap anywhere?"""
    first, second = np.repeat(a, len(b), axis=0), np.tile(b, (len(a), 1))
    return bool(pairs_overlap(first, second).any())


def witness_overlaps(twin, trace: Trace, vehicle: Vehicle, steps: np.ndarray,
                     obstacle_classes: tuple[str | None, ...]) -> list[Witnessed]:
    """Each overlapping pair at the trace's overlapping ``steps`` (ascending), judged by
    SUMO's own placement; none for a step the replay did not reach as the trace has
    it. ``twin``: an unstarted world of the run's spec and road."""
    floats, wanted, witnessed = trace.floats, set(steps.tolist()), []
    with twin as world:
        world.keep_ids = True
        for k in range(int(steps[-1]) + 1 if len(steps) else 0):
            state = VehicleState(float(floats["x_m"][k]), float(floats["y_m"][k]),
                                 float(floats["yaw_rad"][k]), float(floats["speed_mps"][k]),
                                 float(floats["steer_rad"][k]))
            box = vehicle.body_box(state)
            snapshot = (world.start(box, state.speed_mps) if k == 0
                        else world.step(box, state.speed_mps))
            replayed = np.asarray(snapshot.traffic_boxes, np.float32).ravel()
            if not np.array_equal(replayed, trace.traffic[k]):
                break  # not the run's world any more
            if k in wanted:
                witnessed += _judged(world, snapshot, k, obstacle_classes)
    return witnessed


def _judged(world, snapshot, step: int, obstacle_classes) -> list[Witnessed]:
    traffic = snapshot.traffic_boxes
    n = len(traffic)
    pairs = overlapping_pairs(traffic, snapshot.obstacle_boxes, snapshot.traffic_classes,
                              obstacle_classes, snapshot.traffic_bodies)
    rows = sorted({i for pair in pairs for i in pair if i < n})
    standing = sorted({j - n for _, j in pairs if j >= n})
    placed = world.placed_by_sumo(traffic, rows, standing)
    body = dict(zip(rows + [n + j for j in standing], placed, strict=True))
    ids = {**{row: world.last_ids[row] for row in rows},
           **{n + j: f"{OBSTACLE_PREFIX}{j}" for j in standing}}
    return [Witnessed(step, snapshot.t_s, ids[i], ids[j], _overlap_anywhere(body[i], body[j]))
            for i, j in pairs]


def judge_overlaps(twin, trace: Trace, vehicle: Vehicle, steps: np.ndarray,
                   obstacle_classes: tuple[str | None, ...]) -> tuple[int, int]:
    """Of the trace's overlapping ``steps``, how many hold an overlap SUMO's own bodies
    do not have (ours: also every step the replay did not reach) and how many one they
    have too (SUMO's); a step may hold both."""
    if not len(steps):
        return 0, 0
    witnessed = witness_overlaps(twin, trace, vehicle, steps, obstacle_classes)
    sumo = {w.step for w in witnessed if w.sumo_holds_both}
    ours = {w.step for w in witnessed if not w.sumo_holds_both}
    ours |= set(steps.tolist()) - ours - sumo  # judged by nobody
    return len(ours), len(sumo)
