"""What a run that ended standing stood for, read at its last step: the nearest thing
ahead of the front bumper that holds a car, and the light's cycle when that is a red
light or a queue before one (a run that waited there for less than a cycle was too
short to tell: ``unfinished``, not ``stuck``; :mod:`analysis.measures.run_outcome`).

What is ahead, within :data:`REACH_M` of the front bumper along the road:

- a **body in the car's path**: a box reaching into the band the car's body covers
  across the road, widened by :data:`PATH_MARGIN_M` each side (a body the bumper
  overlaps: gap 0). One of the scenario's obstacles is ``obstacle`` (a person among
  them ``person``), a pedestrian of SUMO's ``person``, any other vehicle ``queue``;
- a **stop line** (up to :data:`LINE_OVERSHOOT_M` behind the bumper: a car that
  stopped with its nose over it): ``red_light`` while its light holds the car (red,
  red-yellow or yellow at the last step, or within :data:`START_UP_S` before it: a car
  does not start on the instant), ``give_way`` where the car gives way (a sign, right
  before left, a green without priority, a light off and blinking); a green with
  priority holds no one and is looked past;
- a **pedestrian crossing** not yet left behind: ``crossing``.

The nearest decides (a body before a line at the same gap); nothing within reach is
``nothing``. A ``queue`` stands before a red light when the first stop line past the
body in front, within :data:`QUEUE_REACH_M` of the bumper, holds the car.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import NamedTuple

import numpy as np

from analysis.measures.row_columns import RowCol
from scenarios.scene.boxes import as_boxes, box_corners
from scenarios.scene.signals import holds_the_car, link_signal
from scenarios.spec.bodies import PEDESTRIAN

RED_LIGHT, QUEUE, GIVE_WAY, OBSTACLE, PERSON, CROSSING, NOTHING = (
    "red_light", "queue", "give_way", "obstacle", "person", "crossing", "nothing")
#: what a run that ended standing stood for (``stood_for``; None: it ended moving)
STOOD_FOR = (RED_LIGHT, QUEUE, GIVE_WAY, OBSTACLE, PERSON, CROSSING, NOTHING)
#: what lies farther ahead of the front bumper than this held nothing [m]
REACH_M = 30.0
#: a body reaching this close to the band the car's body covers is in its path [m]
PATH_MARGIN_M = 0.5
#: a stop line this far behind the front bumper is still the one it stands at [m]
LINE_OVERSHOOT_M = 1.0
#: a light that turned green less than this before the end still held the car [s]
START_UP_S = 2.0
#: a queue stands before a red light at most this far from the front bumper [m]
QUEUE_REACH_M = 150.0
#: a box's corners may spread along the road up to twice its diagonal and this [m]
#: (round the outside of a bend a body's extent along the road grows)
SPREAD_TOLERANCE_M = 2.0


class Line(NamedTuple):
    """A stop line as the car stood before it."""

    s_m: float  # along the road
    holds: bool  # its light held the car (red, red-yellow, yellow) at the end
    give_way: bool  # the car gives way there
    cycle_s: float | None  # its light's cycle (None: no light)


class Standing(NamedTuple):
    """What a run that ended standing stood for."""

    what: str  # one of STOOD_FOR
    gap_m: float | None  # from the front bumper to it, along the road (None: nothing)
    cycle_s: float | None  # the light's cycle: red_light, or a queue before a red light


def stood_for(front_s_m: float, band_d_m: tuple[float, float], bodies_sd: np.ndarray,
              body_kinds: Sequence[str], lines: Sequence[Line],
              crosswalks_s_m: Sequence[tuple[float, float]]) -> Standing:
    """What a car standing with its front bumper at ``front_s_m`` along the road and
    its body over ``band_d_m`` (from, to) across it stood for (the module's rules).
    ``bodies_sd``: the other bodies' extents (K, 4) ``[s_from, s_to, d_from, d_to]``,
    each of kind ``body_kinds`` (obstacle, person or queue); ``lines``: the route's
    stop lines; ``crosswalks_s_m``: its crossings (near, far) along the road."""
    candidates: list[tuple[float, int, str, float | None]] = []  # gap, rank, what, cycle
    bodies_sd = np.asarray(bodies_sd, float).reshape(-1, 4)
    lo_m, hi_m = band_d_m[0] - PATH_MARGIN_M, band_d_m[1] + PATH_MARGIN_M
    in_path = ((bodies_sd[:, 1] > front_s_m) & (bodies_sd[:, 0] - front_s_m <= REACH_M)
               & (bodies_sd[:, 3] > lo_m) & (bodies_sd[:, 2] < hi_m))
    for k in np.flatnonzero(in_path):
        candidates.append((max(float(bodies_sd[k, 0]) - front_s_m, 0.0), 0, body_kinds[k], None))
    for line in lines:
        gap_m = line.s_m - front_s_m
        if -LINE_OVERSHOOT_M <= gap_m <= REACH_M and (line.holds or line.give_way):
            candidates.append((max(gap_m, 0.0), 1, RED_LIGHT if line.holds else GIVE_WAY,
                               line.cycle_s if line.holds else None))
    for near_s_m, far_s_m in crosswalks_s_m:
        if far_s_m > front_s_m and near_s_m - front_s_m <= REACH_M:
            candidates.append((max(near_s_m - front_s_m, 0.0), 2, CROSSING, None))
    if not candidates:
        return Standing(NOTHING, None, None)
    gap_m, _, what, cycle_s = min(candidates, key=lambda c: (c[0], c[1]))
    if what == QUEUE:
        cycle_s = _red_light_beyond(front_s_m + gap_m, front_s_m, lines)
    return Standing(what, round(gap_m, 6), cycle_s)


def _red_light_beyond(body_s_m: float, front_s_m: float, lines: Sequence[Line]) -> float | None:
    """The cycle of the first stop line past a body at ``body_s_m`` when it holds the
    car within :data:`QUEUE_REACH_M` of the bumper (None: the queue is not before a red
    light)."""
    beyond = [line for line in lines if line.s_m >= body_s_m]
    if not beyond:
        return None
    first = min(beyond, key=lambda line: line.s_m)
    return first.cycle_s if first.holds and first.s_m - front_s_m <= QUEUE_REACH_M else None


def waited_for_light(standing: Standing | None, stood_s: float) -> bool:
    """Did a run stand at a red light, or in the queue before one, for less than the
    light's cycle when it ended (too short to tell whether it was stuck)?"""
    return (standing is not None and standing.what in (RED_LIGHT, QUEUE)
            and standing.cycle_s is not None and stood_s < standing.cycle_s)


def lines_at_end(stops: Sequence, signals: Sequence[str], t_s: np.ndarray,
                 cycles_s: dict[str, float]) -> list[Line]:
    """The route's stop lines (``RouteStop`` s) as the car stood before them at the
    last step: the lights from the trace's ``signals`` (one character per stop, each
    step), holding the car if they did at the end or within :data:`START_UP_S`
    before; ``cycles_s``: each light's cycle."""
    recent = signals[int(np.searchsorted(t_s, t_s[-1] - START_UP_S - 1e-9)):]
    lines = []
    for k, stop in enumerate(stops):
        states = [row[k] for row in recent if k < len(row)]
        give_way = stop.give_way or (bool(states) and link_signal(states[-1])[1])
        holds = any(holds_the_car(state) for state in states)
        cycle_s = cycles_s.get(stop.tl) if stop.tl is not None else None
        lines.append(Line(stop.s_m, holds, give_way, cycle_s))
    return lines


def body_extents_sd(to_frenet, boxes: np.ndarray) -> np.ndarray:
    """Boxes ``[cx, cy, yaw, length, width]`` (K, 5) as extents along and across the
    road (K, 4) ``[s_from, s_to, d_from, d_to]`` of their corners (``to_frenet``: the
    road's). A box whose corners land farther apart along the road than its size
    allows (:data:`SPREAD_TOLERANCE_M`: they project on parts of a route that winds
    back past it) is not along the road there: all NaN."""
    boxes = as_boxes(boxes)
    corners = box_corners(boxes)
    if not len(corners):
        return np.empty((0, 4))
    s_m, d_m = to_frenet(corners.reshape(-1, 2))
    s_m, d_m = np.asarray(s_m).reshape(-1, 4), np.asarray(d_m).reshape(-1, 4)
    extents = np.column_stack([s_m.min(axis=1), s_m.max(axis=1), d_m.min(axis=1),
                               d_m.max(axis=1)])
    diagonal_m = np.hypot(boxes[:, 3], boxes[:, 4])
    extents[extents[:, 1] - extents[:, 0] > 2 * diagonal_m + SPREAD_TOLERANCE_M] = np.nan
    return extents


def body_kind(vehicle_class: str, obstacle: bool) -> str:
    """A body's kind here: a person (any pedestrian), else an obstacle or traffic."""
    if vehicle_class == PEDESTRIAN:
        return PERSON
    return OBSTACLE if obstacle else QUEUE


def standing_at_end(road, ego_box: np.ndarray, traffic_boxes: np.ndarray,
                    traffic_classes: Sequence[str], obstacle_boxes: np.ndarray,
                    obstacle_classes: Sequence[str], signals: Sequence[str], t_s: np.ndarray,
                    cycles_s: dict[str, float]) -> Standing:
    """:func:`stood_for` of a run's last step on ``road`` (a ``RoadGeometry``): the
    ego's body box there, the traffic's and the obstacles' boxes and classes, the
    trace's ``signals`` and times, each light's cycle."""
    ego = body_extents_sd(road.to_frenet, ego_box)[0]
    boxes = np.vstack([np.asarray(obstacle_boxes, float).reshape(-1, 5),
                       np.asarray(traffic_boxes, float).reshape(-1, 5)])
    kinds = np.array([body_kind(c, True) for c in obstacle_classes]
                     + [body_kind(c, False) for c in traffic_classes], dtype=object)
    # only what could be within reach: the rest may project anywhere on a winding route
    near = (np.hypot(*(boxes[:, :2] - np.asarray(ego_box)[:2]).T)
            <= REACH_M + np.hypot(boxes[:, 3], boxes[:, 4]) + float(np.asarray(ego_box)[3]))
    return stood_for(float(ego[1]), (float(ego[2]), float(ego[3])),
                     body_extents_sd(road.to_frenet, boxes[near]), list(kinds[near]),
                     lines_at_end(road.stops(), signals, t_s, cycles_s),
                     [(c.near_s_m, c.far_s_m) for c in road.crosswalks()])


#: what a run that ended standing stood for, in words
STOOD_FOR_WORDS = {RED_LIGHT: "at a red light", QUEUE: "behind a vehicle",
                   GIVE_WAY: "at a line where it gives way", OBSTACLE: "before an obstacle",
                   PERSON: "before a person", CROSSING: "at a pedestrian crossing"}


def stood_for_text(value: Mapping) -> str:
    """Where a run that ended standing stood (its row's ``stood_for*``), in words: ``at
    a red light 1.5 m ahead``, ``behind a vehicle 4.0 m ahead (a queue before a red
    light)``, ``with nothing within 30 m ahead``; empty when it ended moving or the
    results do not say."""
    what = value.get(RowCol.stood_for)
    if what is None:
        return ""
    if what == NOTHING:
        return f"with nothing within {REACH_M:.0f} m ahead"
    gap = value.get(RowCol.stood_for_gap_m)
    where = "" if gap is None else (" on it" if gap < 0.05 else f" {gap:.1f} m ahead")
    queue = (" (a queue before a red light)"
             if what == QUEUE and value.get(RowCol.stood_for_cycle_s) is not None else "")
    return f"{STOOD_FOR_WORDS[what]}{where}{queue}"
