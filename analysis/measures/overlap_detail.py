"""One overlap of two bodies other than the ego, told so that one can act on it: when
(the run's time and step), which two (a name and a vehicle class each), how deep, and
whose (ours, or SUMO's own: :mod:`sdc.run.world_witness`); and what a drawing of a
step marks.

The trace keeps no SUMO ids (its rows stay as they are). A body is named by SUMO's id
where the audit's replay of the run read it (the world's twin keeps ids,
:mod:`sdc.run.world_witness`), else by its place in the trace: ``traffic[i]``, row
``i`` of that step's traffic boxes, or ``obstacles[j]``, the spec's obstacle.

How deep: :func:`analysis.measures.world_audit.overlap_depth_m` of the two boxes, the
shortest distance one must move to part them; for a body of several boxes (laid
along a bend) the deepest of its boxes against the other body's.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from analysis.measures.numbers import time_text
from analysis.measures.trace_columns import TraceCol, TraceMeta
from analysis.measures.trace_file import Trace
from analysis.measures.world_audit import box_owners, overlap_depth_m, overlapping_pairs
from scenarios.scene.boxes import as_boxes
from scenarios.spec.scenario_spec import ScenarioSpec

#: where an episode's metadata (the trace file's) keeps the overlaps it named
METADATA_KEY = TraceMeta.overlaps
#: whose an overlap is, by :attr:`Overlap.sumo_own`
WHOSE = {False: "ours: SUMO's own lanes hold the two apart",
         True: "SUMO's own: its lanes hold the two inside each other too",
         None: "counted ours: not judged against SUMO's own lanes"}


class Body(NamedTuple):
    name: str  # SUMO's id, or traffic[i] / obstacles[j] (the module's docstring)
    vclass: str | None  # SUMO's vehicle class; None: a thing (a barrel)

    def text(self) -> str:
        return f"{self.name} ({self.vclass or 'thing'})"


class Overlap(NamedTuple):
    """Two bodies inside each other at one step of a run."""

    step: int
    t_s: float  # the run's time at that step [s]
    boxes: tuple[int, int]  # the two boxes: traffic rows of the step, then obstacles
    first: Body
    second: Body
    depth_m: float  # how deep (the module's docstring) [m]
    sumo_own: bool | None = None  # SUMO's own; False: ours; None: not judged (ours)

    def text(self) -> str:
        return (f"at {time_text(self.t_s)} s (step {self.step}): {self.first.text()} and "
                f"{self.second.text()}, {self.depth_m:.3f} m deep; {WHOSE[self.sumo_own]}")

    def to_plain(self) -> dict:
        return {"step": self.step, "t_s": self.t_s, "boxes": list(self.boxes),
                "first": list(self.first), "second": list(self.second),
                "depth_m": self.depth_m, "sumo_own": self.sumo_own}

    @classmethod
    def from_plain(cls, plain: dict) -> Overlap:
        return cls(plain["step"], plain["t_s"], tuple(plain["boxes"]), Body(*plain["first"]),
                   Body(*plain["second"]), plain["depth_m"], plain["sumo_own"])


def _step_bodies(trace: Trace, step: int, obstacle_boxes: np.ndarray,
                 obstacle_classes: tuple[str | None, ...]):
    """The step's boxes (traffic, then obstacles), their classes and their bodies."""
    traffic, obstacles = as_boxes(trace.traffic[step]), as_boxes(obstacle_boxes)
    classes = [*trace.traffic_class[step], *(obstacle_classes or [None] * len(obstacles))]
    owners = box_owners(len(traffic), trace.bodies(step), len(obstacles))
    return traffic, obstacles, classes, owners


def describe(trace: Trace, step: int, boxes: tuple[int, int], obstacle_boxes: np.ndarray,
             obstacle_classes: tuple[str | None, ...] = (),
             names: tuple[str, str] | None = None, sumo_own: bool | None = None) -> Overlap:
    """The overlap of ``boxes`` (indices into ``step``'s traffic boxes, then the
    obstacles') at ``step``; ``names``: SUMO's ids of the two (default: their places in
    the trace)."""
    traffic, obstacles, classes, _ = _step_bodies(trace, step, obstacle_boxes,
                                                  obstacle_classes)
    n = len(traffic)
    both = np.vstack([traffic, obstacles])[list(boxes)]
    if names is None:
        names = tuple(f"traffic[{i}]" if i < n else f"obstacles[{i - n}]" for i in boxes)
    return Overlap(int(step), float(trace.floats[TraceCol.t_s][step]),
                   (int(boxes[0]), int(boxes[1])),
                   Body(names[0], classes[boxes[0]]), Body(names[1], classes[boxes[1]]),
                   float(overlap_depth_m(both[:1], both[1:])[0]), sumo_own)


def overlaps_at(trace: Trace, step: int, obstacle_boxes: np.ndarray,
                obstacle_classes: tuple[str | None, ...] = ()) -> list[Overlap]:
    """The bodies the world audit finds inside each other at ``step``
    (:func:`analysis.measures.world_audit.overlapping_pairs`), one :class:`Overlap` for
    two bodies (their deepest boxes), deepest first, named by their places in the
    trace, not judged."""
    traffic, obstacles, classes, owners = _step_bodies(trace, step, obstacle_boxes,
                                                       obstacle_classes)
    deepest: dict[tuple[int, int], Overlap] = {}
    for pair in overlapping_pairs(traffic, obstacles, classes[:len(traffic)],
                                  tuple(classes[len(traffic):]), trace.bodies(step)):
        overlap = describe(trace, step, pair, obstacle_boxes, obstacle_classes)
        key = (owners[pair[0]], owners[pair[1]])
        if key not in deepest or overlap.depth_m > deepest[key].depth_m:
            deepest[key] = overlap
    return sorted(deepest.values(), key=lambda o: -o.depth_m)


def deepest(overlaps: list[Overlap]) -> Overlap | None:
    return max(overlaps, key=lambda o: o.depth_m, default=None)


def drawn_overlaps(trace: Trace, metadata: dict, step: int) -> list[tuple[Overlap, np.ndarray]]:
    """What a drawing of ``step`` marks: each two bodies inside each other there
    (:func:`overlaps_at`), named as the run named them where it did (its metadata's
    :data:`METADATA_KEY`: SUMO's ids, whose), with their two boxes, (2, 5). A trace
    without its obstacles' boxes in its metadata (older) marks traffic only."""
    spec = ScenarioSpec.from_plain(metadata[TraceMeta.spec])
    obstacles = as_boxes(metadata.get(TraceMeta.obstacle_boxes, np.zeros((0, 5))))
    classes = (tuple(o.vehicle_class for o in spec.obstacles)
               if len(spec.obstacles) == len(obstacles) else ())
    _, _, _, owners = _step_bodies(trace, step, obstacles, classes)
    named = {(owners[o.boxes[0]], owners[o.boxes[1]]): o
             for o in map(Overlap.from_plain, metadata.get(METADATA_KEY, []))
             if o.step == step}
    boxes = np.vstack([as_boxes(trace.traffic[step]), obstacles])
    found = [named.get((owners[o.boxes[0]], owners[o.boxes[1]]), o)
             for o in overlaps_at(trace, step, obstacles, classes)]
    return [(o, boxes[list(o.boxes)]) for o in found]
