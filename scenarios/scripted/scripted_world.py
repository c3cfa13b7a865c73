"""The scripted world backend: a world without a simulator, for testing controllers
and the pipelines around a run (sweeps, resume, reports, replays) fast.

The spec's obstacles stand where the spec puts them (:func:`obstacle_boxes`). Its
traffic is a script, not a simulation: in each lane no obstacle reaches into, a car
(a box :data:`CAR_SIZE_M`) enters at the road's start every ``3600 /
traffic.flow_vph_per_lane`` s and drives along the lane's centre to its end at the
lane's constant speed (``traffic.speed_mean_mps`` times a factor ~ N(1,
``speed_dev``)), each lane's speed and phase drawn from the traffic seed; with
``traffic.warm_up_s`` the road starts full, as the flow leaves it. The cars never
react: not to the ego, not to each other (a lane's cars keep their spacing); those
in the ego's way where it enters are taken off (:func:`in_start_zone`), as on the
other backends. Same spec, same seed: the same world, step for step. No warm
state, no traffic lights, no world's witness (:meth:`ScriptedWorld.twin` is None).
"""

from __future__ import annotations

import numpy as np

from scenarios.common.errors import SdcError
from scenarios.scene.road_geometry import RoadGeometry
from scenarios.scene.snapshot import (
    NO_BOXES,
    Pose,
    Snapshot,
    in_start_zone,
    obstacle_boxes,
    passenger_classes,
    sensing_radius_m,
    within_m,
)
from scenarios.spec.scenario_spec import SPEED_FACTOR_BOUNDS, ScenarioSpec
from scenarios.spec.world_seating import traffic_seed

#: a scripted car's body: SUMO's default passenger car [m]
CAR_SIZE_M = (5.0, 1.8)


class ScriptedWorld:
    """One run of a scenario in a scripted world: boxes where the spec and its
    traffic script put them, the ego pushed in each step (each slot of ``egos`` its
    own ego; they do not see each other)."""

    backend = "scripted"
    warm_state_key = None  # nothing to warm up: the traffic flows from the first step

    def __init__(self, spec: ScenarioSpec, road: RoadGeometry):
        self.spec = spec
        self.road = road
        self.signal_cycles_s: dict[str, float] = {}  # no lights
        self._obstacle_boxes = obstacle_boxes(spec, road)
        self._radius_m = sensing_radius_m(spec)
        self._step_s = spec.scenario.step_s
        self._egos: dict[int, np.ndarray] = {}  # slot -> its last box
        self._steps = 0
        self._lane_mps = np.zeros(road.lanes)
        self._next_entry_s = np.full(road.lanes, np.inf)  # when each lane's next car enters
        self._period_s = np.inf
        #: each car's distance along its lane [m] and its lane
        self._u_m, self._lane = np.zeros(0), np.zeros(0, int)

    @property
    def t_s(self) -> float:
        """The world's clock: its steps so far [s]."""
        return self._steps * self._step_s

    def _open_lanes(self) -> list[int]:
        """The lanes no obstacle's body reaches into (scripted cars would drive through it)."""
        road, boxes = self.road, self._obstacle_boxes
        _, d_m = road.to_frenet(boxes[:, :2]) if len(boxes) else (None, np.zeros(0))
        return [lane for lane in range(road.lanes)
                if not np.any(np.abs(d_m - road.lane_center_d_m(lane))
                              < (road.lane_width_m + boxes[:, 4]) / 2)]

    def start_all(self, egos: dict[int, Pose]) -> dict[int, Snapshot]:
        """Lay out the traffic, put each ego (slot -> its box and speed) where it starts,
        advance one step; each one's first snapshot."""
        traffic = self.spec.traffic
        if traffic.flow_vph_per_lane > 0:
            rng = np.random.default_rng(traffic_seed(self.spec))
            self._period_s = 3600.0 / traffic.flow_vph_per_lane
            for lane in self._open_lanes():
                factor = np.clip(1.0 + traffic.speed_dev * rng.standard_normal(),
                                 *SPEED_FACTOR_BOUNDS)
                self._lane_mps[lane] = speed_mps = traffic.speed_mean_mps * float(factor)
                spacing_m = speed_mps * self._period_s
                phase_m = float(rng.uniform(0.0, spacing_m))
                # warmed up: the flow already along the road; else it enters from now
                u_m = (np.arange(phase_m, self._lane_length_m(lane), spacing_m)
                       if traffic.warm_up_s > 0 else np.zeros(0))
                self._u_m = np.concatenate([self._u_m, u_m])
                self._lane = np.concatenate([self._lane, np.full(len(u_m), lane)])
                self._next_entry_s[lane] = (spacing_m - phase_m) / speed_mps
            boxes = self._boxes()
            ahead = in_start_zone(self.spec, self.road, boxes[:, :2], boxes[:, 3],
                                  self._lane_mps[self._lane])
            self._u_m, self._lane = self._u_m[~ahead], self._lane[~ahead]
        return self.step_all(egos)

    def start(self, ego_box: np.ndarray, ego_speed_mps: float) -> Snapshot:
        """:meth:`start_all` of a world of one ego."""
        return self.start_all({0: (ego_box, ego_speed_mps)})[0]

    def step_all(self, egos: dict[int, Pose]) -> dict[int, Snapshot]:
        """Place each ego still in the world (slot -> its box and speed), advance one
        step; each one's new snapshot."""
        for slot, pose in egos.items():
            if pose is None:
                raise SdcError("the scripted world has no driver of its own: push every "
                               "ego a box and a speed")
            self._egos[slot] = np.asarray(pose[0], float)
        self._advance()
        boxes = self._boxes()
        speeds = self._lane_mps[self._lane]
        snapshots = {}
        for slot, ego_box in self._egos.items():
            keep = within_m(boxes, ego_box[:2], self._radius_m)
            snapshots[slot] = Snapshot(self.t_s, boxes[keep], self._obstacle_boxes,
                                       speeds[keep], passenger_classes(int(keep.sum())))
        return snapshots

    def step(self, ego_box: np.ndarray, ego_speed_mps: float) -> Snapshot:
        """:meth:`step_all` of a world of one ego."""
        return self.step_all({0: (ego_box, ego_speed_mps)})[0]

    def _advance(self) -> None:
        """One step of the script: every car moves on, cars enter and leave."""
        self._steps += 1
        if not np.isfinite(self._period_s):
            return
        self._u_m = self._u_m + self._lane_mps[self._lane] * self._step_s
        for lane in np.flatnonzero(np.isfinite(self._next_entry_s)):
            while self._next_entry_s[lane] <= self.t_s + 1e-9:
                u_m = self._lane_mps[lane] * (self.t_s - self._next_entry_s[lane])
                self._u_m = np.append(self._u_m, u_m)
                self._lane = np.append(self._lane, lane)
                self._next_entry_s[lane] += self._period_s
        on_road = self._u_m <= self._lane_length_m(self._lane)
        self._u_m, self._lane = self._u_m[on_road], self._lane[on_road]

    def _lane_length_m(self, lane):
        """How long lane(s) ``lane`` are: on a curve, an inner lane is shorter [m]."""
        road = self.road
        return road.length_m * (1.0 - road.curvature_1pm * road.lane_center_d_m(lane))

    def _boxes(self) -> np.ndarray:
        """The cars' boxes, each at its distance along its lane's centre."""
        if not len(self._u_m):
            return NO_BOXES
        road = self.road
        d_m = road.lane_center_d_m(self._lane)
        s_m = self._u_m / (1.0 - road.curvature_1pm * d_m)  # along the road's centre line
        size = np.broadcast_to(CAR_SIZE_M, (len(s_m), 2))
        return np.column_stack([road.xy_at(s_m, d_m), road.heading_at(s_m), size])

    def leave(self, slot: int) -> None:
        """The run of the ego in ``slot`` has ended; the world goes on for the others."""
        self._egos.pop(slot, None)

    def vehicle_count(self) -> int:
        """Traffic cars on the whole road."""
        return len(self._u_m)

    def witness(self) -> None:
        """None: its traffic is what the script says, no model to judge it by."""
        return None

    def twin(self) -> None:
        """No witness replays this world: its traffic is what the script says."""
        return None

    def close(self) -> None:
        self._egos = {}

    def __enter__(self) -> ScriptedWorld:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
