"""A run's bodies read out of its trace as paths, for a run written out (``sdc
export``, :mod:`scenarios.asam.xosc_export`).

A trace records the traffic in the ego's sensing radius as boxes per step, without
names, so each body's path is tracked (:func:`body_paths`): the boxes of one body
joined (a vehicle laid along a bend is several boxes), then each step's bodies matched
to the last step's by where each was heading (one to one, least total distance, the
same class, within :data:`MATCH_GATE_M`). A body that leaves the radius and comes back
is a new body; a body of one step is a path of one pose. The obstacles stand where
the trace's metadata puts them (:func:`standing_bodies`).
"""

from __future__ import annotations

import math

import numpy as np

from analysis.measures.trace_columns import TraceCol, TraceMeta
from scenarios.asam.xosc_export import (
    PEDESTRIAN_KINDS,
    VEHICLE_CATEGORIES,
    MovingBody,
    StandingBody,
)
from scenarios.spec.bodies import OBSTACLE_SIZES_M

#: the farthest [m] a body's box centre may lie from where its last two steps put it
#: for the same body (more than SUMO's one-step lane change, 3.5 m, less than the gap
#: between two cars one behind the other)
MATCH_GATE_M = 5.0


def standing_bodies(metadata: dict, spec) -> list[StandingBody]:
    """The run's obstacles, as they stood: the spec's, in its order, then any other
    standing box the run saw (a shared world's), its kind the obstacle kind of its size."""
    boxes = np.array(metadata.get(TraceMeta.obstacle_boxes, []), float).reshape(-1, 5)
    kinds = [o.kind for o in spec.obstacles]
    found = []
    for i, box in enumerate(boxes):
        kind = kinds[i] if i < len(kinds) else min(
            OBSTACLE_SIZES_M, key=lambda k: math.dist(OBSTACLE_SIZES_M[k], box[3:5]))
        found.append(StandingBody(f"obstacle_{i}_{kind}", kind, tuple(float(v) for v in box)))
    return found


def _bodies_of_step(boxes: np.ndarray, classes: list[str], labels: np.ndarray | None):
    """One step's bodies: (centre xy (B, 2), heading (B,), length (B,), width (B,),
    class (B,)); a body of several boxes is its boxes' length-weighted centre, heading
    and summed length."""
    if labels is None or len(labels) != len(boxes):
        return (boxes[:, :2], boxes[:, 2], boxes[:, 3], boxes[:, 4], list(classes))
    xy, heading, length, width, kinds = [], [], [], [], []
    for label in dict.fromkeys(labels.tolist()):
        part = boxes[labels == label]
        w = part[:, 3] / part[:, 3].sum()
        xy.append(w @ part[:, :2])
        heading.append(math.atan2(w @ np.sin(part[:, 2]), w @ np.cos(part[:, 2])))
        length.append(part[:, 3].sum())
        width.append(part[:, 4].max())
        kinds.append(classes[int(np.flatnonzero(labels == label)[0])])
    return (np.array(xy).reshape(-1, 2), np.array(heading), np.array(length),
            np.array(width), kinds)


def body_paths(trace) -> list:
    """Every traffic body's and person's path through the trace, named
    ``<category>_<n>`` (``car_1``, ``truck_1``, ``person_1``) in the order they first
    appear (the module's docstring says how a body is followed from step to step)."""
    from scipy.optimize import linear_sum_assignment

    t_s = trace.floats[TraceCol.t_s]
    tracks: list[dict] = []  # each: kind, t, xy, heading, length, width
    live: list[int] = []  # the tracks seen at the last step
    for k in range(len(trace)):
        boxes = np.asarray(trace.traffic[k], float).reshape(-1, 5)
        xy, heading, length, width, kinds = _bodies_of_step(boxes, trace.traffic_class[k],
                                                            trace.bodies(k))
        matched: dict[int, int] = {}
        if live and len(xy):
            predicted = np.array([_predicted(tracks[i], t_s[k]) for i in live])
            cost = np.linalg.norm(predicted[:, None, :] - xy[None, :, :], axis=2)
            differ = np.array([[tracks[i]["kind"] != kind for kind in kinds] for i in live])
            cost[differ | (cost > MATCH_GATE_M)] = 1e9
            for r, c in zip(*linear_sum_assignment(cost), strict=True):
                if cost[r, c] < 1e9:
                    matched[c] = live[r]
        live = []
        for j in range(len(xy)):
            if j in matched:
                track = tracks[matched[j]]
            else:
                track = {"kind": kinds[j], "t": [], "xy": [], "heading": [], "length": [],
                         "width": []}
                tracks.append(track)
            track["t"].append(t_s[k])
            track["xy"].append(xy[j])
            track["heading"].append(heading[j])
            track["length"].append(length[j])
            track["width"].append(width[j])
            live.append(matched.get(j, len(tracks) - 1))
    counts: dict[str, int] = {}
    paths = []
    for track in tracks:
        kind = ("person" if track["kind"] in PEDESTRIAN_KINDS
                else VEHICLE_CATEGORIES.get(track["kind"], "car"))
        counts[kind] = counts.get(kind, 0) + 1
        paths.append(MovingBody(f"{kind}_{counts[kind]}", track["kind"],
                                float(np.median(track["length"])),
                                float(np.median(track["width"])), np.array(track["t"]),
                                np.array(track["xy"]), np.array(track["heading"])))
    return paths


def _predicted(track: dict, t_s: float) -> np.ndarray:
    """Where a track's body is at ``t_s`` going on as over its last two steps."""
    if len(track["t"]) < 2:
        return track["xy"][-1]
    dt = track["t"][-1] - track["t"][-2]
    velocity = (track["xy"][-1] - track["xy"][-2]) / dt if dt > 0 else 0.0
    return track["xy"][-1] + velocity * (t_s - track["t"][-1])
