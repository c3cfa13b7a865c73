"""Whose overlap is it? The world's audit (:mod:`analysis.measures.world_audit`) finds the
steps in which two bodies other than the ego overlap; here each such step is judged
against SUMO's own placement of the bodies.

At each such step the overlapping bodies are laid along their lanes as SUMO's own
model holds them (:meth:`scenarios.sumo.sumo_world.SumoWorld.placed_by_sumo`). Where
those overlap too, SUMO's own model put them through each other (its junctions let
vehicles on crossing lanes wait inside one another, its bicycles ride through its
pedestrians): ``sumo_overlaps``. Where they do not, what we made of SUMO's world did
(a rigid box where SUMO holds a body along its lane, a body reaching where SUMO was
not shown it): ``world_overlaps``. The first step of each kind is named with SUMO's
ids (the trace keeps none): :class:`Verdict`, told by
:mod:`analysis.measures.overlap_detail`.

:class:`InRunAudit` judges during the run, at the step the overlap happens, from
SUMO's state at that step before it steps on: no run is simulated twice. The replay
(:func:`witness_world`) judges the same steps afterwards: the run's SUMO run once
more, each ego pushed where its trace has it (same spec, same seed, the same pushes:
the same world, step for step, checked against the trace). It is what judged before,
and stays the oracle the in-run audit is held to (``benchmarks/audit_in_run.py``,
``tests/test_world_witness.py``). A step whose replay differs from the trace counts
as ours: missing evidence is never SUMO's alibi.

In a shared world (:mod:`sdc.run.shared_world`) each ego's run is judged in its own
slot. An overlap with another ego is that ego's collision (its own check ends its run
on it): its row counts it, the audit of the others does not. One with another run's
obstacle is ours: where an ego's run is, we put it.
"""

from __future__ import annotations

import contextlib
from typing import NamedTuple

import numpy as np

from analysis.measures.overlap_detail import Overlap, deepest, describe, overlaps_at
from analysis.measures.trace_columns import TraceCol
from analysis.measures.trace_file import Trace
from analysis.measures.world_audit import (
    OVERLAP_TOLERANCE_M,
    overlapping_pairs,
    pairs_overlap,
)
from scenarios.scene.snapshot import Snapshot
from scenarios.spec.bodies import are_people
from scenarios.sumo.routes_xml import ego_names
from scenarios.world_backends import WitnessWorld
from sdc.car.geometry_kernels import bodies_may_overlap
from sdc.car.vehicle import Vehicle, VehicleState
from sdc.run.world_loop import Failed, WorldLoop


class Witnessed(NamedTuple):
    """One overlapping pair at one step, judged."""

    step: int
    sumo_time_s: float  # SUMO's clock at that step
    first: str  # SUMO's ids of the two bodies (an obstacle: obstacle.<i>)
    second: str
    sumo_holds_both: bool  # laid along their lanes as SUMO holds them, they overlap too
    another_ego: bool = False  # one of the two is another ego of a shared world
    boxes: tuple[int, int] = (-1, -1)  # the two in the step's traffic boxes, then obstacles


def _overlap_anywhere(a: np.ndarray, b: np.ndarray) -> bool:
    """Do two bodies, each (P, 5) boxes, overlap anywhere?"""
    first, second = np.repeat(a, len(b), axis=0), np.tile(b, (len(a), 1))
    return bool(pairs_overlap(first, second).any())


class Judged(NamedTuple):
    """What the witness needs of one run of a world (plain data)."""

    trace: Trace
    vehicle: Vehicle
    steps: np.ndarray  # its overlapping steps, ascending
    obstacle_classes: tuple[str | None, ...]
    obstacle_boxes: np.ndarray | None = None  # (K, 5); None: none


class Verdict(NamedTuple):
    """A run's overlapping steps judged: how many hold an overlap of ours (also every
    step nobody judged) and how many one of SUMO's own (a step may hold both), and the
    first of each, named (:mod:`analysis.measures.overlap_detail`; None: none)."""

    ours: int
    sumo: int
    first_ours: Overlap | None = None
    first_sumo: Overlap | None = None


def _pose(run: Judged, k: int) -> tuple[np.ndarray, float]:
    """The ego's box and speed at step ``k`` of its trace."""
    floats = run.trace.floats
    state = VehicleState(float(floats[TraceCol.x_m][k]), float(floats[TraceCol.y_m][k]),
                         float(floats[TraceCol.yaw_rad][k]), float(floats[TraceCol.speed_mps][k]),
                         float(floats[TraceCol.steer_rad][k]))
    return run.vehicle.body_box(state), state.speed_mps


class _Replayed:
    """The driver of one slot of the replay (:class:`sdc.run.world_loop.Driver`): its
    ego pushed along its trace, leaving after its last step; at each of its
    overlapping steps reached as its trace has it, the overlapping pairs judged."""

    end: str | None = None

    def __init__(self, world, run: Judged, slot: int):
        self.world, self.run, self.slot = world, run, slot
        self.wanted = set(run.steps.tolist())
        self.last_wanted = max(self.wanted, default=-1)
        self.reached = bool(self.wanted)  # every step so far as its trace has it
        self.witnessed: list[Witnessed] = []
        self.k = 0
        self.snapshot = None

    def place(self) -> tuple[np.ndarray, float]:
        return _pose(self.run, 0)

    def begin(self, snapshot) -> None:
        self.snapshot = snapshot

    def wants_more(self) -> bool:
        return self.reached and self.last_wanted >= self.k

    def turn(self) -> tuple[np.ndarray, float] | None:
        k, run = self.k, self.run
        if self.reached:
            replayed = np.asarray(self.snapshot.traffic_boxes, np.float32).ravel()
            self.reached = bool(np.array_equal(replayed, run.trace.traffic[k]))
            if self.reached and k in self.wanted:
                self.witnessed += _judged(self.world, self.snapshot, k, run.obstacle_classes,
                                          self.slot)
        if k == len(run.trace) - 1:
            self.end = "trace_end"
            return None
        return _pose(run, k + 1)

    def arrive(self, snapshot) -> None:
        self.snapshot = snapshot
        self.k += 1


class _Entries:
    """The replay's seating (:class:`sdc.run.world_loop.Seating`): each ego enters at the
    world's step its run entered at (``steps``, by slot)."""

    def __init__(self, steps: list[int]):
        self.steps = steps

    def entering(self, waiting: list[int], present: dict, step: int) -> list[int]:
        return [i for i in waiting if self.steps[i] == step]


def witness_world(twin, runs: list[Judged], entries: list[int] | None = None
                  ) -> list[list[Witnessed]]:
    """Each run's overlapping pairs at its overlapping steps, judged by SUMO's own
    placement; ``runs``: every run of the world, in slot order (one, or a shared
    world's: each ego pushed along its trace from the world's step it entered at,
    ``entries`` (default: all at the start), leaving SUMO after its last step, as
    :mod:`sdc.run.shared_world` stepped them). A run's judging stops at the first step
    the replay did not reach as its trace has it. ``twin``: an unstarted world of the
    same egos."""
    with twin as world:
        drivers = [_Replayed(world, run, slot) for slot, run in enumerate(runs)]
        ends = WorldLoop(world, drivers,
                         seating=None if entries is None else _Entries(entries)).run()
    for end in ends.values():
        if isinstance(end, Failed):  # a judging that raised: raised again, as raised
            raise end.exception
    return [driver.witnessed for driver in drivers]


def witness_overlaps(twin, trace: Trace, vehicle: Vehicle, steps: np.ndarray,
                     obstacle_classes: tuple[str | None, ...]) -> list[Witnessed]:
    """Each overlapping pair at the trace's overlapping ``steps`` (ascending) of a run
    alone in its world, judged by SUMO's own placement (:func:`witness_world`)."""
    return witness_world(twin, [Judged(trace, vehicle, steps, obstacle_classes)])[0]


def _judged(world, snapshot, step: int, obstacle_classes, slot: int) -> list[Witnessed]:
    """The overlapping pairs of ``slot``'s snapshot, judged. A pair with another ego is
    that ego's collision (its own check ends its run on it), judged in its row; one
    with another run's obstacle is ours: where an ego's run is, we put it."""
    traffic = snapshot.traffic_boxes
    n, ids = len(traffic), world.ids(slot)
    pairs = overlapping_pairs(traffic, snapshot.obstacle_boxes, snapshot.traffic_classes,
                              obstacle_classes, snapshot.traffic_bodies)
    rows = sorted({i for pair in pairs for i in pair if i < n and world.is_traffic(ids[i])})
    standing = sorted({j - n for _, j in pairs if j >= n})
    placed = world.placed_by_sumo(traffic, rows, standing, slot)
    body = dict(zip(rows + [n + j for j in standing], placed, strict=True))
    prefix = ego_names(slot).obstacle_prefix
    names = {**{i: ids[i] for i in range(n)}, **{n + j: f"{prefix}{j}" for j in standing}}
    return [Witnessed(step, snapshot.t_s, names[i], names[j],
                      i in body and j in body and _overlap_anywhere(body[i], body[j]),
                      bool({names[i], names[j]} & world.ego_ids), (i, j))
            for i, j in pairs]


class InRunAudit:
    """The world's audit inside a run: at each step, the overlapping pairs of bodies other
    than the ego of ``slot`` judged from that step's own state, as SUMO holds it before
    it steps on (:func:`_judged`, the replay's judging at the same state), so no second
    simulation is needed. The steps looked at are the trace's own: its traffic boxes as
    the trace holds them (float32), as :func:`analysis.measures.world_audit.overlap_steps`
    finds them afterwards. ``world``: a world with a model to judge by (SUMO's)."""

    def __init__(self, world: WitnessWorld, slot: int,
                 obstacle_classes: tuple[str | None, ...]):
        self.world, self.slot, self.obstacle_classes = world, slot, obstacle_classes
        self.obstacle_people = np.asarray(are_people(obstacle_classes), float)
        self.witnessed: list[Witnessed] = []

    def look(self, snapshot: Snapshot, step: int) -> None:
        """Judge ``snapshot``'s overlapping pairs, if any (``step``: its trace row)."""
        held = np.asarray(snapshot.traffic_boxes, np.float32).astype(np.float64)
        obstacles = np.ascontiguousarray(snapshot.obstacle_boxes, np.float64)
        bodies = snapshot.traffic_bodies
        owners = None if bodies is None else np.asarray(bodies, np.float64)
        if not bodies_may_overlap(held, obstacles, None, owners, OVERLAP_TOLERANCE_M):
            return
        people = np.concatenate([np.asarray(are_people(snapshot.traffic_classes), float),
                                 self.obstacle_people])
        if not bodies_may_overlap(held, obstacles, people, owners, OVERLAP_TOLERANCE_M):
            return
        if not overlapping_pairs(held, obstacles, snapshot.traffic_classes,
                                 self.obstacle_classes, snapshot.traffic_bodies):
            return
        # a judging that fails leaves the step unjudged, counted ours (verdict): missing
        # evidence is never SUMO's alibi, nor the end of the run
        with contextlib.suppress(Exception):
            self.witnessed += _judged(self.world, snapshot, step, self.obstacle_classes,
                                      self.slot)


def unjudged(run: Judged) -> Verdict:
    """Every overlapping step of ``run`` counted ours, not judged (another backend, or a
    world that cannot be replayed), the first named by its place in the trace."""
    first = (deepest(overlaps_at(run.trace, int(run.steps[0]), _obstacles(run),
                                 run.obstacle_classes)) if len(run.steps) else None)
    return Verdict(len(run.steps), 0, first)


def _obstacles(run: Judged) -> np.ndarray:
    return np.zeros((0, 5)) if run.obstacle_boxes is None else run.obstacle_boxes


def verdict(run: Judged, witnessed: list[Witnessed]) -> Verdict:
    """(ours, SUMO's) of the run's steps, and the first of each: a step may hold both; a
    step nobody judged is ours; a step whose every pair is another ego's collision is
    neither. The first of a kind is its first step's deepest pair of that kind."""
    theirs = {w.step for w in witnessed if w.another_ego}
    judged = [w for w in witnessed if not w.another_ego]
    sumo = {w.step for w in judged if w.sumo_holds_both}
    ours = {w.step for w in judged if not w.sumo_holds_both}
    ours |= set(run.steps.tolist()) - ours - sumo - theirs  # judged by nobody

    def first(steps: set[int], sumo_own: bool) -> Overlap | None:
        if not steps:
            return None
        step = min(steps)
        pairs = [w for w in judged if w.step == step and w.sumo_holds_both == sumo_own]
        if not pairs:  # judged by nobody
            return deepest(overlaps_at(run.trace, step, _obstacles(run), run.obstacle_classes))
        return deepest([describe(run.trace, step, w.boxes, _obstacles(run),
                                 run.obstacle_classes, (w.first, w.second), sumo_own)
                        for w in pairs])

    return Verdict(len(ours), len(sumo), first(ours, False), first(sumo, True))
