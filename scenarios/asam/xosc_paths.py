"""Reading back what :mod:`scenarios.asam.xosc_export` writes: each entity's
trajectory, where each entity placed in ``Init`` stands, when bodies are added and
deleted, and when the scenario stops, with ``scenariogeneration``'s parser
(``xosc.ParseOpenScenario``, which also checks the file against ASAM's schema).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from scenarios.asam.xosc_export import parse_xosc

#: an entity's path: its times [s] (N,), positions (N, 2) [m], headings (N,) [rad]
Path3 = tuple[np.ndarray, np.ndarray, np.ndarray]


@dataclass(frozen=True)
class ScenarioRead:
    """``trajectories``: name -> :data:`Path3`, every ``FollowTrajectoryAction``'s
    polyline; ``placed``: name -> (x, y, heading) of every ``Init`` teleport (the ego,
    the bodies there from the start, the obstacles); ``standing``: the entities placed
    that follow no trajectory (the obstacles); ``added`` and ``deleted``: name -> the
    time [s] its ``AddEntityAction`` and ``DeleteEntityAction`` are triggered after;
    ``stop_s``: the stop trigger's time [s]."""

    trajectories: dict[str, Path3]
    placed: dict[str, tuple[float, float, float]]
    added: dict[str, float]
    deleted: dict[str, float]
    stop_s: float

    @property
    def standing(self) -> dict[str, tuple[float, float, float]]:
        return {n: p for n, p in self.placed.items() if n not in self.trajectories}


def read_trajectories(path: Path) -> dict[str, Path3]:
    """Every entity's trajectory in the ``.xosc`` at ``path``: name -> (times_s, xy,
    heading)."""
    return read_export(path).trajectories


def read_export(path: Path) -> ScenarioRead:
    """What the ``.xosc`` at ``path`` (as :func:`~scenarios.asam.xosc_export.write_xosc`
    writes it) says of its entities and its end."""
    from scenariogeneration import xosc

    scenario = parse_xosc(Path(path))
    placed = {}
    for name, actions in scenario.storyboard.init.initactions.items():
        for action in actions:
            if isinstance(action, xosc.TeleportAction):
                placed[name] = _xyh(action.position)
    trajectories, added, deleted = {}, {}, {}
    for story in scenario.storyboard.stories:
        for act in story.acts:
            for group in act.maneuvergroup:
                actor = group.actors.actors[0].entity  # a body's group: the body alone
                for maneuver in group.maneuvers:
                    for event in maneuver.events:
                        t_s = _time(event.trigger)
                        for action in event.action:
                            _read_action(actor, action.action, t_s, trajectories, added,
                                         deleted)
    return ScenarioRead(trajectories, placed, added, deleted,
                        _time(scenario.storyboard.stoptrigger))


def _read_action(actor: str, action, t_s: float, trajectories: dict, added: dict,
                 deleted: dict) -> None:
    from scenariogeneration import xosc

    if isinstance(action, xosc.FollowTrajectoryAction):
        polyline = action.trajectory.shapes
        xyh = np.array([_xyh(p) for p in polyline.positions], float).reshape(-1, 3)
        trajectories[actor] = (np.array(polyline.time, float), xyh[:, :2], xyh[:, 2])
    elif isinstance(action, xosc.AddEntityAction):
        added[action.entityref] = t_s
    elif isinstance(action, xosc.DeleteEntityAction):
        deleted[action.entityref] = t_s


def _xyh(position) -> tuple[float, float, float]:
    return float(position.x), float(position.y), float(position.h or 0.0)


def _time(trigger) -> float:
    """The time of a trigger of one ``SimulationTimeCondition`` (the first found)."""
    from scenariogeneration import xosc

    for group in trigger.conditiongroups:
        for condition in group.conditions:
            value = getattr(condition, "valuecondition", None)
            if isinstance(value, xosc.SimulationTimeCondition):
                return float(value.value)
    raise ValueError("a trigger without a simulation time condition")
