"""Is the world one world? Overlaps between bodies other than the ego, from a trace.

In a consistent world no two bodies overlap: SUMO's traffic sees every body where it
stands (``scenarios/scene/traffic_model.py``). :func:`world_overlaps` counts the steps in
which a traffic vehicle or person overlaps another one or an obstacle, among the
bodies a trace holds (those within the sensing radius). It must read 0; anything
else is a world that made something up (traffic driving through an obstacle, through
another car during a lane change, or through a person). People overlapping people are
not counted: SUMO's pedestrians squeeze past each other in a crowd (its striping
model), which is no vehicle through anybody.
"""

from __future__ import annotations

import numpy as np

from scenarios.scene.boxes import as_boxes
from scenarios.spec.bodies import are_people

#: a collision's ``collision_role`` (sdc.car.collision) as the report and the CLI say it
ROLE_TEXT = {"ran_into": "ran into", "was_hit": "was hit"}
#: bodies overlapping by less than this are touching, not through each other [m]
OVERLAP_TOLERANCE_M = 0.01


def _axes(yaw_rad: np.ndarray) -> np.ndarray:
    """(M, 2, 2): each box's length and width axes."""
    c, s = np.cos(yaw_rad), np.sin(yaw_rad)
    return np.stack([np.stack([c, s], -1), np.stack([-s, c], -1)], axis=-2)


def _shadows_m(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """On each of the 4 axes of the separating-axis test (the two boxes' length and
    width axes), for each pair ``a[k]``, ``b[k]``: the distance between the centres'
    shadows and the sum of the two boxes' half shadows, each (M, 4) [m]."""
    a, b = as_boxes(a), as_boxes(b)
    axes_a, axes_b = _axes(a[:, 2]), _axes(b[:, 2])
    test = np.concatenate([axes_a, axes_b], axis=1)  # (M, 4, 2)
    radius_a = np.einsum("mak,mk->ma", np.abs(test @ axes_a.transpose(0, 2, 1)), a[:, 3:5] / 2)
    radius_b = np.einsum("mak,mk->ma", np.abs(test @ axes_b.transpose(0, 2, 1)), b[:, 3:5] / 2)
    gap = np.abs(np.einsum("mad,md->ma", test, b[:, :2] - a[:, :2]))
    return gap, radius_a + radius_b


def pairs_overlap(a: np.ndarray, b: np.ndarray, tolerance_m: float = OVERLAP_TOLERANCE_M
                  ) -> np.ndarray:
    """(M,) bool: does box ``a[k]`` overlap box ``b[k]`` by more than ``tolerance_m``
    along every separating axis (the separating-axis theorem, 4 axes a pair)?"""
    gap, reach = _shadows_m(a, b)
    return np.all(gap < reach - tolerance_m, axis=1)


def overlap_depth_m(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(M,) how deep box ``a[k]`` and box ``b[k]`` are inside each other: the least
    overlap of their shadows over the 4 axes of :func:`pairs_overlap`, which for two
    rectangles is the shortest distance one must move to part them (their penetration
    depth) [m]; negative: apart."""
    gap, reach = _shadows_m(a, b)
    return np.min(reach - gap, axis=1)


def _overlapping_pairs(bodies: np.ndarray, traffic: int, people: np.ndarray,
                       owners: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Of (T, M, 5) boxes per step (NaN rows: none), the first ``traffic`` of each step
    traffic and the rest obstacles, ``people`` (T, M) those that are persons, ``owners``
    (T, M) which body each is of: the overlapping pairs of boxes of two bodies that
    hold a traffic vehicle or person, and not two persons, as (step, box, box) index
    arrays."""
    reach = np.hypot(bodies[..., 3], bodies[..., 4]) / 2
    d = bodies[:, :traffic, None, :2] - bodies[:, None, :, :2]
    touch = reach[:, :traffic, None] + reach[:, None, :]
    near = (d[..., 0] ** 2 + d[..., 1] ** 2) < touch**2  # NaN: False
    near &= np.triu(np.ones(near.shape[1:], bool), k=1)  # each pair once
    near &= ~(people[:, :traffic, None] & people[:, None, :])
    near &= owners[:, :traffic, None] != owners[:, None, :]  # a body's own pieces touch
    t, i, j = np.nonzero(near)
    hits = pairs_overlap(bodies[t, i], bodies[t, j])
    return t[hits], i[hits], j[hits]


#: pairs looked at in one numpy pass (steps are taken in chunks of about this many)
_PAIRS_PER_PASS = 1 << 20


def box_owners(count: int, bodies, obstacles: int) -> np.ndarray:
    """Which body each of ``count`` traffic boxes (``bodies``: their labels, or
    None/empty: each its own) and then ``obstacles`` obstacle boxes is of."""
    own = (np.arange(count) if bodies is None or len(bodies) == 0
           else np.asarray(bodies, np.intp))
    return np.concatenate([own, count + np.arange(obstacles)])


def overlap_steps(traffic_rows: list[np.ndarray], obstacle_boxes: np.ndarray,
                  traffic_classes: list[list[str]] | None = None,
                  obstacle_classes: tuple[str | None, ...] = (),
                  traffic_bodies: list[list[int]] | None = None) -> np.ndarray:
    """The steps of a trace (``traffic`` rows: N x 5 boxes, flattened; ``traffic_classes``
    their classes, row by row; ``traffic_bodies`` which body each box is of, as
    :class:`analysis.measures.trace_file.Trace` holds them) in which a traffic vehicle or
    person overlaps another one or an obstacle (``obstacle_classes``: theirs,
    ``pedestrian`` for a standing person), two persons aside (two obstacles on one
    another are the spec's doing, not the world's): their indices, ascending."""
    rows = [np.asarray(row, float).reshape(-1, 5) for row in traffic_rows]
    most = max((len(r) for r in rows), default=0)
    if most == 0:
        return np.zeros(0, np.intp)
    obstacles = as_boxes(obstacle_boxes)
    per_step = most * (most + len(obstacles))
    chunk = max(1, _PAIRS_PER_PASS // per_step)
    steps = []
    for start in range(0, len(rows), chunk):
        part = rows[start : start + chunk]
        bodies = np.full((len(part), most + len(obstacles), 5), np.nan)
        people = np.zeros(bodies.shape[:2], bool)
        owners = np.tile(np.arange(bodies.shape[1]), (len(part), 1))
        for k, row in enumerate(part):
            bodies[k, : len(row)] = row
            if traffic_classes is not None:
                people[k, : len(row)] = are_people(traffic_classes[start + k])
            if traffic_bodies:
                owners[k, : len(row)] = box_owners(len(row), traffic_bodies[start + k], 0)
        bodies[:, most:] = obstacles
        people[:, most:] = are_people(obstacle_classes or [None] * len(obstacles))
        steps.append(start + np.unique(_overlapping_pairs(bodies, most, people, owners)[0]))
    return np.concatenate(steps)


def world_overlaps(traffic_rows: list[np.ndarray], obstacle_boxes: np.ndarray,
                   traffic_classes: list[list[str]] | None = None,
                   obstacle_classes: tuple[str | None, ...] = (),
                   traffic_bodies: list[list[int]] | None = None) -> int:
    """How many steps of a trace :func:`overlap_steps` finds."""
    return len(overlap_steps(traffic_rows, obstacle_boxes, traffic_classes, obstacle_classes,
                             traffic_bodies))


def overlapping_pairs(traffic_boxes: np.ndarray, obstacle_boxes: np.ndarray,
                      traffic_classes, obstacle_classes: tuple[str | None, ...] = (),
                      traffic_bodies: np.ndarray | None = None) -> list[tuple[int, int]]:
    """One step's overlapping pairs, as :func:`overlap_steps` finds them: (traffic row,
    traffic row or ``len(traffic_boxes)`` + obstacle index)."""
    traffic, obstacles = as_boxes(traffic_boxes), as_boxes(obstacle_boxes)
    bodies = np.vstack([traffic, obstacles])[None]
    people = are_people([*traffic_classes, *(obstacle_classes or [None] * len(obstacles))])
    owners = box_owners(len(traffic), traffic_bodies, len(obstacles))
    _, i, j = _overlapping_pairs(bodies, len(traffic), people[None], owners[None])
    return list(zip(i.tolist(), j.tolist(), strict=True))
